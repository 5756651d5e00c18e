// Shared by every dofkit compute shader. Buffers are planar float arrays like dofkit::Image:
// plane c of a w × h image starts at c·w·h, row y of it at c·w·h + y·w.
//
// Precision: results are compared with the CPU passes (tests/gpu/): variables marked
// `precise` keep the CPU's operation order and rounding (no multiply-add fused into an FMA,
// which drivers are otherwise free to do), so that a comparison such as a table index or a
// threshold decides the same way on both sides.
#ifndef DOFKIT_GLSL
#define DOFKIT_GLSL

// 2-D passes: 16 × 8 invocations per workgroup (the host dispatches ceil(w/16) × ceil(h/8)).
#define DOFKIT_LOCAL_2D layout(local_size_x = 16, local_size_y = 8, local_size_z = 1) in;

// a / b correctly rounded (IEEE), as the CPU divides: GPU division may be up to 2.5 ulp off,
// and one residual step with a fused multiply-add recovers the rounded quotient. Where the
// step is undefined (b or the quotient infinite: 0·inf) the quotient stands as it is.
float div_rn(float a, float b) {
  precise float q = a / b;
  precise float r = fma(-q, b, a);
  precise float res = fma(r, 1.0 / b, q);
  return isnan(res) ? q : res;
}

int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }
float saturate(float x) { return clamp(x, 0.0, 1.0); }

#endif
