// Tap weights of the dual blur: src/methods/mcguire/blur_weights.hpp, formula for formula.
#include "dofkit.glsl"

const float kGaussianTable[7] = float[7](0.13425804976814, 0.12815541114232, 0.11143948794984, 0.08822292796029,
                                         0.06352050813141, 0.04153263993208, 0.0);
const float kDiscTable[7] = float[7](1.00, 1.00, 0.90, 0.75, 0.60, 0.50, 0.00);

bool in_near(float r) { return r > 0.25; }

// Far/focus weight of tap B (offset d px, radius r_b) for a centre of radius r_a.
float far_weight(float d, float r_a, float r_b) {
  if (in_near(r_b)) return 0.0;
  precise float abs_b = abs(r_b);
  if (p.variant == kG3d) {
    precise float inv_b = 1.0 / (0.01 + abs_b);
    precise float w = exp(-2.0 * d * d * inv_b * inv_b);
    if (p.far_occlusion != 0) w *= saturate(max(r_b - r_a + 1.0, (0.01 - r_a) * inv_b));
    return w;
  }
  const bool book = p.variant == kBook;
  // The table index must be the CPU's: floor of the correctly rounded quotient (GPU
  // division may be up to 2.5 ulp off; one residual step makes it correctly rounded).
  precise float num = 5.0 * abs(d);
  precise float den = 0.001 + (book ? 0.5 : 0.8) * abs_b;
  precise float t = div_rn(num, den);
  const int idx = t >= 6.0 ? 6 : int(t);
  precise float w = book ? kGaussianTable[idx] : kDiscTable[idx];
  if (p.far_occlusion != 0) w *= saturate(abs(r_a) - abs_b + 1.5);
  return w;
}

// Near coverage of tap B in the horizontal pass.
float near_alpha_horizontal(float d, float r_b) {
  if (p.variant == kG3d) {
    precise float a = saturate(r_b * p.inv_near);
    return a * a;
  }
  if (!(abs(d) <= r_b)) return 0.0;
  precise float a = p.near_alpha_code != 0 ? saturate(4.0 * r_b * p.inv_near) : min(1.0, r_b * p.inv_near);
  a *= a;
  return a * a;
}

// Near-field box weight at offset d: [|d| < R_near], or exp(-(d/R_near)^2) in g3d.
float near_box(float d) {
  if (p.variant == kG3d) {
    precise float t = d * p.inv_near;
    return p.r_near > 0.0 ? exp(-t * t) : 0.0;
  }
  return abs(d) < p.r_near ? 1.0 : 0.0;
}
