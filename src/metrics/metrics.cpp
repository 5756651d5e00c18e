// Image-quality metrics (see metrics.hpp for the exact protocol).
#include "metrics/metrics.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/parallel.hpp"
#include "dofkit/error.hpp"

namespace dofkit::metrics {

namespace {

std::string size_text(const Image& img) {
  return std::to_string(img.width()) + "x" + std::to_string(img.height()) + "x" + std::to_string(img.channels());
}

void check_pair(const Image& ref, const Image& test, const char* what) {
  if (ref.channels() < 3 || test.channels() < 3)
    throw_bad_input(std::string(what) + ": needs RGB images, got " + size_text(ref) + " and " + size_text(test));
  if (!ref.same_size(test) || ref.empty())
    throw_bad_input(std::string(what) + ": image sizes differ or are empty: reference " + size_text(ref) + ", test " +
                    size_text(test));
}

void check_mask(const Image& ref, const Image& mask, const char* what) {
  if (mask.channels() < 1 || !mask.same_size(ref))
    throw_bad_input(std::string(what) + ": mask " + size_text(mask) + " does not match the image " + size_text(ref));
}

/// Sum of per-row partial sums in row order: the same value for any thread partition.
double ordered_sum(const std::vector<double>& rows) {
  double s = 0;
  for (double v : rows) s += v;
  return s;
}

/// Display values of planes 0..2, plane-major (3 · W · H floats).
std::vector<float> display_planes(const Image& img) {
  const std::size_t n = img.plane_size();
  std::vector<float> out(3 * n);
  core::parallel_for(
      img.height(),
      [&](int y0, int y1) {
        for (int c = 0; c < 3; ++c)
          for (int y = y0; y < y1; ++y) {
            const float* s = img.row(c, y);
            float* d = out.data() + c * n + static_cast<std::size_t>(y) * img.width();
            for (int x = 0; x < img.width(); ++x) d[x] = display_value(s[x]);
          }
      },
      16);
  return out;
}

/// scipy.ndimage 'reflect' border: half-sample symmetric, periodic with period 2n.
int reflect_index(int i, int n) {
  if (n == 1) return 0;
  const int period = 2 * n;
  i %= period;
  if (i < 0) i += period;
  return i < n ? i : period - 1 - i;
}

// SSIM constants of the protocol (Wang et al. 2004 with data range L = 1).
constexpr double kSigma = 1.5;
constexpr int kRadius = 5;  // int(3.5 σ + 0.5): scikit-image's truncate = 3.5
constexpr int kTaps = 2 * kRadius + 1;
constexpr double kC1 = 0.01 * 0.01;  // (K1 L)²
constexpr double kC2 = 0.03 * 0.03;  // (K2 L)²
constexpr int kStripRows = 32;       // rows per work item (fixed: results do not depend on threads)

std::array<double, kTaps> gaussian_taps() {
  std::array<double, kTaps> w{};
  double sum = 0;
  for (int k = -kRadius; k <= kRadius; ++k) {
    w[k + kRadius] = std::exp(-0.5 / (kSigma * kSigma) * k * k);
    sum += w[k + kRadius];
  }
  for (double& v : w) v /= sum;
  return w;
}

/// Mean SSIM of one plane pair (display values, W × H), cropped by kRadius on every side.
double ssim_plane(const float* a, const float* b, int w, int h) {
  static const std::array<double, kTaps> g = gaussian_taps();
  const int nstrips = (h + kStripRows - 1) / kStripRows;
  std::vector<double> row_sums(h, 0.0);
  core::parallel_for(nstrips, [&](int s0, int s1) {
    // Horizontally filtered moments of the rows a strip needs (kRadius rows of halo each
    // side, borders reflected): ux, uy, uxx, uyy, uxy.
    std::vector<double> hbuf;
    std::vector<double> tmp(5 * static_cast<std::size_t>(w));
    std::vector<double> pad[5];
    for (auto& v : pad) v.resize(w + 2 * kRadius);
    for (int s = s0; s < s1; ++s) {
      const int y0 = s * kStripRows, y1 = std::min(h, y0 + kStripRows);
      const int nrows = y1 - y0 + 2 * kRadius;
      hbuf.assign(5 * static_cast<std::size_t>(nrows) * w, 0.0);
      for (int r = 0; r < nrows; ++r) {
        const int sy = reflect_index(y0 - kRadius + r, h);
        const float* ra = a + static_cast<std::size_t>(sy) * w;
        const float* rb = b + static_cast<std::size_t>(sy) * w;
        // The row and its products with kRadius reflected samples each side, so the
        // filter below is a plain loop over x for each tap.
        for (int i = 0; i < w + 2 * kRadius; ++i) {
          const int sx = reflect_index(i - kRadius, w);
          const double va = ra[sx], vb = rb[sx];
          pad[0][i] = va;
          pad[1][i] = vb;
          pad[2][i] = va * va;
          pad[3][i] = vb * vb;
          pad[4][i] = va * vb;
        }
        for (int q = 0; q < 5; ++q) {
          double* m = hbuf.data() + (static_cast<std::size_t>(q) * nrows + r) * w;
          const double* p = pad[q].data();
          std::fill(m, m + w, 0.0);
          for (int k = 0; k < kTaps; ++k) {
            const double wk = g[k];
            for (int x = 0; x < w; ++x) m[x] += wk * p[x + k];
          }
        }
      }
      for (int y = y0; y < y1; ++y) {
        // Only rows and columns at least kRadius from the border count (skimage's crop).
        if (y < kRadius || y >= h - kRadius) continue;
        const int r0 = y - y0;  // first halo row of this output row in hbuf
        std::fill(tmp.begin(), tmp.end(), 0.0);
        for (int k = 0; k < kTaps; ++k) {
          const double wk = g[k];
          for (int q = 0; q < 5; ++q) {
            const double* src = hbuf.data() + (static_cast<std::size_t>(q) * nrows + r0 + k) * w;
            double* dst = tmp.data() + static_cast<std::size_t>(q) * w;
            for (int x = 0; x < w; ++x) dst[x] += wk * src[x];
          }
        }
        double sum = 0;
        for (int x = kRadius; x < w - kRadius; ++x) {
          const double ux = tmp[x], uy = tmp[w + x];
          const double vx = tmp[2 * w + x] - ux * ux;
          const double vy = tmp[3 * w + x] - uy * uy;
          const double vxy = tmp[4 * w + x] - ux * uy;
          sum += ((2 * ux * uy + kC1) * (2 * vxy + kC2)) / ((ux * ux + uy * uy + kC1) * (vx + vy + kC2));
        }
        row_sums[y] = sum;
      }
    }
  });
  const double count = static_cast<double>(w - 2 * kRadius) * (h - 2 * kRadius);
  return ordered_sum(row_sums) / count;
}

/// Sum over masked pixels (mask null = all) of squared differences of display planes
/// (3 planes of W × H each) over R, G, B; `count` = number of pixels summed.
void masked_sse(const std::vector<float>& da, const std::vector<float>& db, int w, int h, const Image* mask,
                double& sse, double& count) {
  const std::size_t n = static_cast<std::size_t>(w) * h;
  std::vector<double> row_sse(h, 0.0), row_n(h, 0.0);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* m = mask ? mask->row(0, y) : nullptr;
          const std::size_t o = static_cast<std::size_t>(y) * w;
          double s = 0, cnt = 0;
          for (int x = 0; x < w; ++x) {
            if (m && !(m[x] > 0.5f)) continue;
            for (int c = 0; c < 3; ++c) {
              const double d = static_cast<double>(da[c * n + o + x]) - db[c * n + o + x];
              s += d * d;
            }
            cnt += 1;
          }
          row_sse[y] = s;
          row_n[y] = cnt;
        }
      },
      8);
  sse = ordered_sum(row_sse);
  count = ordered_sum(row_n);
}

double ssim_display(const std::vector<float>& da, const std::vector<float>& db, int w, int h) {
  if (w < kTaps || h < kTaps)
    throw_bad_input("ssim: images are " + std::to_string(w) + "x" + std::to_string(h) +
                    ", the 11x11 SSIM window needs at least 11x11 pixels");
  const std::size_t n = static_cast<std::size_t>(w) * h;
  double total = 0;
  for (int c = 0; c < 3; ++c) total += ssim_plane(da.data() + c * n, db.data() + c * n, w, h);
  return total / 3.0;
}

double psnr_from(double sse, double pixels) {
  if (pixels <= 0) return std::numeric_limits<double>::quiet_NaN();
  const double mse = sse / (3.0 * pixels);
  if (mse <= 0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(1.0 / mse);
}

/// Relative depth jump between two neighbours (see metrics.hpp).
bool depth_jump(float z1, float z2, double jump) {
  if (std::isnan(z1) || std::isnan(z2)) return false;
  const bool i1 = std::isinf(z1), i2 = std::isinf(z2);
  if (i1 || i2) return i1 != i2;
  const double lo = std::min(z1, z2);
  if (lo <= 0) return z1 != z2;
  return std::abs(static_cast<double>(z1) - z2) / lo > jump;
}

}  // namespace

float display_value(float v) {
  if (!(v > 0.0f)) return 0.0f;  // also maps NaN to 0
  if (v >= 1.0f) return 1.0f;
  // Piecewise sRGB transfer (IEC 61966-2-1).
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

double psnr(const Image& ref, const Image& test) {
  check_pair(ref, test, "psnr");
  double sse = 0, n = 0;
  masked_sse(display_planes(ref), display_planes(test), ref.width(), ref.height(), nullptr, sse, n);
  return psnr_from(sse, n);
}

double psnr_linear(const Image& ref, const Image& test, double peak) {
  if (!ref.same_size(test) || ref.channels() != test.channels())
    throw_usage("psnr_linear: images differ in size or channels");
  double sse = 0;
  for (std::size_t i = 0; i < ref.data().size(); ++i) {
    const double d = static_cast<double>(test.data()[i]) - ref.data()[i];
    sse += d * d;
  }
  if (sse == 0) return std::numeric_limits<double>::infinity();
  return 10 * std::log10(peak * peak / (sse / static_cast<double>(ref.data().size())));
}

double psnr_masked(const Image& ref, const Image& test, const Image& mask) {
  check_pair(ref, test, "psnr_masked");
  check_mask(ref, mask, "psnr_masked");
  double sse = 0, n = 0;
  masked_sse(display_planes(ref), display_planes(test), ref.width(), ref.height(), &mask, sse, n);
  return psnr_from(sse, n);
}

double ssim(const Image& ref, const Image& test) {
  check_pair(ref, test, "ssim");
  return ssim_display(display_planes(ref), display_planes(test), ref.width(), ref.height());
}

double ssim_values(const float* a, const float* b, int w, int h) {
  if (w < kTaps || h < kTaps)
    throw_bad_input("ssim: images are " + std::to_string(w) + "x" + std::to_string(h) +
                    ", the 11x11 SSIM window needs at least 11x11 pixels");
  return ssim_plane(a, b, w, h);
}

double rmse_linear(const Image& ref, const Image& test) {
  check_pair(ref, test, "rmse");
  const int w = ref.width(), h = ref.height();
  std::vector<double> rows(h, 0.0);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          double s = 0;
          for (int c = 0; c < 3; ++c) {
            const float* p = ref.row(c, y);
            const float* q = test.row(c, y);
            for (int x = 0; x < w; ++x) {
              const double d = static_cast<double>(p[x]) - q[x];
              s += d * d;
            }
          }
          rows[y] = s;
        }
      },
      8);
  return std::sqrt(ordered_sum(rows) / (3.0 * static_cast<double>(ref.plane_size())));
}

Image edge_band(const Image& depth, int band_px, double jump) {
  if (depth.empty() || depth.channels() < 1) throw_bad_input("edge_band: depth map is empty");
  if (band_px < 0) throw_usage("edge_band: band_px must be >= 0, got " + std::to_string(band_px));
  const int w = depth.width(), h = depth.height();
  // 1. Edge pixels: a jump to any 4-neighbour (both pixels of a jumping pair are marked).
  std::vector<unsigned char> edge(depth.plane_size(), 0);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* r = depth.row(0, y);
          for (int x = 0; x < w; ++x) {
            const float z = r[x];
            bool e = (x > 0 && depth_jump(z, r[x - 1], jump)) || (x + 1 < w && depth_jump(z, r[x + 1], jump)) ||
                     (y > 0 && depth_jump(z, depth.row(0, y - 1)[x], jump)) ||
                     (y + 1 < h && depth_jump(z, depth.row(0, y + 1)[x], jump));
            edge[static_cast<std::size_t>(y) * w + x] = e ? 1 : 0;
          }
        }
      },
      8);
  // 2. Per row, horizontal distance to the nearest edge pixel (capped at band + 1).
  const int cap = band_px + 1;
  std::vector<int> hd(depth.plane_size(), cap);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const unsigned char* e = edge.data() + static_cast<std::size_t>(y) * w;
          int* d = hd.data() + static_cast<std::size_t>(y) * w;
          int last = -1000000000;
          for (int x = 0; x < w; ++x) {
            if (e[x]) last = x;
            d[x] = std::min(cap, x - last);
          }
          last = 2000000000;
          for (int x = w - 1; x >= 0; --x) {
            if (e[x]) last = x;
            d[x] = std::min(d[x], std::min(cap, last - x));
          }
        }
      },
      8);
  // 3. A pixel is in the band if some edge pixel (x', y') has (x − x')² + (y − y')² <= band².
  Image mask(w, h, 1, 0.0f);
  const long long b2 = static_cast<long long>(band_px) * band_px;
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          float* m = mask.row(0, y);
          const int ya = std::max(0, y - band_px), yb = std::min(h - 1, y + band_px);
          for (int x = 0; x < w; ++x) {
            for (int yy = ya; yy <= yb; ++yy) {
              const long long dx = hd[static_cast<std::size_t>(yy) * w + x];
              const long long dy = yy - y;
              if (dx <= band_px && dx * dx + dy * dy <= b2) {
                m[x] = 1.0f;
                break;
              }
            }
          }
        }
      },
      8);
  return mask;
}

Scores compare_with_mask(const Image& ref, const Image& test, const Image* band_mask) {
  check_pair(ref, test, "compare");
  if (band_mask) check_mask(ref, *band_mask, "edge PSNR");
  const int w = ref.width(), h = ref.height();
  // Display values once for all scores.
  const std::vector<float> da = display_planes(ref), db = display_planes(test);
  Scores s;
  double sse = 0, n = 0;
  masked_sse(da, db, w, h, nullptr, sse, n);
  s.psnr_db = psnr_from(sse, n);
  s.ssim = ssim_display(da, db, w, h);
  s.rmse_linear = rmse_linear(ref, test);
  if (band_mask) {
    masked_sse(da, db, w, h, band_mask, sse, n);
    s.edge_psnr_db = psnr_from(sse, n);
    s.edge_fraction = n / static_cast<double>(ref.plane_size());
  }
  return s;
}

Scores compare(const Image& ref, const Image& test, const Image* depth) {
  check_pair(ref, test, "compare");
  if (!depth) return compare_with_mask(ref, test, nullptr);
  if (!depth->same_size(ref))
    throw_bad_input("compare: depth " + size_text(*depth) + " does not match the images " + size_text(ref));
  const Image band = edge_band(*depth, kEdgeBandPx, kEdgeJump);
  return compare_with_mask(ref, test, &band);
}

Image crop(const Image& img, int x0, int y0, int x1, int y1) {
  if (x0 < 0 || y0 < 0 || x1 > img.width() || y1 > img.height() || x0 >= x1 || y0 >= y1)
    throw_usage("crop " + std::to_string(x0) + "," + std::to_string(y0) + "," + std::to_string(x1) + "," +
                std::to_string(y1) + " is empty or outside the " + std::to_string(img.width()) + "x" +
                std::to_string(img.height()) + " image (X0,Y0 inclusive, X1,Y1 exclusive)");
  Image out(x1 - x0, y1 - y0, img.channels());
  for (int c = 0; c < img.channels(); ++c)
    for (int y = y0; y < y1; ++y) std::copy(img.row(c, y) + x0, img.row(c, y) + x1, out.row(c, y - y0));
  return out;
}

Image abs_error_map(const Image& ref, const Image& test) {
  check_pair(ref, test, "error map");
  Image out(ref.width(), ref.height(), 1);
  core::parallel_for(
      ref.height(),
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y)
          for (int x = 0; x < ref.width(); ++x) {
            float s = 0;
            for (int c = 0; c < 3; ++c)
              s += std::abs(display_value(ref.row(c, y)[x]) - display_value(test.row(c, y)[x]));
            out.row(0, y)[x] = s / 3.0f;
          }
      },
      8);
  return out;
}

}  // namespace dofkit::metrics
