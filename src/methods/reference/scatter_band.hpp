// The hot loop of the disc scatter: every source that reaches a band of receiver rows adds
// its disc to the band's accumulators. Two implementations with the same arithmetic per
// receiver: a plain scalar loop (the test oracle) and a SIMD one (Highway, run-time dispatch).
#pragma once
#include <cstddef>

#include "core/aperture.hpp"

namespace dofkit::detail {

/// Sources are taken in blocks of this many consecutive pixels of one row (SIMD loop).
constexpr int kSourceBlock = 16;

struct BandJob {
  int w = 0, h = 0;    // image size
  int y0 = 0, y1 = 0;  // receiver rows [y0, y1)
  int reach = 0;       // largest disc extent (px)
  bool depth_order = true;
  float softness = 0.05f;  // relative inverse-depth softness (isu = 1/(softness·inv_z))
  // Per pixel (row-major, padded by at least 16 floats at the end so vector loads may run past
  // the last pixel): disc radius, sharpness max(|r|−0.5,0), inverse depth, 1/(softness·inv_z),
  // weight per unit coverage, colour planes.
  const float* rho = nullptr;
  const float* sharp = nullptr;
  const float* inv_z = nullptr;
  const float* isu = nullptr;
  const float* wscale = nullptr;
  const float* colour[4] = {};
  // SIMD loop only. ext: rows a source reaches above/below itself, ceil(ρ + 0.5) − 1;
  // block_ext: its maximum over each block of kSourceBlock sources of a row (row qy, block b at
  // qy·ceil(w / kSourceBlock) + b); dist: |(dx, dy)| for integer offsets, row |dy| at
  // dist + |dy|·dist_stride, column dx at index dx + dist_half (dist_half >= reach + 16).
  const int* ext = nullptr;
  const int* block_ext = nullptr;
  const float* dist = nullptr;
  int dist_half = 0;
  std::size_t dist_stride = 0;
  // Aperture other than the circle (null: the circle, with `dist` as above). Then `rho` is each
  // source's footprint radius (quantised to the bank's step for an aperture image), `coc` its
  // signed CoC (the field side), and the coverage of offset (dx, dy) is model->coverage(...)
  // for `channel`. SIMD loop: `dist` holds the model's gauge, rows dy = −reach … reach of the
  // far field, then those of the near field (dy at dist + (dy + reach + field·(2·reach + 1))·
  // dist_stride, dx at + dx + dist_half); an aperture image takes its rasters from `bank`
  // (bucket: each source's); eye_x/eye_y: each source's cat's-eye offset (null when off).
  const core::ApertureModel* model = nullptr;
  const float* coc = nullptr;
  int channel = 0;
  const core::KernelBank* bank = nullptr;
  const int* bucket = nullptr;
  const float* eye_x = nullptr;
  const float* eye_y = nullptr;
  // Accumulators: row r of stream k (F rgba, F w, B rgba, B w) at acc + (k·band + r)·stride;
  // stride >= w + 16 so vector stores may run past the last receiver.
  float* acc = nullptr;
  int band = 0;
  std::size_t stride = 0;
};

/// The hidden-background estimate of disc_scatter.cpp for rows [y0, y1), SIMD form (the
/// scalar loop there is its oracle; same arithmetic per receiver, so the same result).
struct HiddenJob {
  int w = 0, h = 0;
  const float* rho = nullptr;  // per pixel, padded like BandJob's
  const float* sharp = nullptr;
  const float* inv_z = nullptr;
  const float* colour[4] = {};
  const float* ox = nullptr;  // unit-disc sample offsets
  const float* oy = nullptr;
  int samples = 0;
  float keep = 0.95f;       // 1 − softness: "clearly behind" is inv_z below inv_z_p·keep
  float min_inv_z = 0.0f;   // smallest inverse depth in the image
  float* hidden = nullptr;  // out: 4 floats per pixel, alpha −1 = no estimate (rest 0)
};
void hidden_rows_simd(const HiddenJob& job, int y0, int y1);

void scatter_band_plain(const BandJob& job);
void scatter_band_simd(const BandJob& job);

}  // namespace dofkit::detail
