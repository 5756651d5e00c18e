#include "methods/layered/inpaint.hpp"

#include <algorithm>

#include "core/filters.hpp"
#include "core/parallel.hpp"

namespace dofkit::detail::layered {

namespace {
// One pyramid level: 4 value planes (weight-normalised premultiplied RGBA) + confidence.
struct Level {
  Image value;   // 4 planes
  Image weight;  // 1 plane, in [0, 1]
};
}  // namespace

void push_pull_fill(Image& layer, const std::vector<std::uint8_t>& hole, bool opaque, bool under) {
  const int w = layer.width(), h = layer.height();
  std::vector<Level> pyr;
  pyr.push_back({layer, Image(w, h, 1, 0.0f)});
  for (std::size_t i = 0; i < layer.plane_size(); ++i) pyr[0].weight.plane(0)[i] = hole[i] ? 0.0f : 1.0f;
  // Pull: coarse value = Σ w v / Σ w over the 2×2 children, confidence = Σ w / 4.
  while (pyr.back().value.width() > 1 || pyr.back().value.height() > 1) {
    const Level& f = pyr.back();
    const int fw = f.value.width(), fh = f.value.height();
    const int cw = (fw + 1) / 2, ch = (fh + 1) / 2;
    Level c{Image(cw, ch, 4, 0.0f), Image(cw, ch, 1, 0.0f)};
    pull_level(
        f.value, [&](int fx, int fy) { return f.weight.at(fx, fy); }, c.value, c.weight);
    pyr.push_back(std::move(c));
  }
  // Push: from coarse to fine, v_l ← w_l v_l + (1 − w_l) · upsample(v_{l+1}).
  for (int l = static_cast<int>(pyr.size()) - 2; l >= 0; --l) {
    Level& f = pyr[l];
    const Level& c = pyr[l + 1];
    const int fw = f.value.width(), fh = f.value.height();
    const int cw = c.value.width(), ch = c.value.height();
    core::parallel_for(fh, [&](int y0, int y1) {
      for (int y = y0; y < y1; ++y)
        for (int x = 0; x < fw; ++x) {
          const float wt = f.weight.at(x, y);
          if (wt >= 1.0f) continue;
          // Fine pixel centre (x + 0.5) lies at (x + 0.5) / 2 in coarse pixel units.
          const float cx = (x + 0.5f) * 0.5f, cy = (y + 0.5f) * 0.5f;
          for (int k = 0; k < 4; ++k) {
            const float up = core::sample_bilinear(c.value.plane(k), cw, ch, cx, cy);
            float& v = f.value.at(x, y, k);
            v = wt * v + (1.0f - wt) * up;
          }
        }
    });
  }
  const Image& filled = pyr[0].value;
  for (std::size_t i = 0; i < layer.plane_size(); ++i) {
    if (!hole[i]) continue;
    float v[4];
    for (int k = 0; k < 4; ++k) v[k] = filled.plane(k)[i];
    if (opaque && v[3] > 1e-6f) {
      for (int k = 0; k < 3; ++k) v[k] /= v[3];
      v[3] = 1.0f;
    }
    if (under) {
      const float t = 1.0f - layer.plane(3)[i];
      for (int k = 0; k < 4; ++k) layer.plane(k)[i] += t * v[k];
    } else {
      for (int k = 0; k < 4; ++k) layer.plane(k)[i] = v[k];
    }
  }
}

}  // namespace dofkit::detail::layered
