// The fused stack's layer generator: FusedLayer's values and the code pass's span summaries
// (see fused_layer.hpp).
#include "methods/layered/fused_layer.hpp"

#include <algorithm>
#include <bit>

#include "methods/layered/fast_push_pull.hpp"

namespace dofkit::detail::layered {

std::pair<int, int> FusedLayer::matte(int y, int x0, int n, float (*o)[kBlock], std::uint8_t* hb,
                                      bool zero_outside) const {
  const Cls c = cls(y, x0);
  if (c != kGeneral) {
    for (int ch = 0; ch < 4; ++ch) std::fill(o[ch], o[ch] + n, 0.0f);
    if (hb) std::fill(hb, hb + n, static_cast<std::uint8_t>(c == kEmptyHole ? 1 : 0));
    return {n, 0};
  }
  const std::size_t bi = static_cast<std::size_t>(y) * nb + x0 / kBlock;
  const std::size_t base = static_cast<std::size_t>(y) * w + x0;
  int lo = n, hi = 0;
  if ((bpres[bi] >> k) & 1u) {
    const std::uint32_t sp = bspan[16 * bi + static_cast<std::size_t>(k)];
    lo = static_cast<int>(sp & 0xffffu);
    hi = static_cast<int>(sp >> 16);
  }
  if (hi <= lo) {
    if (zero_outside)
      for (int ch = 0; ch < 4; ++ch) std::fill(o[ch], o[ch] + n, 0.0f);
  } else {
    const float* in[4];
    for (int ch = 0; ch < 4; ++ch) {
      if (zero_outside) {
        std::fill(o[ch], o[ch] + lo, 0.0f);
        std::fill(o[ch] + hi, o[ch] + n, 0.0f);
      }
      in[ch] = color->row(ch, y) + x0;
    }
    kern::matte_row(code + base, w0 + base, in, k, lo, hi, o);
  }
  if (hb) {
    // The flags are k >= hk per pixel; all 0 below the block's smallest hk, all 1 from its
    // largest on.
    const int hmin = static_cast<int>(bhk[bi] & 255u), hmax = static_cast<int>(bhk[bi] >> 8);
    if (k < hmin || k >= hmax) {
      std::fill(hb, hb + n, static_cast<std::uint8_t>(k >= hmax ? 1 : 0));
    } else {  // 0 outside the hole span (bhole), no hole there
      const std::uint32_t hs = bhole[16 * bi + static_cast<std::size_t>(k)];
      const int a0 = static_cast<int>(hs & 0xffffu), a1 = static_cast<int>(hs >> 16);
      std::fill(hb, hb + a0, static_cast<std::uint8_t>(0));
      kern::hole_row(code + base, k, a0, a1, hb);
      std::fill(hb + a1, hb + n, static_cast<std::uint8_t>(0));
    }
  }
  return {lo, hi};
}

void FusedLayer::get(int y, int x0, int n, float (*o)[kBlock], HCache* cache) const {
  if (fill && l1 && cache && !opaque && !under && cls(y, x0) == kEmptyHole) {
    // Every pixel is a hole over a zero matte: fill_row gives 0·0 + (1 − 0)·up = +0 + up
    // everywhere, computed here straight into o.
    if (cache->img != l1 || cache->x0 != x0) cache->reset(l1, 2, x0);
    cache->get(y, n, o, true);
    return;
  }
  matte(y, x0, n, o, nullptr);
  if (!fill) return;
  // The flags are k >= hk per pixel: none below the block's smallest hk, all from its
  // largest on (as in matte).
  const std::size_t bi = static_cast<std::size_t>(y) * nb + x0 / kBlock;
  const int hmin = static_cast<int>(bhk[bi] & 255u), hmax = static_cast<int>(bhk[bi] >> 8);
  if (k < hmin) return;
  std::uint8_t hb[kBlock];
  int a0 = 0, a1 = n;
  if (k >= hmax) {
    std::fill(hb, hb + n, static_cast<std::uint8_t>(1));
  } else {
    const std::uint32_t hs = bhole[16 * bi + static_cast<std::size_t>(k)];
    a0 = static_cast<int>(hs & 0xffffu);
    a1 = static_cast<int>(hs >> 16);
    kern::hole_row(code + static_cast<std::size_t>(y) * w + x0, k, a0, a1, hb);
  }
  float up[4][kBlock];
  if (l1 && cache) {
    if (cache->img != l1 || cache->x0 != x0) cache->reset(l1, 2, x0);
    cache->get(y, n, a0, a1, up);  // the fill reads up only at [a0, a1)
  } else {
    for (int c = 0; c < 4; ++c) {
      if (l1)
        up_block(l1->plane(c), l1->width(), l1->height(), y, x0, n, up[c]);
      else
        std::copy(o[c], o[c] + n, up[c]);  // 1×1: the fill is the pixel itself
    }
  }
  if (l1) {
    kern::fill_row(hb, up, opaque, under, a0, a1, o);
    return;
  }
  float* d[4] = {o[0], o[1], o[2], o[3]};
  for (int j = a0; j < a1; ++j) {
    if (!hb[j]) continue;
    float v[4];
    for (int c = 0; c < 4; ++c) v[c] = up[c][j];
    finish_fill(opaque, under, d, j, v);
  }
}

void block_spans(const std::uint32_t* cm, int n, std::uint32_t* span) {
  const int nc = (n + 15) / 16;
  std::uint32_t lo[16], hi[16];
  std::uint32_t seen = 0;
  for (int c = 0; c < nc; ++c) {
    const std::uint32_t b = cm[c] & 0xffffu;
    for (std::uint32_t f = b & ~seen; f; f &= f - 1) lo[std::countr_zero(f)] = static_cast<std::uint32_t>(16 * c);
    seen |= b;
  }
  seen = 0;
  for (int c = nc - 1; c >= 0; --c) {
    const std::uint32_t b = cm[c] & 0xffffu;
    for (std::uint32_t f = b & ~seen; f; f &= f - 1)
      hi[std::countr_zero(f)] = static_cast<std::uint32_t>(std::min(n, 16 * c + 16));
    seen |= b;
  }
  for (std::uint32_t f = seen; f; f &= f - 1) {
    const int k = std::countr_zero(f);
    span[k] = lo[k] | hi[k] << 16;
  }
}

void hole_spans(const std::uint32_t* ch, int n, std::uint32_t hk, std::uint32_t* span) {
  const std::uint32_t hmin = hk & 255u, hmax = std::min(hk >> 8, 16u);
  std::uint32_t s = hmax;
  for (int c = 0; s > hmin; ++c)
    for (; s > ch[c]; --s) span[s - 1] = static_cast<std::uint32_t>(16 * c);
  s = hmax;
  for (int c = (n + 15) / 16 - 1; s > hmin; --c)
    for (; s > ch[c]; --s) span[s - 1] |= static_cast<std::uint32_t>(std::min(n, 16 * c + 16)) << 16;
}

}  // namespace dofkit::detail::layered
