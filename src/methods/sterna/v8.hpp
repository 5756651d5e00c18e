// The 8-float vector helpers shared by sterna's fast passes (GCC/clang vector extensions;
// each fast file compiles its hot functions for several targets with target_clones, and these
// helpers are always inlined into them). Internal linkage per file on purpose: every
// translation unit gets its own copy, compiled for the target of the function it lands in.
#pragma once
#include <cstdint>
#include <cstring>
#include <xmmintrin.h>

namespace dofkit::detail::sterna::fast {
namespace {

typedef float V8 __attribute__((vector_size(32)));
typedef int I8 __attribute__((vector_size(32)));

__attribute__((always_inline)) inline V8 load8(const float* p) {
  V8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
__attribute__((always_inline)) inline void store8(float* p, V8 v) { std::memcpy(p, &v, sizeof v); }
__attribute__((always_inline)) inline V8 splat(float f) { return V8{f, f, f, f, f, f, f, f}; }
__attribute__((always_inline)) inline I8 splat_i(int v) { return I8{v, v, v, v, v, v, v, v}; }
// |v| by clearing the sign bit, exactly what std::abs does to a float.
__attribute__((always_inline)) inline V8 vabs(V8 v) {
  return reinterpret_cast<V8>(reinterpret_cast<I8>(v) & splat_i(0x7fffffff));
}
// Whether any lane of a comparison mask (lanes 0 or all ones) is set: the two halves or-ed,
// then the SSE sign-bit mask (movmskps is in every x86-64 target, so each clone gets its own
// form of it; extracting the four 64-bit words took eight instructions).
__attribute__((always_inline)) inline bool any(I8 m) {
  typedef int I4 __attribute__((vector_size(16)));
  const I4 lo = __builtin_shufflevector(m, m, 0, 1, 2, 3), hi = __builtin_shufflevector(m, m, 4, 5, 6, 7);
  return _mm_movemask_ps(reinterpret_cast<__m128>(lo | hi)) != 0;
}

}  // namespace
}  // namespace dofkit::detail::sterna::fast
