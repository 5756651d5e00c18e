// Pass 3 (sc2) — the raw occlusion term, plain oracle (the chapter's recap, §5.5, step by step).
// Inputs: full-res depth (the pixel's own position), the quarter-res depth (what the samples
// read), internal normals, Sc2Kernel. Outputs: the AO term (1 − the darker set's mean
// occlusion) and each set's AO. The Highway kernels (sc2_simd.cpp) compute the same values
// bit for bit: every operation below is a single IEEE float operation in this order, and both
// files are compiled without FMA contraction (CMakeLists.txt).
//
// Per pixel with finite z:
//  1. P = (kx·z, ky·z, z) (§5.4 listing: the eye ray scaled by the depth);
//  2. the screen-space radius limiter: s = min(1, limit_px · z / (radius · F)) scales both
//     sets' radii, so the wide set never covers more than limit_px on screen;
//  3. for each offset k of a set: v = k − 2 (k·r) r (reflected through the pixel's noise
//     vector r); v = −v if v·n < 0 (into the normal's hemisphere); S = P + v · R_set;
//  4. project S (u = S.x·F/S.z + W/2, …); behind the camera or off screen: a far depth (the
//     chapter's border colour), no occlusion; else z_s = the quarter-res texel under (u, v);
//  5. delta a = (S.z − z_s) / R_set (> 0: a surface in front of the sample point); occlusion =
//     the set's tabulated function of a (0 for a <= 0 and beyond the no-occlusion threshold);
//  6. each set's occlusion averaged; AO = 1 − the larger (darker) one.
#include <algorithm>
#include <cmath>
#include <limits>

#include "effects/ssao/ssao.hpp"

namespace dofkit::detail::ao {

void sc2_span_plain(const Camera& cam, const Image& depth, const Image& n, const Image& quarter, const Sc2Kernel& k,
                    const Sc2Out& out, int y, int x0, int x1) {
  const int w = cam.w, qw = quarter.width();
  const float fw = static_cast<float>(cam.w), fh = static_cast<float>(cam.h);
  const float inv_rf = 1.0f / (k.radius_wide * cam.f);
  const float* q = quarter.plane(0);
  const float inv_small = 1.0f / static_cast<float>(k.n_small), inv_wide = 1.0f / static_cast<float>(k.n_wide);
  {
    const float* zr = depth.row(0, y);
    const float *n0 = n.row(0, y), *n1 = n.row(1, y), *n2 = n.row(2, y);
    const int trow = (y % k.noise) * k.noise;
    for (int x = x0; x < x1; ++x) {
      const float z = zr[x];
      const std::size_t o = static_cast<std::size_t>(y) * w + x;
      if (!(z < std::numeric_limits<float>::infinity())) {
        out.ao[o] = 1.0f;
        if (out.small) out.small[o] = 1.0f;
        if (out.wide) out.wide[o] = 1.0f;
        continue;
      }
      const float px = cam.kx[x] * z, py = cam.ky[y] * z, pz = z;
      const float nx = n0[x], ny = n1[x], nz = n2[x];
      const int t = trow + x % k.noise;
      const float rx = k.nx[t], ry = k.ny[t], rz = k.nz[t];
      const float scale = std::min(1.0f, (k.limit_px * z) * inv_rf);
      float set_ao[2];
      for (int set = 0; set < 2; ++set) {
        const int i0 = set == 0 ? 0 : k.n_small, i1 = set == 0 ? k.n_small : k.n_small + k.n_wide;
        const float rs = (set == 0 ? k.radius_small : k.radius_wide) * scale;
        const float inv_rs = 1.0f / rs;
        const float* table = set == 0 ? k.table_small.data() : k.table_wide.data();
        const float tscale = set == 0 ? k.scale_small : k.scale_wide;
        float sum = 0.0f;
        for (int i = i0; i < i1; ++i) {
          const float d = (k.ox[i] * rx + k.oy[i] * ry) + k.oz[i] * rz;
          const float d2 = d + d;
          float vx = k.ox[i] - d2 * rx, vy = k.oy[i] - d2 * ry, vz = k.oz[i] - d2 * rz;
          if ((vx * nx + vy * ny) + vz * nz < 0.0f) {
            vx = -vx;
            vy = -vy;
            vz = -vz;
          }
          const float sx = px + vx * rs, sy = py + vy * rs, sz = pz + vz * rs;
          float occ = 0.0f;
          if (sz > 0.0f) {
            const float fi = cam.f / sz;
            const float u = sx * fi + cam.cx, v = sy * fi + cam.cy;
            if (u >= 0.0f && u < fw && v >= 0.0f && v < fh) {
              const int qx = static_cast<int>(u * k.q_scale + k.q_offset),
                        qy = static_cast<int>(v * k.q_scale + k.q_offset);
              const float a = (sz - q[qy * qw + qx]) * inv_rs;
              const float ta = a * tscale;
              if (a > 0.0f && ta < static_cast<float>(kTableSize)) occ = table[static_cast<int>(ta)];
            }
          }
          sum += occ;
        }
        set_ao[set] = 1.0f - sum * (set == 0 ? inv_small : inv_wide);
      }
      out.ao[o] = std::min(set_ao[0], set_ao[1]);
      if (out.small) out.small[o] = set_ao[0];
      if (out.wide) out.wide[o] = set_ao[1];
    }
  }
}

void sc2_rows_plain(const Camera& cam, const Image& depth, const Image& n, const Image& quarter, const Sc2Kernel& k,
                    const Sc2Out& out, int y0, int y1) {
  for (int y = y0; y < y1; ++y) sc2_span_plain(cam, depth, n, quarter, k, out, y, 0, cam.w);
}

}  // namespace dofkit::detail::ao
