// The texel and fold forms of the gather's kernel (impl=fast; fast_gather.hpp): per frame, the
// taps' bilinear weights summed per source texel (in double, in tap order, then rounded once),
// and for kernels symmetric about the horizontal axis the pairs of mirrored texels. Inputs: the
// scaled tap offsets and the padded planes' pitch; outputs: TexelKernel / FoldKernel, which
// the FMA copies of the gather (fast_gather.cpp) sum. Oracle: gather.cpp's per-tap sum (same
// real-number sum; tests/sterna/sterna_fast_test.cpp bound the rounding difference).
#include <algorithm>
#include <cmath>

#include "methods/sterna/fast_gather.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

// Per texel (dy, dx) of the taps (offsets already scaled): the sum of the bilinear weights of
// the taps that touch it, each computed as gather.cpp's split() does and added in double in
// tap order; texels ordered by (dy, dx). Works in vectors kept per thread.
struct TexelSum {
  int dy, dx, tap;
  double w;
};
void texel_sums(const std::vector<std::pair<float, float>>& offsets, int pitch, std::vector<TexelSum>& texels) {
  thread_local std::vector<TexelSum> terms;
  terms.clear();
  for (int t = 0; t < static_cast<int>(offsets.size()); ++t) {
    const auto [ox, oy] = offsets[t];
    const Tap tp = split(ox, oy, pitch);
    const float w[4] = {tp.w00, tp.w10, tp.w01, tp.w11};
    const int x0 = static_cast<int>(std::floor(ox)), y0 = static_cast<int>(std::floor(oy));
    for (int i = 0; i < 4; ++i)
      if (w[i] != 0.0f) terms.push_back({y0 + i / 2, x0 + i % 2, t, w[i]});
  }
  // By texel (dy, then dx), the taps of a texel in tap order; then one weight per texel.
  std::sort(terms.begin(), terms.end(), [](const TexelSum& a, const TexelSum& b) {
    return a.dy != b.dy ? a.dy < b.dy : (a.dx != b.dx ? a.dx < b.dx : a.tap < b.tap);
  });
  texels.clear();
  for (const TexelSum& t : terms) {
    if (!texels.empty() && texels.back().dy == t.dy && texels.back().dx == t.dx)
      texels.back().w += t.w;
    else
      texels.push_back(t);
  }
}

}  // namespace

void build_texel_kernel(const std::vector<std::pair<float, float>>& offsets, int pitch, TexelKernel& k) {
  thread_local std::vector<TexelSum> texels;
  texel_sums(offsets, pitch, texels);
  // Source texel (s, dx) from the pair's first row carries weight (s, dx) for that row and
  // (s − 1, dx) for the second: merge the texel list with itself shifted down one row, both
  // ordered by (s, dx).
  k.both.clear();
  k.only0.clear();
  k.only1.clear();
  const std::size_t n = texels.size();
  std::size_t i = 0, j = 0;  // i: the first row's texels (s = dy), j: the second's (s = dy + 1)
  while (i < n || j < n) {
    const bool take_i = i < n && (j >= n || texels[i].dy < texels[j].dy + 1 ||
                                  (texels[i].dy == texels[j].dy + 1 && texels[i].dx <= texels[j].dx));
    const bool take_j = j < n && (i >= n || texels[j].dy + 1 < texels[i].dy ||
                                  (texels[j].dy + 1 == texels[i].dy && texels[j].dx <= texels[i].dx));
    const int s = take_i ? texels[i].dy : texels[j].dy + 1, dx = take_i ? texels[i].dx : texels[j].dx;
    const std::ptrdiff_t off = static_cast<std::ptrdiff_t>(s) * pitch + dx;
    const float w0 = take_i ? static_cast<float>(texels[i].w) : 0.0f;
    const float w1 = take_j ? static_cast<float>(texels[j].w) : 0.0f;
    if (w0 != 0.0f && w1 != 0.0f)
      k.both.push_back({off, w0, w1});
    else if (w0 != 0.0f)
      k.only0.push_back({off, w0});
    else if (w1 != 0.0f)
      k.only1.push_back({off, w1});
    i += take_i ? 1 : 0;
    j += take_j ? 1 : 0;
  }
}

void build_fold_kernel(const std::vector<std::pair<float, float>>& offsets, int pitch, int cw, FoldKernel& k) {
  thread_local std::vector<TexelSum> texels;
  texel_sums(offsets, pitch, texels);
  k.ok = false;
  k.e.clear();
  k.e_of.clear();
  k.pairs.clear();
  k.single.clear();
  if (texels.empty()) return;
  // Texel (dx, e ≥ 0) pairs with (dx, −e) where their float weights are equal; e = 0 pairs with
  // nothing. (Sorted by (dy, dx): binary search.)
  auto find = [&](int dy, int dx) -> const TexelSum* {
    auto it = std::lower_bound(
        texels.begin(), texels.end(), std::make_pair(dy, dx),
        [](const TexelSum& t, std::pair<int, int> v) { return t.dy != v.first ? t.dy < v.first : t.dx < v.second; });
    return it != texels.end() && it->dy == dy && it->dx == dx ? &*it : nullptr;
  };
  struct P {
    int e, dx;
    float w;
  };
  thread_local std::vector<P> pairs;
  thread_local std::vector<const TexelSum*> single;
  pairs.clear();
  single.clear();
  int dx_min = 0, dx_max = 0;
  for (const TexelSum& t : texels) {
    const float w = static_cast<float>(t.w);
    if (t.dy == 0) {
      pairs.push_back({0, t.dx, w});
    } else {
      const TexelSum* m = find(-t.dy, t.dx);
      const bool mirrored = m != nullptr && static_cast<float>(m->w) == w;
      if (!mirrored)
        single.push_back(&t);
      else if (t.dy > 0)
        pairs.push_back({t.dy, t.dx, w});
    }
    dx_min = std::min(dx_min, t.dx);
    dx_max = std::max(dx_max, t.dx);
  }
  std::sort(pairs.begin(), pairs.end(), [](const P& a, const P& b) { return a.e != b.e ? a.e < b.e : a.dx < b.dx; });
  for (const P& q : pairs)
    if (k.e.empty() || k.e.back() != q.e) k.e.push_back(q.e);
  k.e_slot.assign(k.e.empty() ? 1 : k.e.back() + 1, -1);
  for (std::size_t i = 0; i < k.e.size(); ++i) k.e_slot[k.e[i]] = static_cast<int>(i);
  k.bx = -((-dx_min + 15) / 16) * 16;
  k.vstride = (cw + dx_max - k.bx + 15) / 16 * 16;
  k.vspan = dx_max - k.bx;
  for (const P& q : pairs) {
    const int ei = static_cast<int>(std::lower_bound(k.e.begin(), k.e.end(), q.e) - k.e.begin());
    k.pairs.push_back({ei * k.vstride + q.dx - k.bx, q.w});
    k.e_of.push_back(q.e);
  }
  for (const TexelSum* t : single)  // (texels order: (dy, dx))
    k.single.push_back({t->dy * pitch + t->dx, static_cast<float>(t->w)});
  k.ok = k.pairs.size() + k.single.size() + k.e.size() <= texels.size();
}

}  // namespace dofkit::detail::sterna::fast
