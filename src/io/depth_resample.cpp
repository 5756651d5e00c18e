// Depth resampling to the colour's size (depth_resample.hpp).
//
// Interpolation is done in inverse depth w = 1/z: the thin-lens CoC is linear in it
// (r = K (z_F w − 1)), so a blend of two depths gives a blend of their radii, and an infinite
// depth is w = 0 like any other value.
//
// guided: edge-aware upsampling guided by the colour (edge_aware_upsample below has the
// steps). A joint bilateral upsampling (Kopf et al. 2007) that only weights samples by colour
// still averages the near and the far side where the colour is ambiguous, and keeps the
// samples that straddle an edge (their depth is a mix of both sides): both showed as halos in
// the blur. The guided filter of He et al. (radius 2·ratio, ε = 1e-3) is kept as the
// alternative that measured worse (docs/cli.md, --depth-upsample, has the table).
#include "io/depth_resample.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "dofkit/error.hpp"

namespace dofkit::io {

DepthUpsample parse_depth_upsample(const std::string& name) {
  if (name == "nearest") return DepthUpsample::nearest;
  if (name == "bilinear") return DepthUpsample::bilinear;
  if (name == "guided") return DepthUpsample::guided;
  if (name == "guided-filter") return DepthUpsample::guided_filter;
  throw_usage("--depth-upsample " + name + ": unknown (known: nearest, bilinear, guided, guided-filter)");
}

const char* depth_upsample_name(DepthUpsample how) {
  switch (how) {
    case DepthUpsample::nearest:
      return "nearest";
    case DepthUpsample::bilinear:
      return "bilinear";
    case DepthUpsample::guided:
      return "guided";
    case DepthUpsample::guided_filter:
      return "guided-filter";
  }
  return "?";
}

void check_depth_fit(const std::string& depth_path, int dw, int dh, const std::string& color_path, int cw, int ch,
                     bool stretch) {
  if (dw == cw && dh == ch) return;
  const std::string sizes = depth_path + ": depth is " + std::to_string(dw) + "x" + std::to_string(dh) +
                            " but colour " + color_path + " is " + std::to_string(cw) + "x" + std::to_string(ch);
  if (dw > cw || dh > ch) throw_bad_input(sizes + "; a depth map larger than the colour image is not supported");
  if (stretch) return;
  // Same aspect: each side of the depth is the colour's scaled by one factor, within half a
  // depth pixel (integer sizes of a non-integer ratio round).
  const double want_h = static_cast<double>(ch) * dw / cw, want_w = static_cast<double>(cw) * dh / ch;
  if (std::fabs(want_h - dh) <= 0.5 || std::fabs(want_w - dw) <= 0.5) return;
  throw_bad_input(sizes + ": a different aspect ratio (" + std::to_string(static_cast<double>(dw) / dh).substr(0, 5) +
                  " against " + std::to_string(static_cast<double>(cw) / ch).substr(0, 5) +
                  "); crop it to the colour's, or scale it per axis with --depth-fit stretch");
}

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

float inverse(float z) { return std::isinf(z) ? 0.0f : 1.0f / z; }
float from_inverse(double w) { return w <= 0 ? kInf : static_cast<float>(1.0 / w); }

// The guide: sRGB-like encoded luminance of the (premultiplied, linear) colour, in [0, 1].
std::vector<float> grey_guide(const Image& color) {
  std::vector<float> g(color.plane_size());
  for (std::size_t i = 0; i < g.size(); ++i) {
    const double y = 0.2126 * color.plane(0)[i] + 0.7152 * color.plane(1)[i] + 0.0722 * color.plane(2)[i];
    g[i] = static_cast<float>(std::pow(std::clamp(y, 0.0, 1.0), 1.0 / 2.2));
  }
  return g;
}

// Box means over (2r+1)² windows (clipped at the borders) through a summed-area table in
// double, built serially: the same result for any thread count.
std::vector<double> box_mean(const std::vector<double>& v, int W, int H, int r) {
  std::vector<double> sat(static_cast<std::size_t>(W + 1) * (H + 1), 0.0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      sat[static_cast<std::size_t>(y + 1) * (W + 1) + x + 1] =
          v[static_cast<std::size_t>(y) * W + x] + sat[static_cast<std::size_t>(y) * (W + 1) + x + 1] +
          sat[static_cast<std::size_t>(y + 1) * (W + 1) + x] - sat[static_cast<std::size_t>(y) * (W + 1) + x];
  std::vector<double> out(v.size());
  for (int y = 0; y < H; ++y) {
    const int y0 = std::max(0, y - r), y1 = std::min(H, y + r + 1);
    for (int x = 0; x < W; ++x) {
      const int x0 = std::max(0, x - r), x1 = std::min(W, x + r + 1);
      const auto S = [&](int yy, int xx) { return sat[static_cast<std::size_t>(yy) * (W + 1) + xx]; };
      out[static_cast<std::size_t>(y) * W + x] =
          (S(y1, x1) - S(y0, x1) - S(y1, x0) + S(y0, x0)) / ((y1 - y0) * (x1 - x0));
    }
  }
  return out;
}

// He et al.'s grey-guide guided filter of the bilinear inverse depth p by the guide I.
Image guided_filter(const Image& bilinear_z, const std::vector<float>& guide, double ratio) {
  const int W = bilinear_z.width(), H = bilinear_z.height();
  const std::size_t n = bilinear_z.plane_size();
  const int r = static_cast<int>(std::ceil(2 * ratio));
  constexpr double kEps = 1e-3;
  std::vector<double> I(n), p(n), Ip(n), II(n);
  for (std::size_t i = 0; i < n; ++i) {
    I[i] = guide[i];
    p[i] = inverse(bilinear_z.plane(0)[i]);
    Ip[i] = I[i] * p[i];
    II[i] = I[i] * I[i];
  }
  const auto mI = box_mean(I, W, H, r), mp = box_mean(p, W, H, r), mIp = box_mean(Ip, W, H, r),
             mII = box_mean(II, W, H, r);
  std::vector<double> a(n), b(n);
  for (std::size_t i = 0; i < n; ++i) {
    a[i] = (mIp[i] - mI[i] * mp[i]) / (mII[i] - mI[i] * mI[i] + kEps);
    b[i] = mp[i] - a[i] * mI[i];
  }
  const auto ma = box_mean(a, W, H, r), mb = box_mean(b, W, H, r);
  Image out(W, H, 1);
  for (std::size_t i = 0; i < n; ++i) out.plane(0)[i] = from_inverse(std::max(0.0, ma[i] * I[i] + mb[i]));
  return out;
}

// The colour pixels [first, last) that depth sample i covers along an axis of n colour pixels,
// s = depth size / colour size: [floor(i/s), floor((i+1)/s)), at least one pixel, clipped to n.
std::pair<int, int> footprint(int i, double s, int n) {
  const int first = static_cast<int>(std::floor(i / s));
  return {first, std::min(n, std::max(first + 1, static_cast<int>(std::floor((i + 1) / s))))};
}

// The colour as three sRGB-like encoded planes in [0, 1] (the guide of `guided`).
std::vector<float> colour_guide(const Image& color) {
  const std::size_t n = color.plane_size();
  std::vector<float> g(3 * n);
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n; ++i)
      g[c * n + i] = static_cast<float>(std::pow(std::clamp<double>(color.plane(c)[i], 0.0, 1.0), 1.0 / 2.2));
  return g;
}

// Edge-aware upsampling (`guided`, the default). Three steps, each pixel or sample computed on
// its own, so the result is the same for any thread count:
//  1. per depth sample k: the mean colour μ_k of its footprint in the colour image (3
//     channels) and the footprint's colour variance v_k (summed over channels);
//  2. per sample: "mixed" if its 3x3 neighbourhood spans a depth edge (max − min of w = 1/z
//     above kEdge of the max) and its own w lies inside that span, more than kMargin of it from
//     both ends — a sample that straddles the edge holds an average of both sides, a depth
//     that exists nowhere, so it gets weight kMixedWeight;
//  3. per pixel x: the 5x5 samples around it weighted by distance (σ_s = 1 sample) and by
//     colour, exp(−|c(x) − μ_k|² / (2 (σ_r² + v_k))) — a textured footprint tolerates more
//     colour difference. Where the samples that are not mixed span a depth edge, they are split
//     at the middle of that span into a near and a far group and the pixel takes the weighted
//     mean of the heavier group only (a pixel belongs to one surface, not to a blend of two);
//     elsewhere the weighted mean of all.
Image edge_aware_upsample(const Image& depth, const Image& color) {
  constexpr int kRadius = 2;
  constexpr double kSigmaS = 1.0, kSigmaR = 0.1, kEdge = 0.15, kMargin = 0.15, kMixedWeight = 0.02;
  const int dw = depth.width(), dh = depth.height(), cw = color.width(), ch = color.height();
  const double sx = static_cast<double>(dw) / cw, sy = static_cast<double>(dh) / ch;
  const std::size_t nd = depth.plane_size(), nc = color.plane_size();
  std::vector<float> w(nd);
  for (std::size_t i = 0; i < nd; ++i) w[i] = inverse(depth.plane(0)[i]);
  const std::vector<float> g = colour_guide(color);
  std::vector<float> mean(3 * nd, 0.0f), var(nd, 0.0f);
  std::vector<unsigned char> mixed(nd, 0);
  tbb::parallel_for(0, dh, [&](int j) {
    const auto [y0, y1] = footprint(j, sy, ch);
    for (int i = 0; i < dw; ++i) {
      const std::size_t k = static_cast<std::size_t>(j) * dw + i;
      const auto [x0, x1] = footprint(i, sx, cw);
      const int n = std::max(0, (y1 - y0) * (x1 - x0));
      double v = 0;
      for (int c = 0; c < 3; ++c) {
        const float* plane = g.data() + c * nc;
        double sum = 0, sum2 = 0;
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x) {
            const double e = plane[static_cast<std::size_t>(y) * cw + x];
            sum += e;
            sum2 += e * e;
          }
        const double m = n ? sum / n : 0.0;
        mean[c * nd + k] = static_cast<float>(m);
        v += n ? std::max(0.0, sum2 / n - m * m) : 0.0;
      }
      var[k] = static_cast<float>(v);
      float lo = w[k], hi = w[k];
      for (int jj = std::max(0, j - 1); jj <= std::min(dh - 1, j + 1); ++jj)
        for (int ii = std::max(0, i - 1); ii <= std::min(dw - 1, i + 1); ++ii) {
          lo = std::min(lo, w[static_cast<std::size_t>(jj) * dw + ii]);
          hi = std::max(hi, w[static_cast<std::size_t>(jj) * dw + ii]);
        }
      const double span = static_cast<double>(hi) - lo;
      mixed[k] = span > kEdge * hi && w[k] > lo + kMargin * span && w[k] < hi - kMargin * span;
    }
  });
  Image out(cw, ch, 1);
  tbb::parallel_for(0, ch, [&](int y) {
    float* row = out.row(0, y);
    const double v = std::clamp((y + 0.5) * sy - 0.5, 0.0, dh - 1.0);
    const int jc = static_cast<int>(std::lround(v));
    const int j0 = std::max(0, jc - kRadius), j1 = std::min(dh - 1, jc + kRadius);
    for (int x = 0; x < cw; ++x) {
      const double u = std::clamp((x + 0.5) * sx - 0.5, 0.0, dw - 1.0);
      const int ic = static_cast<int>(std::lround(u));
      const int i0 = std::max(0, ic - kRadius), i1 = std::min(dw - 1, ic + kRadius);
      const std::size_t px = static_cast<std::size_t>(y) * cw + x;
      // The span of the samples that are not mixed (all of them if every one is).
      float lo = std::numeric_limits<float>::max(), hi = -1.0f;
      for (int pass = 0; pass < 2 && hi < 0; ++pass)
        for (int j = j0; j <= j1; ++j)
          for (int i = i0; i <= i1; ++i) {
            const std::size_t k = static_cast<std::size_t>(j) * dw + i;
            if (mixed[k] && pass == 0) continue;
            lo = std::min(lo, w[k]);
            hi = std::max(hi, w[k]);
          }
      const bool split = static_cast<double>(hi) - lo > kEdge * hi;
      const double mid = 0.5 * (static_cast<double>(lo) + hi);
      double sum[2] = {0, 0}, weight[2] = {0, 0};
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const std::size_t k = static_cast<std::size_t>(j) * dw + i;
          const double ds = (i - u) * (i - u) + (j - v) * (j - v);
          double dc = 0;
          for (int c = 0; c < 3; ++c) {
            const double d = static_cast<double>(g[c * nc + px]) - mean[c * nd + k];
            dc += d * d;
          }
          double e = std::exp(-ds / (2 * kSigmaS * kSigmaS) - dc / (2 * (kSigmaR * kSigmaR + var[k])));
          if (mixed[k]) e *= kMixedWeight;
          const int side = split && w[k] >= mid ? 1 : 0;
          sum[side] += e * w[k];
          weight[side] += e;
        }
      if (!split) {
        sum[0] += sum[1];
        weight[0] += weight[1];
      }
      const int side = split && weight[1] > weight[0] ? 1 : 0;
      row[x] = weight[side] > 0 ? from_inverse(sum[side] / weight[side]) : depth.at(ic, jc);
    }
  });
  return out;
}

}  // namespace

Image resample_depth(const Image& depth, const Image& color, DepthUpsample how) {
  const int dw = depth.width(), dh = depth.height(), cw = color.width(), ch = color.height();
  Image out(cw, ch, 1);
  if (dw == cw && dh == ch) {
    out = depth;
    return out;
  }
  if (how == DepthUpsample::guided) return edge_aware_upsample(depth, color);
  if (how == DepthUpsample::guided_filter)
    return guided_filter(resample_depth(depth, color, DepthUpsample::bilinear), grey_guide(color),
                         std::max(static_cast<double>(cw) / dw, static_cast<double>(ch) / dh));
  const double sx = static_cast<double>(dw) / cw, sy = static_cast<double>(dh) / ch;
  // Inverse depth of the samples.
  std::vector<float> w(depth.plane_size());
  for (std::size_t i = 0; i < w.size(); ++i) w[i] = inverse(depth.plane(0)[i]);
  tbb::parallel_for(0, ch, [&](int y) {
    float* row = out.row(0, y);
    const double v = std::clamp((y + 0.5) * sy - 0.5, 0.0, dh - 1.0);
    for (int x = 0; x < cw; ++x) {
      const double u = std::clamp((x + 0.5) * sx - 0.5, 0.0, dw - 1.0);
      switch (how) {
        case DepthUpsample::nearest: {
          const int i = std::min(dw - 1, static_cast<int>(std::floor((x + 0.5) * sx)));
          const int j = std::min(dh - 1, static_cast<int>(std::floor((y + 0.5) * sy)));
          row[x] = depth.at(i, j);
          break;
        }
        case DepthUpsample::bilinear: {
          const int i0 = static_cast<int>(u), j0 = static_cast<int>(v);
          const int i1 = std::min(i0 + 1, dw - 1), j1 = std::min(j0 + 1, dh - 1);
          const double fu = u - i0, fv = v - j0;
          auto at = [&](int i, int j) { return static_cast<double>(w[static_cast<std::size_t>(j) * dw + i]); };
          const double top = at(i0, j0) * (1 - fu) + at(i1, j0) * fu, bottom = at(i0, j1) * (1 - fu) + at(i1, j1) * fu;
          row[x] = from_inverse(top * (1 - fv) + bottom * fv);
          break;
        }
        case DepthUpsample::guided:
        case DepthUpsample::guided_filter:
          break;  // above
      }
    }
  });
  return out;
}

Image refine_depth(const Image& depth, const Image& color) {
  const int cw = depth.width(), ch = depth.height();
  const int dw = std::max(1, (cw + kRefineFactor / 2) / kRefineFactor),
            dh = std::max(1, (ch + kRefineFactor / 2) / kRefineFactor);
  if (dw == cw && dh == ch) return depth;
  // The same footprints as edge_aware_upsample's.
  const double sx = static_cast<double>(dw) / cw, sy = static_cast<double>(dh) / ch;
  Image low(dw, dh, 1);
  tbb::parallel_for(0, dh, [&](int j) {
    const auto [y0, y1] = footprint(j, sy, ch);
    for (int i = 0; i < dw; ++i) {
      const auto [x0, x1] = footprint(i, sx, cw);
      double sum = 0;
      int n = 0;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x, ++n) sum += inverse(depth.at(x, y));
      low.at(i, j) = n ? from_inverse(sum / n) : depth.at(std::min(x0, cw - 1), std::min(y0, ch - 1));
    }
  });
  return resample_depth(low, color, DepthUpsample::guided);
}

}  // namespace dofkit::io
