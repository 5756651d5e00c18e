#include "core/filters.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/parallel.hpp"
#include "core/strip.hpp"

namespace dofkit::core {

namespace {

// Microseconds for n dependent float multiplies starting from x (the asm keeps each product
// in a register, so none is folded or vectorised away).
double multiply_chain_us(float x, int n) {
  const float c = 0.9999f;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    x *= c;
#if defined(__x86_64__) || defined(__i386__)
    asm volatile("" : "+x"(x));
#else
    asm volatile("" : "+w"(x));
#endif
  }
  const auto t1 = std::chrono::steady_clock::now();
  volatile float sink = x;
  (void)sink;
  return std::chrono::duration<double, std::micro>(t1 - t0).count();
}

bool subnormal_multiplies_slow() {
  double normal = 1e30, subnormal = 1e30;
  for (int r = 0; r < 3; ++r) {  // ≈ 10 µs without an assist, ≈ 0.2 ms where it costs ~20×
    normal = std::min(normal, multiply_chain_us(1.0f, 1024));
    subnormal = std::min(subnormal, multiply_chain_us(1e-40f, 1024));  // stays subnormal: 1e-40 · 0.9999^1024 ≈ 9e-41
  }
  return subnormal >= 4.0 * normal;
}

std::atomic<int> g_exact_tiny_mode{-1};

}  // namespace

bool exact_tiny_multiplies() {
  const int mode = g_exact_tiny_mode.load(std::memory_order_relaxed);
  if (mode >= 0) return mode != 0;
  static const bool slow = subnormal_multiplies_slow();
  return slow;
}

void set_exact_tiny_multiplies(int mode) {
  g_exact_tiny_mode.store(mode < 0 ? -1 : (mode ? 1 : 0), std::memory_order_relaxed);
}

namespace {
inline int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }
}  // namespace

void extended_box_params(float sigma, int passes, int& r, float& alpha) {
  // One pass of weights {alpha at ±(r+1), 1 for |i| <= r} / (2r + 1 + 2 alpha) has variance
  // (r(r+1)(2r+1)/3 + 2 alpha (r+1)²) / (2r + 1 + 2 alpha). Setting it to s = sigma²/passes
  // and solving for alpha gives the expression below; choosing r = floor((sqrt(12 s + 1) − 1)/2)
  // keeps alpha in [0, 1).
  const double s = static_cast<double>(sigma) * sigma / passes;
  r = static_cast<int>(std::floor((std::sqrt(12.0 * s + 1.0) - 1.0) / 2.0));
  if (r < 0) r = 0;
  const double rr = r;
  double a = (2 * rr + 1) * (s - rr * (rr + 1) / 3.0) / (2.0 * ((rr + 1) * (rr + 1) - s));
  alpha = static_cast<float>(std::clamp(a, 0.0, 1.0));
}

void extended_box_x_plain(float* data, int w, int h, int r, float alpha) {
  const double norm = 1.0 / (2.0 * r + 1.0 + 2.0 * alpha);
  parallel_for(
      h,
      [&](int y0, int y1) {
        std::vector<float> row(w);
        for (int y = y0; y < y1; ++y) {
          float* p = data + static_cast<std::size_t>(y) * w;
          std::copy(p, p + w, row.begin());
          auto at = [&](int i) { return static_cast<double>(row[clampi(i, 0, w - 1)]); };
          double sum = 0;
          for (int i = -r; i <= r; ++i) sum += at(i);
          for (int x = 0; x < w; ++x) {
            p[x] = static_cast<float>((sum + alpha * (at(x - r - 1) + at(x + r + 1))) * norm);
            sum += at(x + r + 1) - at(x - r);
          }
        }
      },
      8);
}

void extended_box_y_plain(float* data, int w, int h, int r, float alpha) {
  const double norm = 1.0 / (2.0 * r + 1.0 + 2.0 * alpha);
  constexpr int kBlock = 64;
  const int blocks = (w + kBlock - 1) / kBlock;
  parallel_for(blocks, [&](int b0, int b1) {
    std::vector<float> col(static_cast<std::size_t>(h) * kBlock);
    std::vector<double> sum(kBlock);
    for (int b = b0; b < b1; ++b) {
      const int x0 = b * kBlock, nx = std::min(kBlock, w - x0);
      for (int y = 0; y < h; ++y)
        std::copy(data + static_cast<std::size_t>(y) * w + x0, data + static_cast<std::size_t>(y) * w + x0 + nx,
                  col.begin() + y * kBlock);
      auto rowp = [&](int y) { return col.data() + static_cast<std::size_t>(clampi(y, 0, h - 1)) * kBlock; };
      std::fill(sum.begin(), sum.end(), 0.0);
      for (int i = -r; i <= r; ++i) {
        const float* q = rowp(i);
        for (int x = 0; x < nx; ++x) sum[x] += q[x];
      }
      for (int y = 0; y < h; ++y) {
        const float* lo = rowp(y - r - 1);
        const float* hi = rowp(y + r + 1);
        const float* out_lo = rowp(y - r);
        float* dst = data + static_cast<std::size_t>(y) * w + x0;
        for (int x = 0; x < nx; ++x) {
          dst[x] = static_cast<float>((sum[x] + alpha * (static_cast<double>(lo[x]) + hi[x])) * norm);
          sum[x] += static_cast<double>(hi[x]) - out_lo[x];
        }
      }
    }
  });
}

void box_blur_plane_plain(const float* src, float* dst, int w, int h, int rx, int ry) {
  if (src != dst) std::copy(src, src + static_cast<std::size_t>(w) * h, dst);
  if (rx > 0) extended_box_x_plain(dst, w, h, rx, 0.0f);
  if (ry > 0) extended_box_y_plain(dst, w, h, ry, 0.0f);
}

void gaussian_blur_plane_plain(float* data, int w, int h, float sigma_x, float sigma_y, int passes) {
  if (w <= 0 || h <= 0) return;
  if (sigma_x > 0) {
    int r;
    float a;
    extended_box_params(sigma_x, passes, r, a);
    for (int i = 0; i < passes; ++i) extended_box_x_plain(data, w, h, r, a);
  }
  if (sigma_y > 0) {
    int r;
    float a;
    extended_box_params(sigma_y, passes, r, a);
    for (int i = 0; i < passes; ++i) extended_box_y_plain(data, w, h, r, a);
  }
}

void gaussian_blur_plain(Image& img, float sigma, int passes) {
  if (!(sigma > 0)) return;
  for (int c = 0; c < img.channels(); ++c)
    gaussian_blur_plane_plain(img.plane(c), img.width(), img.height(), sigma, sigma, passes);
}

// ---------------------------------------------------------------------------------------
// Fast forms.
//
// A strip is kLanes independent 1-D signals stored interleaved: buf[(i + pad) * kLanes + j]
// is sample i of signal j, for i in [−pad, n + pad). For the vertical pass the signals are
// kLanes adjacent columns (a plain copy), for the horizontal pass kLanes adjacent rows
// (a transpose). The clamp-to-edge border becomes pad replicated samples, so the sliding
// window loop has no branches and every lane runs the same instructions (SIMD across j).
//
// The box passes themselves are strip::strip_passes (core/strip.cpp), shared with
// core/weighted_gaussian.cpp; its header comment gives their precision.

namespace {

constexpr int kLanes = strip::kStripLanes;
using strip::strip_passes;

/// Per-thread strip scratch (two buffers), grown on demand and kept: no allocation per frame.
/// 64-byte aligned (the vector's own storage is 16-byte aligned; a 1080p strip pair is an
/// mmap'd chunk at 16 mod 64), so that no strip sample, one 16-lane vector of strip_passes,
/// straddles two cache lines; floats is a multiple of kLanes, so b = a + floats is aligned too.
float* strip_scratch(std::size_t floats) {
  thread_local std::vector<float> buf;
  if (buf.size() < 2 * floats + kLanes) buf.resize(2 * floats + kLanes);
  const std::size_t mis = reinterpret_cast<std::uintptr_t>(buf.data()) % 64;
  return buf.data() + (64 - mis) % 64 / sizeof(float);
}

using strip::load_rows_transposed;
using strip::store_rows_transposed;

}  // namespace

void extended_box_passes_x(float* data, int w, int h, int r, float alpha, int passes) {
  if (w <= 0 || h <= 0 || passes <= 0) return;
  const int pad = r + 1;
  const std::size_t strip = static_cast<std::size_t>(w + 2 * pad) * kLanes;
  const int strips = (h + kLanes - 1) / kLanes;
  parallel_for(strips, [&](int s0, int s1) {
    float* a = strip_scratch(strip);
    float* b = a + strip;
    for (int s = s0; s < s1; ++s) {
      const int y0 = s * kLanes, ny = std::min(kLanes, h - y0);
      float* rows[kLanes];
      // Lanes past the last row repeat it (their results are discarded).
      for (int j = 0; j < kLanes; ++j) rows[j] = data + static_cast<std::size_t>(y0 + std::min(j, ny - 1)) * w;
      load_rows_transposed(rows, w, nullptr, a + static_cast<std::size_t>(pad) * kLanes);
      const float* res = strip_passes(a, b, w, pad, r, alpha, passes);
      store_rows_transposed(res + static_cast<std::size_t>(pad) * kLanes, w, rows, ny);
    }
  });
}

void extended_box_passes_y(float* data, int w, int h, int r, float alpha, int passes) {
  if (w <= 0 || h <= 0 || passes <= 0) return;
  const int pad = r + 1;
  const std::size_t strip = static_cast<std::size_t>(h + 2 * pad) * kLanes;
  const int strips = (w + kLanes - 1) / kLanes;
  parallel_for(strips, [&](int s0, int s1) {
    float* a = strip_scratch(strip);
    float* b = a + strip;
    for (int s = s0; s < s1; ++s) {
      const int x0 = s * kLanes, nx = std::min(kLanes, w - x0);
      // Lanes past the last column repeat it (their results are discarded).
      strip::load_columns(data + x0, static_cast<std::size_t>(w), h, nx, a + static_cast<std::size_t>(pad) * kLanes);
      const float* res = strip_passes(a, b, h, pad, r, alpha, passes) + static_cast<std::size_t>(pad) * kLanes;
      strip::store_columns(res, h, nx, data + x0, static_cast<std::size_t>(w));
    }
  });
}

void extended_box_x(float* data, int w, int h, int r, float alpha) { extended_box_passes_x(data, w, h, r, alpha, 1); }
void extended_box_y(float* data, int w, int h, int r, float alpha) { extended_box_passes_y(data, w, h, r, alpha, 1); }

void box_blur_plane(const float* src, float* dst, int w, int h, int rx, int ry) {
  if (src != dst) std::copy(src, src + static_cast<std::size_t>(w) * h, dst);
  if (rx > 0) extended_box_passes_x(dst, w, h, rx, 0.0f, 1);
  if (ry > 0) extended_box_passes_y(dst, w, h, ry, 0.0f, 1);
}

void gaussian_blur_plane(float* data, int w, int h, float sigma_x, float sigma_y, int passes) {
  if (w <= 0 || h <= 0) return;
  if (sigma_x > 0) {
    int r;
    float a;
    extended_box_params(sigma_x, passes, r, a);
    extended_box_passes_x(data, w, h, r, a, passes);
  }
  if (sigma_y > 0) {
    int r;
    float a;
    extended_box_params(sigma_y, passes, r, a);
    extended_box_passes_y(data, w, h, r, a, passes);
  }
}

void gaussian_blur(Image& img, float sigma, int passes) {
  if (!(sigma > 0)) return;
  for (int c = 0; c < img.channels(); ++c)
    gaussian_blur_plane(img.plane(c), img.width(), img.height(), sigma, sigma, passes);
}

float sample_bilinear(const float* plane, int w, int h, float x, float y) {
  const float fx = x - 0.5f, fy = y - 0.5f;
  const float x0f = std::floor(fx), y0f = std::floor(fy);
  const float tx = fx - x0f, ty = fy - y0f;
  const int x0 = static_cast<int>(x0f), y0 = static_cast<int>(y0f);
  const int xa = clampi(x0, 0, w - 1), xb = clampi(x0 + 1, 0, w - 1);
  const int ya = clampi(y0, 0, h - 1), yb = clampi(y0 + 1, 0, h - 1);
  const float* ra = plane + static_cast<std::size_t>(ya) * w;
  const float* rb = plane + static_cast<std::size_t>(yb) * w;
  const float top = ra[xa] + (ra[xb] - ra[xa]) * tx;
  const float bot = rb[xa] + (rb[xb] - rb[xa]) * tx;
  return top + (bot - top) * ty;
}

}  // namespace dofkit::core
