// The plain form of `lens`: straightforward loops over the same model as the fast path (the
// oracle it is tested against; see lens.hpp and docs/methods/lens.md).
#include <algorithm>
#include <cmath>
#include <vector>

#include "methods/lens/footprint.hpp"
#include "methods/lens/lens.hpp"

namespace dofkit::detail::lens {

namespace {

inline float sat(float v) { return std::min(std::max(v, 0.0f), 1.0f); }

// One slice's grids at its level: merged sources (see kM*), scattered sums (rgba, weight) and
// the hidden-background estimate (rgba sum, mass).
enum { kMR, kMG, kMB, kMA, kMMass, kMRho, kMAll, kMAllRho, kMChannels };
struct SliceGrid {
  int level = 1, w = 0, h = 0;
  std::vector<float> merged;  // kMChannels per cell
  std::vector<float> acc;     // 5 per cell
  std::vector<float> est;     // 5 per cell
};

// Bilinear sample (clamp to edge) of `n` interleaved channels at frame pixel (x, y).
void sample(const SliceGrid& g, const std::vector<float>& buf, int n, int x, int y, float* out) {
  const float s = 1.0f / static_cast<float>(1 << g.level);
  const float fx = (x + 0.5f) * s - 0.5f, fy = (y + 0.5f) * s - 0.5f;
  const float cx = std::clamp(fx, 0.0f, static_cast<float>(g.w - 1));
  const float cy = std::clamp(fy, 0.0f, static_cast<float>(g.h - 1));
  const int x0 = std::min(static_cast<int>(cx), g.w - 1), y0 = std::min(static_cast<int>(cy), g.h - 1);
  const int x1 = std::min(x0 + 1, g.w - 1), y1 = std::min(y0 + 1, g.h - 1);
  const float ax = cx - x0, ay = cy - y0;
  const float wt[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
  const std::size_t idx[4] = {(static_cast<std::size_t>(y0) * g.w + x0) * n, (static_cast<std::size_t>(y0) * g.w + x1) * n,
                              (static_cast<std::size_t>(y1) * g.w + x0) * n, (static_cast<std::size_t>(y1) * g.w + x1) * n};
  for (int c = 0; c < n; ++c) {
    float v = 0;
    for (int k = 0; k < 4; ++k) v += wt[k] * buf[idx[k] + c];
    out[c] = v;
  }
}

// Per fragment f·n + pixel.
struct Frag {
  std::vector<int> slice;
  std::vector<float> t, inv_z, rho, sharp, isu;
  std::vector<std::uint8_t> exists, direct;
};

}  // namespace

void render_plain(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Image& out, Image* cover) {
  const Image& colour = *src.colour[0];
  const int w = colour.width(), h = colour.height();
  const std::size_t n = colour.plane_size();
  const int k = plan.count();
  const int nf = src.count();
  const float soft = opt.depth_softness;
  std::vector<float> trans;
  // Colour (premultiplied, times the hidden layers' transmittance) and weight of fragment q.
  auto col = [&](std::size_t q, int ch) { return src.colour[q / n]->plane(ch)[q % n] * trans[q]; };
  auto weight = [&](std::size_t q) { return q < n ? 1.0f : src.colour[q / n]->plane(3)[q % n] * trans[q]; };

  // Fragments: layer 0 is the visible surface (the receivers and the reference's sources);
  // layers >= 1 are the hidden fragments of deep input (alpha > 0 where they exist).
  Frag fr;
  const std::size_t nn = n * nf;
  fr.slice.resize(nn);
  fr.t.resize(nn);
  fr.inv_z.resize(nn);
  fr.rho.resize(nn);
  fr.sharp.resize(nn);
  fr.isu.resize(nn);
  fr.exists.resize(nn);
  fr.direct.resize(nn);
  float rho_max = 0.5f;
  std::vector<float> lum(n);
  // A hidden fragment counts as far as the fragments in front of it at its pixel that belong
  // to the same surface (not clearly in front of it: the front face of a closed object hides
  // its back face) let it through: trans[q] = Π (1 − alpha) over those.
  trans.assign(nn, 1.0f);
  for (std::size_t i = 0; i < n; ++i)
    for (int f = 1; f < nf; ++f) {
      const float zf = src.depth[f]->plane(0)[i];
      const float uf = std::isinf(zf) ? 0.0f : 1.0f / zf;
      float t = 1.0f;
      auto behind_of = [&](float ua, float ub) { return ub > 0 ? (ua - ub) >= soft * ub : ua > 0; };  // a clearly in front of b
      if (opt.deep_mode == 3) {
        const float z0 = src.depth[0]->plane(0)[i];
        const float u0 = std::isinf(z0) ? 0.0f : 1.0f / z0;
        if (!behind_of(u0, uf)) t = 0.0f;
        for (int g = 1; g < f && t > 0; ++g) {
          const float zg = src.depth[g]->plane(0)[i];
          const float ug = std::isinf(zg) ? 0.0f : 1.0f / zg;
          if (behind_of(u0, ug)) t *= 1.0f - src.colour[g]->plane(3)[i];
        }
      } else
      for (int g = 0; g < f; ++g) {
        const float zg = src.depth[g]->plane(0)[i];
        const float ug = std::isinf(zg) ? 0.0f : 1.0f / zg;
        const bool clearly_in_front = behind_of(ug, uf);
        if (!clearly_in_front || (opt.deep_mode == 2 && g > 0)) t *= 1.0f - src.colour[g]->plane(3)[i];
      }
      trans[f * n + i] = t;
    }
  for (int f = 0; f < nf; ++f) {
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t q = f * n + i;
      const float r = src.coc[f]->plane(0)[i];
      plan.member(r, fr.slice[q], fr.t[q]);
      const float z = src.depth[f]->plane(0)[i];
      fr.inv_z[q] = std::isinf(z) ? 0.0f : 1.0f / z;
      fr.isu[q] = fr.inv_z[q] > 0 ? 1.0f / (soft * fr.inv_z[q]) : 1e30f;
      fr.rho[q] = std::max(std::fabs(r), 0.5f);
      fr.sharp[q] = std::max(std::fabs(r) - 0.5f, 0.0f);
      fr.exists[q] = f == 0 || (src.colour[f]->plane(3)[i] > 0.0f && trans[q] > 0.0f);
      if (fr.exists[q]) rho_max = std::max(rho_max, fr.rho[q]);
      lum[i] = luminance(col(q, 0), col(q, 1), col(q, 2));
    }
    const std::vector<std::uint8_t> d = direct_sources(&fr.rho[f * n], lum.data(), w, h, opt);
    std::copy(d.begin(), d.end(), fr.direct.begin() + static_cast<std::ptrdiff_t>(f * n));
  }

  // Slices: the mean inverse depth of their members (all fragments), and per source set
  // (0: visible, 1: hidden) the merged sources at the slice's level.
  std::vector<double> mass(k, 0.0), u_sum(k, 0.0);
  std::vector<SliceGrid> g[2];
  for (int set = 0; set < 2; ++set) {
    g[set].resize(k);
    for (int j = 0; j < k; ++j) {
      SliceGrid& s = g[set][j];
      s.level = plan.level[j];
      s.w = (w + (1 << s.level) - 1) >> s.level;
      s.h = (h + (1 << s.level) - 1) >> s.level;
      if (set == 0 || nf > 1) s.merged.assign(static_cast<std::size_t>(s.w) * s.h * kMChannels, 0.0f);
    }
  }
  for (int f = 0; f < nf; ++f)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = f * n + static_cast<std::size_t>(y) * w + x;
        if (!fr.exists[i]) continue;
        for (int part = 0; part < 2; ++part) {
          const int j = fr.slice[i] + part;
          const float hw = part ? fr.t[i] : 1.0f - fr.t[i];
          if (j >= k || hw <= 0.0f) continue;
          mass[j] += hw;
          u_sum[j] += static_cast<double>(hw) * fr.inv_z[i];
          SliceGrid& s = g[f > 0][j];
          float* c = &s.merged[((static_cast<std::size_t>(y >> s.level)) * s.w + (x >> s.level)) * kMChannels];
          if (f == 0) {  // receivers: the hidden-background estimate's mass and radius
            c[kMAll] += hw;
            c[kMAllRho] += hw * fr.rho[i];
          }
          if (fr.direct[i]) continue;
          for (int ch = 0; ch < 4; ++ch) c[ch] += hw * col(i, ch);
          c[kMMass] += hw * weight(i);
          c[kMRho] += hw * weight(i) * fr.rho[i];
        }
      }
  std::vector<float> slice_u(k, 0.0f), slice_sharp(k, 0.0f), slice_inv_sharp(k, 1e30f);
  for (int j = 0; j < k; ++j) {
    slice_u[j] = mass[j] > 0 ? static_cast<float>(u_sum[j] / mass[j]) : 0.0f;
    slice_sharp[j] = std::max(std::fabs(plan.anchor[j]) - 0.5f, 0.0f);
    slice_inv_sharp[j] = slice_sharp[j] > 0 ? 1.0f / slice_sharp[j] : 1e30f;
  }

  // Merged sources: one footprint each at the slice's level, energy-normalised.
  TapTable taps;
  for (int set = 0; set < 2; ++set)
    for (int j = 0; j < k; ++j) {
      SliceGrid& s = g[set][j];
      if (s.merged.empty()) continue;
      bool any = false;
      for (int qy = 0; qy < s.h; ++qy)
        for (int qx = 0; qx < s.w; ++qx) {
          const float* c = &s.merged[(static_cast<std::size_t>(qy) * s.w + qx) * kMChannels];
          if (c[kMMass] <= 0.0f) continue;
          if (!any) s.acc.assign(static_cast<std::size_t>(s.w) * s.h * 5, 0.0f);
          any = true;
          const int ri = merged_radius_index(c[kMRho] / c[kMMass], s.level);
          taps.prepare(radius_of_index(ri));
          const Taps& t = taps[ri];
          for (int dy = -t.n; dy <= t.n; ++dy) {
            const int py = qy + dy;
            if (py < 0 || py >= s.h) continue;
            const int row = dy + t.n;
            for (int e = 0; e < t.len[row]; ++e) {
              const int px = qx + t.x0[row] + e;
              if (px < 0 || px >= s.w) continue;
              const float wt = t.w[t.off[row] + e];
              float* a = &s.acc[(static_cast<std::size_t>(py) * s.w + px) * 5];
              for (int ch = 0; ch < 5; ++ch) a[ch] += wt * c[ch];
            }
          }
        }
    }

  // Hidden-background estimate per slice and cell (visible set's grids): the mean colour of the
  // visible pixels clearly behind the slice, summed per cell, at 64 fixed samples within the
  // members' mean radius of the cell.
  const HiddenPattern pattern(opt.hidden_samples);
  if (opt.hidden)
    for (int j = 0; j < k; ++j) {
      SliceGrid& s = g[0][j];
      if (mass[j] <= 0) continue;
      const float limit = slice_u[j] * (1.0f - soft);
      std::vector<float> behind(static_cast<std::size_t>(s.w) * s.h * 5, 0.0f);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * w + x;
          if (!(fr.inv_z[i] < limit)) continue;
          float* b = &behind[((static_cast<std::size_t>(y >> s.level)) * s.w + (x >> s.level)) * 5];
          for (int ch = 0; ch < 4; ++ch) b[ch] += col(i, ch);
          b[4] += 1.0f;
        }
      const float scale = 1.0f / static_cast<float>(1 << s.level);
      for (int qy = 0; qy < s.h; ++qy)
        for (int qx = 0; qx < s.w; ++qx) {
          const float* c = &s.merged[(static_cast<std::size_t>(qy) * s.w + qx) * kMChannels];
          if (c[kMAll] <= 0.0f) continue;
          const float r = c[kMAllRho] / c[kMAll];
          if (r <= 0.5f) continue;  // an in-focus receiver is opaque
          float sum[5] = {0, 0, 0, 0, 0};
          for (int t = 0; t < pattern.count(); ++t) {
            const int bx = round_clamp(qx + pattern.x(t) * r * scale, s.w - 1);
            const int by = round_clamp(qy + pattern.y(t) * r * scale, s.h - 1);
            const float* b = &behind[(static_cast<std::size_t>(by) * s.w + bx) * 5];
            for (int ch = 0; ch < 5; ++ch) sum[ch] += b[ch];
          }
          if (sum[4] <= 0.0f) continue;
          if (s.est.empty()) s.est.assign(static_cast<std::size_t>(s.w) * s.h * 5, 0.0f);
          float* e = &s.est[(static_cast<std::size_t>(qy) * s.w + qx) * 5];
          for (int ch = 0; ch < 4; ++ch) e[ch] = sum[ch] / sum[4] * c[kMAll];
          e[4] = c[kMAll];
        }
    }

  // Receivers (layer 0): F (in front) and B (own surface and behind) sums, rgba + weight, and
  // the hidden fragments that show behind them (rgba + weight).
  std::vector<float> acc(n * 15, 0.0f);
  // A source at (u_q, sharp_q) reaching receiver p with weight wt: the reference's rule for a
  // visible source; a hidden fragment fills only behind a receiver blurred more than itself.
  auto add = [&](float* a, std::size_t p, bool hidden, float uq, float sq_inv, float sq, float wt, const float* c) {
    const float rel = (uq - fr.inv_z[p]) * fr.isu[p];
    const float front = sat(rel), behind = sat(-rel);
    if (hidden) {
      // In front of the receiver and on its surface as a visible source; behind it, it fills
      // the share the receiver's discs leave uncovered, as far as it is sharper than the
      // receiver (seen through a blurred near surface).
      const float sp = fr.sharp[p];
      const float show = sp > 0.0f ? behind * sat(2.0f * (sp - sq) / sp) : 0.0f;
      const float fb = opt.deep_mode == 1 ? 0.0f : 1.0f;
      for (int ch = 0; ch < 5; ++ch) {
        a[ch] += fb * wt * front * c[ch];
        a[5 + ch] += fb * wt * (1.0f - front - behind) * c[ch];
        a[10 + ch] += wt * show * c[ch];
      }
      return;
    }
    const float pass = std::min(fr.sharp[p] * sq_inv, 1.0f);
    const float v = wt * (1.0f - behind * (1.0f - pass));
    for (int ch = 0; ch < 5; ++ch) {
      a[ch] += v * front * c[ch];
      a[5 + ch] += v * (1.0f - front) * c[ch];
    }
  };
  // Direct sources: one full-resolution footprint each, exact per-pair weights.
  InverseArea inv_area;
  inv_area.prepare(rho_max + 1.0f);
  for (int f = 0; f < nf; ++f)
    for (int qy = 0; qy < h; ++qy)
      for (int qx = 0; qx < w; ++qx) {
        const std::size_t q = f * n + static_cast<std::size_t>(qy) * w + qx;
        if (!fr.exists[q] || !fr.direct[q]) continue;
        const float rq = fr.rho[q], ws = inv_area(rq);
        const float inv_sq = fr.sharp[q] > 0 ? 1.0f / fr.sharp[q] : 1e30f;
        const float c[5] = {col(q, 0), col(q, 1), col(q, 2), col(q, 3), weight(q)};
        const int e = reach(rq);
        for (int py = std::max(0, qy - e); py <= std::min(h - 1, qy + e); ++py)
          for (int px = std::max(0, qx - e); px <= std::min(w - 1, qx + e); ++px) {
            const float cov = coverage(rq, static_cast<float>(px - qx), static_cast<float>(py - qy));
            if (cov <= 0.0f) continue;
            const std::size_t p = static_cast<std::size_t>(py) * w + px;
            add(&acc[p * 15], p, f > 0, fr.inv_z[q], inv_sq, fr.sharp[q], cov * ws, c);
          }
      }

  out.resize(w, h, 4);
  if (cover) cover->resize(w, h, 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * w + x;
      float* a = &acc[p * 15];
      // Slices: the same rule with the slice's mean inverse depth and anchor sharpness.
      for (int set = 0; set < 2; ++set)
        for (int j = 0; j < k; ++j) {
          const SliceGrid& s = g[set][j];
          if (s.acc.empty()) continue;
          float v[5];
          sample(s, s.acc, 5, x, y, v);
          add(a, p, set > 0, slice_u[j], slice_inv_sharp[j], slice_sharp[j],
              1.0f / static_cast<float>(1 << (2 * s.level)), v);
        }
      float est[5] = {0, 0, 0, 0, 0};
      if (opt.hidden && fr.sharp[p] > 0.0f)
        for (int part = 0; part < 2; ++part) {
          const int j = fr.slice[p] + part;
          const float hw = part ? fr.t[p] : 1.0f - fr.t[p];
          if (j >= k || hw <= 0.0f || g[0][j].est.empty()) continue;
          float v[5];
          sample(g[0][j], g[0][j].est, 5, x, y, v);
          for (int ch = 0; ch < 5; ++ch) est[ch] += hw * v[ch];
        }
      float px[4];
      const float m = composite(a, est, a + 10, colour.plane(0)[p], colour.plane(1)[p], colour.plane(2)[p],
                                colour.plane(3)[p], px);
      for (int ch = 0; ch < 4; ++ch) out.row(ch, y)[x] = px[ch];
      if (cover) {
        cover->row(0, y)[x] = a[4];
        cover->row(1, y)[x] = a[9];
        cover->row(2, y)[x] = m;
        cover->row(3, y)[x] = 1.0f;
      }
    }
}

}  // namespace dofkit::detail::lens
