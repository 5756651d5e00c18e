// Pass 1 — view-space geometry.
// Inputs: the depth (planar z, metres) and, optionally, normals in the file convention.
// Outputs: the camera tables (Camera: kx, ky — a pixel's view position is (kx·z, ky·z, z), the
// chapter's §5.4 reconstruction: the pixel's normalised eye ray scaled by its depth) and unit
// normals in the effect's view space (x right, y down, z forward), turned towards the camera.
// Oracle: none needed — one scalar implementation serves both paths (row-parallel, each
// pixel computed alone, so the result does not depend on the thread count).
#include <cmath>
#include <limits>
#include <numbers>

#include "core/parallel.hpp"
#include "effects/ssao/ssao.hpp"

namespace dofkit::detail::ao {

namespace {

std::string at(int x, int y) { return "(" + std::to_string(x) + ", " + std::to_string(y) + ")"; }

std::string text(float v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", static_cast<double>(v));
  return b;
}

}  // namespace

Camera make_camera(int w, int h, double hfov_deg) {
  if (!(hfov_deg > 0 && hfov_deg < 180)) throw_usage("field of view: must be in (0, 180) degrees");
  Camera c;
  c.w = w;
  c.h = h;
  c.f = static_cast<float>(0.5 * w / std::tan(0.5 * hfov_deg * std::numbers::pi / 180.0));
  c.inv_f = 1.0f / c.f;
  c.cx = 0.5f * static_cast<float>(w);
  c.cy = 0.5f * static_cast<float>(h);
  fill_rays(c);
  return c;
}

void fill_rays(Camera& c) {
  c.kx.resize(c.w);
  c.ky.resize(c.h);
  for (int x = 0; x < c.w; ++x) c.kx[x] = (static_cast<float>(x) + 0.5f - c.cx) * c.inv_f;
  for (int y = 0; y < c.h; ++y) c.ky[y] = (static_cast<float>(y) + 0.5f - c.cy) * c.inv_f;
}

void check_inputs(const Image& depth, const Image* normals) {
  if (depth.empty() || depth.channels() < 1) throw_bad_input("depth: empty image");
  const int w = depth.width(), h = depth.height();
  if (normals) {
    if (normals->channels() < 3)
      throw_bad_input("normals: need 3 channels (X, Y, Z), got " + std::to_string(normals->channels()));
    if (!normals->same_size(depth))
      throw_bad_input("normals: size " + std::to_string(normals->width()) + "x" + std::to_string(normals->height()) +
                      " does not match the depth's " + std::to_string(w) + "x" + std::to_string(h));
  }
  for (int y = 0; y < h; ++y) {
    const float* z = depth.row(0, y);
    for (int x = 0; x < w; ++x) {
      if (!(z[x] > 0))
        throw_bad_input("depth: invalid value " + text(z[x]) + " at pixel " + at(x, y) + " (z must be > 0 or +inf)");
      if (!normals || std::isinf(z[x])) continue;
      const float a = normals->row(0, y)[x], b = normals->row(1, y)[x], c = normals->row(2, y)[x];
      const float len2 = a * a + b * b + c * c;
      if (!std::isfinite(len2) || len2 < 1e-6f)
        throw_bad_input("normals: invalid normal (" + text(a) + ", " + text(b) + ", " + text(c) + ") at pixel " +
                        at(x, y) + " (a finite, non-zero vector is needed wherever the depth is finite)");
    }
  }
}

void normals_from_input(const Image& normals, const Image& depth, Image& out) {
  const int w = depth.width();
  out.resize(w, depth.height(), 3);
  core::parallel_for(
      depth.height(),
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* z = depth.row(0, y);
          const float *a = normals.row(0, y), *b = normals.row(1, y), *c = normals.row(2, y);
          float *o0 = out.row(0, y), *o1 = out.row(1, y), *o2 = out.row(2, y);
          for (int x = 0; x < w; ++x) {
            if (std::isinf(z[x])) {
              o0[x] = o1[x] = o2[x] = 0;
              continue;
            }
            const float inv = 1.0f / std::sqrt(a[x] * a[x] + b[x] * b[x] + c[x] * c[x]);
            o0[x] = a[x] * inv;
            o1[x] = -b[x] * inv;
            o2[x] = -c[x] * inv;
          }
        }
      },
      8);
}

void normals_from_depth(const Image& depth, const Camera& cam, Image& out) {
  const int w = depth.width(), h = depth.height();
  out.resize(w, h, 3);
  const auto pos = [&](int x, int y, float p[3]) {
    const float z = depth.row(0, y)[x];
    p[0] = cam.kx[x] * z;
    p[1] = cam.ky[y] * z;
    p[2] = z;
  };
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y)
          for (int x = 0; x < w; ++x) {
            const float z = depth.row(0, y)[x];
            float* o[3] = {out.row(0, y) + x, out.row(1, y) + x, out.row(2, y) + x};
            if (std::isinf(z)) {
              *o[0] = *o[1] = *o[2] = 0;
              continue;
            }
            float p[3], d[2][3];
            pos(x, y, p);
            bool ok[2] = {false, false};
            // Per axis, the one-sided difference towards the neighbour of nearer depth (the
            // side that is most likely on the same surface).
            for (int axis = 0; axis < 2; ++axis) {
              float best = std::numeric_limits<float>::infinity();
              for (int side : {-1, 1}) {
                const int nx = axis == 0 ? x + side : x, ny = axis == 1 ? y + side : y;
                if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
                const float zn = depth.row(0, ny)[nx];
                if (std::isinf(zn) || !(std::abs(zn - z) < best)) continue;
                best = std::abs(zn - z);
                float q[3];
                pos(nx, ny, q);
                for (int k = 0; k < 3; ++k) d[axis][k] = side > 0 ? q[k] - p[k] : p[k] - q[k];
                ok[axis] = true;
              }
            }
            float n[3] = {-p[0], -p[1], -p[2]};  // fallback: facing the camera
            if (ok[0] && ok[1]) {
              n[0] = d[0][1] * d[1][2] - d[0][2] * d[1][1];
              n[1] = d[0][2] * d[1][0] - d[0][0] * d[1][2];
              n[2] = d[0][0] * d[1][1] - d[0][1] * d[1][0];
              if (n[0] * p[0] + n[1] * p[1] + n[2] * p[2] > 0)
                for (float& v : n) v = -v;
            }
            const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            for (int k = 0; k < 3; ++k) *o[k] = len > 0 ? n[k] / len : (k == 2 ? -1.0f : 0.0f);
          }
      },
      8);
}

}  // namespace dofkit::detail::ao
