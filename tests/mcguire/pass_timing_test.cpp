// Per-pass timing harness for the fast demo path at 1920x1080 (not part of the normal run; no
// assertions on time). It times P2, P3 and P4 on the `dofkit bench` frame without the
// renderer's own per-frame work (colour check, CoC from depth), which is what
// docs/performance_mcguire.md splits. Run with
//   test_mcguire --gtest_also_run_disabled_tests --gtest_filter=*PassTiming*
// (MCGUIRE_TIMING_ITERS, default 12; MCGUIRE_TIMING_THREADS, default 1). It also prints a
// checksum of the composite output (bit-identity checks between builds) and, per pass, the
// process CPU time beside the wall time (on a shared machine the CPU time of a one-thread
// run is the steadier figure). Under
// `valgrind --tool=callgrind` it gives the per-pass instruction counts quoted in the note.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <initializer_list>
#include <vector>

#include "core/parallel.hpp"
#include "dofkit/coc.hpp"
#include "methods/mcguire/fast.hpp"
#include "methods/mcguire/mcguire.hpp"
#include "scene/bench_frame.hpp"

using namespace dofkit;
namespace mg = dofkit::detail::mcguire;

namespace {

constexpr int W = 1920, H = 1080;

/// The bench frame, its CoC, the iteration and thread counts from the environment and the
/// radii-derived constants render_mcguire's read_setup computes for it (the variant-specific
/// ones are set by each harness).
struct BenchSetup {
  Frame fr = scene::bench_frame(W, H);
  Image coc = compute_coc(fr.depth, scene::bench_camera(W));
  int iters, threads;
  mg::Constants k;
  explicit BenchSetup(int default_iters) {
    const char* it_env = std::getenv("MCGUIRE_TIMING_ITERS");
    const char* th_env = std::getenv("MCGUIRE_TIMING_THREADS");
    iters = std::max(1, it_env ? std::atoi(it_env) : default_iters);
    threads = std::max(1, th_env ? std::atoi(th_env) : 1);
    float max_near = 0, max_far = 0;
    for (float r : coc.data()) {
      max_near = std::max(max_near, r);
      max_far = std::max(max_far, -r);
    }
    k.r_max = static_cast<int>(std::ceil(std::max(max_near, max_far)));
    k.r_near = std::ceil(max_near);
    k.inv_near = 1.0f / std::max(k.r_near, 1e-4f);
    k.far_rescale = static_cast<float>(k.r_max) / std::max(max_far, 1e-4f);
  }
};

/// Process CPU time in ms. On the shared machine the wall time of a pass also counts the
/// time other processes hold the core; the CPU time of a one-thread run does not.
double cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

/// Prints an FNV-1a checksum of the output's bits (changes that should keep the arithmetic
/// can be checked for bit-identical output between builds) and each pass's median and
/// minimum time, wall (t) and process CPU (cpu).
void report(const Image& out, std::vector<double>* t, std::vector<double>* cpu,
            std::initializer_list<const char*> names, const char* note) {
  std::uint64_t fnv = 1469598103934665603ull;
  for (float v : out.data()) {
    std::uint32_t b;
    std::memcpy(&b, &v, 4);
    fnv = (fnv ^ b) * 1099511628211ull;
  }
  std::printf("output checksum %016llx\n", static_cast<unsigned long long>(fnv));
  int i = 0;
  for (const char* name : names) {
    std::vector<double>& v = t[i];
    std::vector<double>& c = cpu[i++];
    std::sort(v.begin(), v.end());
    std::sort(c.begin(), c.end());
    std::printf("%-14s median %8.2f ms  min %8.2f ms  cpu median %8.2f ms  (%s)\n", name, v[v.size() / 2], v[0],
                c[c.size() / 2], note);
  }
}

}  // namespace

TEST(McguirePassTiming, DISABLED_Demo1080p) {
  BenchSetup st(12);
  const Frame& fr = st.fr;
  const Image& coc = st.coc;
  const int iters = st.iters, threads = st.threads;
  mg::Constants& k = st.k;
  k.variant = mg::Variant::demo;
  k.f = 4;
  k.coverage_boost = 1.0f;
  k.double_coc = true;
  detail::Workspace ws;
  Image tb, tn, blur, near, out(W, H, 4);
  std::vector<int> near_span(2 * H);
  const mg::Rect src{0, 0, W, H};
  std::vector<double> t[3], cpu[3];
  core::with_threads(threads, [&] {
    for (int it = 0; it < iters; ++it) {
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = cpu_ms();
      mg::blur_horizontal_fast(fr.color, coc, src, k, 0, W / 4, tb, tn, ws, nullptr, near_span.data());
      const auto t1 = std::chrono::steady_clock::now();
      const double c1 = cpu_ms();
      mg::blur_vertical_fast(tb, tn, k, 0, H / 4, blur, near, ws, near_span.data());
      const auto t2 = std::chrono::steady_clock::now();
      const double c2 = cpu_ms();
      mg::composite_fast(fr.color, coc, src, 0, 0, blur, near, k, src, out, ws);
      const auto t3 = std::chrono::steady_clock::now();
      const double c3 = cpu_ms();
      if (it == 0 && iters > 1) continue;  // first frame allocates the workspace
      t[0].push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      t[1].push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
      t[2].push_back(std::chrono::duration<double, std::milli>(t3 - t2).count());
      cpu[0].push_back(c1 - c0);
      cpu[1].push_back(c2 - c1);
      cpu[2].push_back(c3 - c2);
    }
  });
  char note[64];
  std::snprintf(note, sizeof note, "%d threads, R_max %d", threads, k.r_max);
  report(out, t, cpu, {"P2 horizontal", "P3 vertical", "P4 composite"}, note);
}

// The same harness for variant=g3d (whose P2/P3 are blur.cpp's blur_horizontal /
// blur_vertical with the kernels of g3d_simd.cpp; P1 is pack_coc): times P1 pack, P2, P3
// and P4. Run with --gtest_filter=*PassTiming.DISABLED_G3d* (same environment variables;
// MCGUIRE_TIMING_IMPL=plain times the plain passes instead).
TEST(McguirePassTiming, DISABLED_G3d1080p) {
  const char* impl_env = std::getenv("MCGUIRE_TIMING_IMPL");
  const bool plain = impl_env && std::strcmp(impl_env, "plain") == 0;
  BenchSetup st(5);
  const Frame& fr = st.fr;
  const Image& coc = st.coc;
  const int iters = st.iters, threads = st.threads;
  mg::Constants& k = st.k;
  k.variant = mg::Variant::g3d;
  k.f = 2;
  k.coverage_boost = 1.5f;
  k.far_occlusion = true;
  k.g3d_fov_rad = static_cast<float>(40.0 * M_PI / 180.0);
  detail::Workspace ws;
  Image packed, tb, tn, blur, near, out(W, H, 4);
  const mg::Rect src{0, 0, W, H};
  std::vector<double> t[4], cpu[4];
  core::with_threads(threads, [&] {
    for (int it = 0; it < iters; ++it) {
      std::chrono::steady_clock::time_point tw[5];
      double tc[5];
      auto mark = [&](int i) {
        tw[i] = std::chrono::steady_clock::now();
        tc[i] = cpu_ms();
      };
      mark(0);
      mg::pack_coc(fr.color, coc, src, k, packed);
      mark(1);
      if (plain)
        mg::blur_horizontal_plain(packed, k, 0, W / 2, tb, tn);
      else
        mg::blur_horizontal(packed, k, 0, W / 2, tb, tn);
      mark(2);
      if (plain)
        mg::blur_vertical_plain(tb, tn, k, 0, H / 2, blur, near);
      else
        mg::blur_vertical(tb, tn, k, 0, H / 2, blur, near);
      mark(3);
      mg::composite_fast(fr.color, coc, src, 0, 0, blur, near, k, src, out, ws);
      mark(4);
      if (it == 0 && iters > 1) continue;  // first frame allocates
      for (int i = 0; i < 4; ++i) {
        t[i].push_back(std::chrono::duration<double, std::milli>(tw[i + 1] - tw[i]).count());
        cpu[i].push_back(tc[i + 1] - tc[i]);
      }
    }
  });
  char note[96];
  std::snprintf(note, sizeof note, "%d threads, R_max %d, R_near %.0f, %s", threads, k.r_max, k.r_near,
                plain ? "plain" : "fast");
  report(out, t, cpu, {"P1 pack", "P2 horizontal", "P3 vertical", "P4 composite"}, note);
}
