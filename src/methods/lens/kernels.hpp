// The SIMD row kernels of lens's tiles (Highway, run-time dispatch; kernels.cpp). Each works
// on one row segment of a tile: n receivers, planar arrays indexed from the segment's first
// receiver. They compute what add_source / composite (common.hpp) compute per receiver, up to
// the rounding of fused multiply-adds and the order of the sums (tests/lens/ compare the
// whole fast path with the plain form).
#pragma once
#include <cstddef>
#include <cstdint>

namespace dofkit::detail::lens {

/// The receivers of a row segment and their accumulators (F rgba w, B rgba w, fill rgba w).
struct RowReceivers {
  int n = 0;
  const float* u = nullptr;      // inverse depth
  const float* isu = nullptr;    // 1 / (softness · inverse depth)
  const float* sharp = nullptr;  // max(|r| − 0.5, 0)
  float* acc[15] = {};
};

/// One slice read back at the receivers of a segment: its sums at coarse row pair (Y0, Y0 + 1)
/// already interpolated vertically into `row` (5 channels, indexed by cell column), sampled
/// horizontally at each receiver's bilinear position.
struct FoldRow {
  const float* row[5] = {};
  int x0 = 0;           // frame column of the segment's first receiver
  int level = 1;        // cells of 2^level px
  int margin = 0;       // cell columns left of the frame
  float norm = 1.0f;    // 1 / 4^level (energy per cell → per pixel)
  float su = 0.0f;      // the slice's inverse depth
  float ssharp = 0.0f;  // its sharpness
  bool hidden = false;  // a hidden-fragment slice (fill rule)
};
void fold_row(const FoldRow& f, const RowReceivers& r);

/// A slice's hidden-background estimate at the receivers of a segment that belong to it (hat
/// weight 1 − t if slice == j, t if slice == j − 1; none for in-focus receivers).
struct EstRow {
  const float* row[5] = {};
  int x0 = 0, level = 1, margin = 0, j = 0;
  const std::int32_t* slice = nullptr;
  const float* t = nullptr;
  const float* sharp = nullptr;
  float* est[5] = {};
  int n = 0;
};
void est_row(const EstRow& e);

/// One direct source on one receiver row: receivers at dx = dx0 … dx0 + n − 1 from it.
struct DirectRow {
  float dx0 = 0.0f, dy = 0.0f;
  float rho = 0.5f, ws = 1.0f;  // radius and 1 / area
  float c[5] = {};              // rgba, weight
  float su = 0.0f, ssharp = 0.0f;
  bool hidden = false;
};
void direct_row(const DirectRow& d, const RowReceivers& r);

/// The receivers of a tile: planes of `stride` floats per row (rows 0 … rows − 1, columns
/// 0 … cols − 1; kernels may run up to 16 lanes past a row's end).
struct TileReceivers {
  int rows = 0, cols = 0;
  std::size_t stride = 0;
  const float* u = nullptr;
  const float* isu = nullptr;
  const float* sharp = nullptr;
  float* acc[15] = {};
};

/// One direct source over the receivers of a tile: its exact footprint (the reference's disc,
/// row spans as the reference computes them, or an analytic aperture: coverage
/// sat(lim − T(dx, dy)) from a gauge table), centred at tile column qx, row qy.
struct DirectSource {
  int qx = 0, qy = 0;
  float rho = 0.5f, ws = 1.0f;  // radius and 1 / area
  // An analytic aperture (gauge null: the circle): T(dx, dy) at gauge[dy · pitch + dx] for
  // |dx|, |dy| <= reach, readable up to 32 floats past dx = reach; lim = the model's lim(rho).
  const float* gauge = nullptr;
  std::ptrdiff_t pitch = 0;
  int reach = 0;
  float lim = 1.0f;
  float c[5] = {};  // rgba, weight
  float su = 0.0f, ssharp = 0.0f;
  bool hidden = false;
};
void direct_source(const DirectSource& d, const TileReceivers& r);

/// The composite of a segment: acc (15 planes; 10 unless `hidden`), est (5 planes), the
/// receivers' own colour (4 planes) → out (4 planes); cover (3 planes, may be null): F weight,
/// B weight, filled share. src and out may be the frame's rows (nothing past n is touched).
struct CompositeRow {
  int n = 0;
  bool hidden = false;
  const float* acc[15] = {};
  const float* est[5] = {};
  const float* src[4] = {};
  float* out[4] = {};
  float* cover[3] = {};
};
void composite_row(const CompositeRow& c);

}  // namespace dofkit::detail::lens
