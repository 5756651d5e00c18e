// Pieces of `lens` that the plain and the fast path share, so that both compute the same model.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "dofkit/image.hpp"
#include "methods/lens/footprint.hpp"
#include "methods/lens/plan.hpp"

namespace dofkit::detail::lens {

inline float luminance(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

/// The block level of a highlight test: the smallest m with 2^m >= 2ρ.
inline int block_level(float rho) {
  int m = 0;
  while (static_cast<float>(1 << m) < 2.0f * rho && m < 24) ++m;
  return m;
}

/// Marks (ORs `bit` into flags[i]) the fragments of one layer that are scattered directly at
/// full resolution: radius below opt.direct_px(), or a highlight — luminance above
/// opt.highlight_abs and above opt.highlight_rel times the mean luminance of the aligned
/// block of side 2^m >= 2ρ that holds it (a source much brighter than the area its footprint
/// covers: reduced resolution would soften the rim of its bokeh). colour: rgba premultiplied,
/// times trans[i] where trans is given (hidden layers); coc: signed px. Rows in parallel; the
/// block sums are doubles added in a fixed order, so the flags never depend on the threads.
/// scratch: the block sums' storage (kept by the caller from frame to frame; may be null).
void mark_direct(const Image& colour, const Image& coc, const float* trans, const LensOptions& opt, std::uint8_t* flags,
                 std::uint8_t bit, std::vector<std::vector<double>>* scratch = nullptr);

/// The radius index (footprint.hpp) of the footprints of slice j's merged sources: its
/// anchor's radius at the slice's level (a source between two anchors is the hat-weighted mix
/// of the two slices' footprints). The box merge and the bilinear read-back blur by a
/// variance of 4^L / 4 px² per axis, so the footprint is shrunk to keep the total (a disc of
/// radius ρ has ρ² / 4).
inline int slice_radius_index(const SlicePlan& plan, int j) {
  const float rho = std::max(std::fabs(plan.anchor[j]), 0.5f);
  const float cell = static_cast<float>(1 << plan.level[j]);
  const float r = std::sqrt(std::max(rho * rho - cell * cell, 0.25f)) / cell;
  return radius_index(std::max(r, 0.5f));
}

/// clamp(lround(v), 0, hi) (the reference's, without the libm call).
inline int round_clamp(float v, int hi) {
  if (!(v >= 0.5f)) return 0;
  const float t = v + 0.5f;
  return t >= static_cast<float>(hi) ? hi : static_cast<int>(t);
}

/// Index of the frame pixel that the mirror-padded frame shows at coordinate v (the frame
/// has n pixels along that axis): … 1 0 | 0 1 … n−1 | n−1 n−2 …
inline int mirror(int v, int n) {
  while (v < 0 || v >= n) v = v < 0 ? -1 - v : 2 * n - 1 - v;
  return v;
}

/// The sources: one fragment per pixel (an RGB-D frame) or several front to back (deep /
/// multi-layer input; a missing fragment has alpha 0). Layer 0 is the visible surface.
struct Sources {
  std::vector<const Image*> colour, depth, coc;  // rgba premultiplied, z, signed CoC px
  int count() const { return static_cast<int>(colour.size()); }
  int width() const { return colour[0]->width(); }
  int height() const { return colour[0]->height(); }
};

/// Everything lens derives per fragment (index f·W·H + pixel).
struct Fragments {
  Fragments(const Sources& src, const SlicePlan& plan, const LensOptions& opt);
  const Sources& src;
  std::size_t n = 0;  // pixels per layer
  std::vector<int> slice;
  std::vector<float> t, inv_z, rho, sharp;
  /// The weight a fragment spreads: 1 for the visible one; for a hidden one its alpha times
  /// what the hidden fragments in front of it let through (the surface seen with the visible
  /// one peeled away; fragments not clearly behind the visible one — its back faces — are
  /// peeled with it). Its colour is scaled by the same transmittance (trans).
  std::vector<float> weight, trans;
  std::vector<std::uint8_t> exists, direct;
  float rho_max = 0.5f;
  int pad = 1;  // mirror padding of the frame, px: more than any footprint reaches
  float soft = 0.05f;
  float colour(std::size_t q, int ch) const { return src.colour[q / n]->plane(ch)[q % n] * trans[q]; }
};

/// A slice's depth as the fold sees it: the mean inverse depth of its members and the
/// sharpness max(|a| − 0.5, 0) of its anchor.
struct SliceDepth {
  SliceDepth(const SlicePlan& plan, const std::vector<double>& mass, const std::vector<double>& u_sum);
  std::vector<float> u, sharp;
};

/// A slice's cells at its level: the frame (frame_w × frame_h cells of 2^level px) plus
/// `margin` cells on every side for the mirror padding. Cell (X, Y) covers frame pixels
/// [(X − margin)·2^level, …) × [(Y − margin)·2^level, …).
struct Grid {
  int level = 1, margin = 0, frame_w = 0, frame_h = 0, w = 0, h = 0;
  Grid() = default;
  /// margin_cells: at least ceil(pad / 2^level) + 1 (every source the padding holds, and the
  /// bilinear read-back of the frame's edge pixels).
  Grid(int width, int height, int level_, int margin_cells)
      : level(level_),
        margin(margin_cells),
        frame_w((width + (1 << level_) - 1) >> level_),
        frame_h((height + (1 << level_) - 1) >> level_),
        w(frame_w + 2 * margin),
        h(frame_h + 2 * margin) {}
  static int min_margin(int pad_px, int level_) { return (pad_px + (1 << level_) - 1) / (1 << level_) + 1; }
  std::size_t cells() const { return static_cast<std::size_t>(w) * h; }
  std::size_t index(int x, int y) const { return static_cast<std::size_t>(y) * w + x; }
  bool covers(int x, int y) const {
    const int o = margin << level;
    return x + o >= 0 && y + o >= 0 && ((x + o) >> level) < w && ((y + o) >> level) < h;
  }
  std::size_t cell_of(int x, int y) const {
    const int o = margin << level;
    return index((x + o) >> level, (y + o) >> level);
  }
  /// Bilinear read-back position of frame pixel (x, y): cells (x0 … x0 + 1) × (y0 … y0 + 1)
  /// with weights of the second ax, ay.
  void locate(int x, int y, int& x0, int& y0, float& ax, float& ay) const {
    const float s = 1.0f / static_cast<float>(1 << level);
    const float fx = (static_cast<float>(x) + 0.5f) * s - 0.5f + static_cast<float>(margin);
    const float fy = (static_cast<float>(y) + 0.5f) * s - 0.5f + static_cast<float>(margin);
    x0 = std::min(static_cast<int>(fx), w - 2);
    y0 = std::min(static_cast<int>(fy), h - 2);
    ax = fx - static_cast<float>(x0);
    ay = fy - static_cast<float>(y0);
  }
};

/// What a source needs to know about itself for the per-pair rule.
struct Source {
  float u, sharp;
};

/// The receivers: layer 0's inverse depth, 1 / (softness · inverse depth) and sharpness.
struct Receivers {
  explicit Receivers(const Fragments& fr);
  explicit Receivers(std::size_t count) : inv_z(count), isu(count), sharp(count) {}
  std::vector<float> inv_z, isu, sharp;
};

/// The per-pair rule: a source (inverse depth u_q, sharpness) reaching receiver p with
/// weight wt carries c = (rgba, weight). A visible source: the reference's rule — in front
/// (soft in inverse depth) it goes to F (a[0…4]), else to B (a[5…9]), and from behind only in
/// proportion sharp_p / sharp_q. A hidden fragment: in front and on the receiver's surface
/// the same, behind it to the fill (a[10…14]) as far as it is sharper than the receiver (seen
/// through a blurred near surface; one blurred about as much is covered in the lens too).
inline void add_source_at(float up, float isup, float sp, bool hidden, const Source& s, float wt, const float* c,
                          float* a) {
  const float rel = (s.u - up) * isup;
  const float front = std::min(std::max(rel, 0.0f), 1.0f), behind = std::min(std::max(-rel, 0.0f), 1.0f);
  if (hidden) {
    const float show = sp > 0.0f ? behind * std::min(std::max(2.0f * (sp - s.sharp) / sp, 0.0f), 1.0f) : 0.0f;
    for (int ch = 0; ch < 5; ++ch) {
      a[ch] += wt * front * c[ch];
      a[5 + ch] += wt * (1.0f - front - behind) * c[ch];
      a[10 + ch] += wt * show * c[ch];
    }
    return;
  }
  const float pass = s.sharp > 0.0f ? std::min(sp / s.sharp, 1.0f) : (sp > 0.0f ? 1.0f : 0.0f);
  const float v = wt * (1.0f - behind * (1.0f - pass));
  for (int ch = 0; ch < 5; ++ch) {
    a[ch] += v * front * c[ch];
    a[5 + ch] += v * (1.0f - front) * c[ch];
  }
}
inline void add_source(const Receivers& rc, std::size_t p, bool hidden, const Source& s, float wt, const float* c,
                       float* a) {
  add_source_at(rc.inv_z[p], rc.isu[p], rc.sharp[p], hidden, s, wt, c, a);
}

/// The parts of composite() for the debug views: front = F · fs (what lies in front, composited
/// over), back = (B + m · fill) / (B weight + m) (the receiver's surface and behind), est = the
/// estimate's colour (zero where none).
inline void composite_parts(const float* a, const float* est, const float* hid, float* front, float* back,
                            float* est_out) {
  const bool has_est = est[4] > 1e-6f, has_hid = hid[4] > 0.0f;
  const float fw = a[4], bw = a[9];
  const float missing = has_est || has_hid ? std::max(0.0f, 1.0f - fw - bw) : 0.0f;
  const float rest = has_est ? std::max(0.0f, 1.0f - hid[4]) : 0.0f;
  const float fs = fw > 1.0f ? 1.0f / fw : 1.0f;
  for (int ch = 0; ch < 4; ++ch) {
    float fill = 0.0f;
    if (missing > 0.0f) fill = (hid[ch] + (has_est ? rest / est[4] : 0.0f) * est[ch]) / (hid[4] + rest);
    front[ch] = a[ch] * fs;
    back[ch] = bw + missing > 0.0f ? (a[5 + ch] + missing * fill) / (bw + missing) : 0.0f;
    est_out[ch] = has_est ? est[ch] / est[4] : 0.0f;
  }
}

/// Fixed sample offsets in the unit disc for the hidden-background estimate: the concentric
/// map of an 8 × 8 grid (the reference's).
class HiddenPattern {
 public:
  HiddenPattern();
  int count() const { return static_cast<int>(x_.size()); }
  float x(int i) const { return x_[static_cast<std::size_t>(i)]; }
  float y(int i) const { return y_[static_cast<std::size_t>(i)]; }

 private:
  std::vector<float> x_, y_;
};

/// The reference's composite of one receiver: a = F rgba, F weight, B rgba, B weight; est =
/// the hidden-background estimate as (rgba · mass, mass) (mass <= 1e-6: none); hid = hidden
/// fragments of deep input scattered onto the receiver (rgba, weight; weight 0: none), which
/// fill the uncovered share before the estimate does; src = the receiver's own colour (used
/// only when no footprint reaches it). Writes rgba into out and returns the uncovered share
/// that was filled.
inline float composite(const float* a, const float* est, const float* hid, float s0, float s1, float s2, float s3,
                       float* out) {
  const bool has_est = est[4] > 1e-6f, has_hid = hid[4] > 0.0f;
  const float fw = a[4], bw = a[9];
  const float missing = has_est || has_hid ? std::max(0.0f, 1.0f - fw - bw) : 0.0f;
  // The fill colour: the hidden fragments where they cover, the estimate for the rest.
  float fill[4] = {0, 0, 0, 0};
  if (missing > 0.0f) {
    const float rest = has_est ? std::max(0.0f, 1.0f - hid[4]) : 0.0f;
    const float inv = 1.0f / (hid[4] + rest);
    const float est_scale = has_est ? rest / est[4] : 0.0f;
    for (int ch = 0; ch < 4; ++ch) fill[ch] = (hid[ch] + est_scale * est[ch]) * inv;
  }
  const float src[4] = {s0, s1, s2, s3};
  const float fs = fw > 1.0f ? 1.0f / fw : 1.0f;
  const float keep = 1.0f - std::min(fw, 1.0f);
  for (int ch = 0; ch < 4; ++ch) {
    float v;
    if (bw + missing > 0) {
      const float back = (a[5 + ch] + missing * fill[ch]) / (bw + missing);
      v = a[ch] * fs + keep * back;
    } else if (fw > 0) {
      v = a[ch] / fw;
    } else {
      v = src[ch];
    }
    out[ch] = v;
  }
  return missing;
}

}  // namespace dofkit::detail::lens
