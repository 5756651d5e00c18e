// P3–P6 (docs/methods/sterna.md): the near CoC that only spreads outward.
//
// A box blur alone would also pull the near factor *down* inside the silhouette of a near
// object (its edge pixels would average with the in-focus background), so the blurred
// near field would not cover the object's own edge. Taking the max over the same window
// first grows the silhouette by the radius; the box then ramps from 1 at the original edge
// down to 0 one radius outside it — a blur that only goes outward (Sterna Fig. 3.9).
// Both filters are separable (max of a rectangle = max of row maxima); the max uses the
// van Herk / Gil–Werman block trick (O(1) per pixel for any radius): for windows of width
// k = 2r+1 aligned anywhere, max(a[x−r..x+r]) = max(suffix_max[x−r], prefix_max[x+r]) where
// prefix/suffix maxima restart every k samples. Near factors are >= 0, so padding the line
// with zeros is the same as clamping the window at the image border.
#include <algorithm>
#include <vector>

#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "methods/sterna/passes.hpp"

namespace dofkit::detail::sterna {

namespace {

// Running max of width 2r+1 over `n` samples read with stride; writes with the same stride.
void max_line(const float* in, float* out, int n, int stride, int r, std::vector<float>& buf) {
  const int k = 2 * r + 1;
  const int len = n + 2 * r;  // zero padded by r on both sides
  const int blocks = (len + k - 1) / k;
  const int padded = blocks * k;
  buf.assign(static_cast<std::size_t>(3) * padded, 0.0f);
  float* a = buf.data();
  float* pre = a + padded;
  float* suf = pre + padded;
  for (int i = 0; i < n; ++i) a[i + r] = in[static_cast<std::size_t>(i) * stride];
  for (int b = 0; b < padded; b += k) {
    pre[b] = a[b];
    for (int i = b + 1; i < b + k; ++i) pre[i] = std::max(pre[i - 1], a[i]);
    suf[b + k - 1] = a[b + k - 1];
    for (int i = b + k - 2; i >= b; --i) suf[i] = std::max(suf[i + 1], a[i]);
  }
  // Output x covers padded samples [x, x + 2r].
  for (int x = 0; x < n; ++x) out[static_cast<std::size_t>(x) * stride] = std::max(suf[x], pre[x + 2 * r]);
}

}  // namespace

void dilate_near_coc(const Settings& s, HalfRes& h) {
  const int w = h.w, hh = h.h, r = s.dilate_radius;
  Image tmp(w, hh, 1);
  h.near_blur.resize(w, hh, 1);
  const float* near = h.coc.plane(0);
  if (r <= 0) {
    std::copy(near, near + h.coc.plane_size(), h.near_blur.plane(0));
    return;
  }
  // P3 max along x, P4 max along y.
  core::parallel_for(
      hh,
      [&](int y0, int y1) {
        std::vector<float> buf;
        for (int y = y0; y < y1; ++y) max_line(near + static_cast<std::size_t>(y) * w, tmp.row(0, y), w, 1, r, buf);
      },
      8);
  core::parallel_for(
      w,
      [&](int x0, int x1) {
        std::vector<float> buf;
        for (int x = x0; x < x1; ++x) max_line(tmp.plane(0) + x, h.near_blur.plane(0) + x, hh, w, r, buf);
      },
      16);
  // P5/P6 box mean over the same window (clamp-to-edge).
  core::box_blur_plane(h.near_blur.plane(0), h.near_blur.plane(0), w, hh, r, r);
  // The running-sum box leaves rounding residue (~1e-8) where the window has just left a
  // non-zero region; flush it so "nearBlur > 0" still means "a near pixel is within reach".
  float* nb = h.near_blur.plane(0);
  for (std::size_t i = 0; i < h.near_blur.plane_size(); ++i)
    if (nb[i] < 1e-6f) nb[i] = 0.0f;
}

}  // namespace dofkit::detail::sterna
