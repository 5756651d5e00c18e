// The prep pass of the fast form of `lens`: see lens_prepare.hpp.
#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "core/clones.hpp"
#include "core/parallel.hpp"
#include "core/pass_profile.hpp"
#include "methods/lens/footprint.hpp"
#include "methods/lens/kernels.hpp"
#include "methods/lens/lens.hpp"
#include "methods/lens/lens_prepare.hpp"
#include "methods/method.hpp"

namespace dofkit::detail::lens {

void prepare(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Prep& pr) {
  const int w = src.width(), h = src.height(), nf = src.count(), k = plan.count();
  pr.w = w;
  pr.h = h;
  pr.nf = nf;
  pr.k = k;
  pr.n = static_cast<std::size_t>(w) * h;
  const std::size_t n = pr.n, nn = n * nf;
  pr.slice.resize(nn);
  pr.t.resize(nn);
  pr.flags.assign(nn, 0);
  pr.inv_z.resize(n);
  if (nf > 1) {
    pr.weight.assign(n * (nf - 1), 0.0f);
    pr.trans.assign(n * (nf - 1), 0.0f);
    // Hidden fragments (Fragments in common.cpp): peeled with the visible surface unless
    // clearly behind it; then what the hidden ones in front let through.
    const float soft = opt.depth_softness;
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          for (std::size_t i = static_cast<std::size_t>(y0) * w; i < static_cast<std::size_t>(y1) * w; ++i) {
            const float u0 = inv_depth(src.depth[0]->plane(0)[i]);
            float through = 1.0f;
            for (int f = 1; f < nf; ++f) {
              const float uf = inv_depth(src.depth[f]->plane(0)[i]);
              const bool behind = uf > 0 ? (u0 - uf) >= soft * uf : u0 > 0;
              const std::size_t hq = (f - 1) * n + i;
              if (!behind) continue;
              const float a = src.colour[f]->plane(3)[i];
              pr.trans[hq] = through;
              pr.weight[hq] = a * through;
              through *= 1.0f - a;
            }
          }
        },
        8);
  }
  for (int f = 0; f < nf; ++f)
    mark_direct(*src.colour[f], *src.coc[f], f > 0 ? &pr.trans[(f - 1) * n] : nullptr, opt, &pr.flags[f * n], kDirect,
                &pr.block_sums);
  // Slices, existence, per-block sums and extents (combined in block order: deterministic).
  const int blocks = (h + kRowBlock - 1) / kRowBlock;
  const std::size_t bk = static_cast<std::size_t>(blocks) * k;
  std::vector<double> bmass(bk, 0.0), bu(bk, 0.0);
  std::vector<int> b_ylo[2], b_yhi[2], b_xlo[2], b_xhi[2];
  std::vector<std::uint8_t> b_sliced[2];
  for (int s = 0; s < 2; ++s) {
    b_ylo[s].assign(bk, h);
    b_yhi[s].assign(bk, -1);
    b_xlo[s].assign(bk, w);
    b_xhi[s].assign(bk, -1);
    b_sliced[s].assign(bk, 0);
  }
  std::vector<float> brho(blocks, 0.5f);
  const float r0 = opt.direct_px();
  pr.row_hl.assign(h, 0);
  pr.row_small.assign(h, 0);
  core::parallel_for(blocks, [&](int b0, int b1) {
    // Per row and slice: hat mass and mass · inverse depth (in double, as the plain form sums
    // them: the slice's depth decides which pixels are "clearly behind" it, and a whole row of
    // a receding surface shares one depth), and the columns touched.
    std::vector<double> rm(k), ru(k);
    std::vector<int> rx0(k), rx1(k);
    for (int b = b0; b < b1; ++b) {
      double* ms = &bmass[static_cast<std::size_t>(b) * k];
      double* us = &bu[static_cast<std::size_t>(b) * k];
      float rmax = 0.5f;
      for (int y = b * kRowBlock; y < std::min(h, (b + 1) * kRowBlock); ++y)
        for (int f = 0; f < nf; ++f) {
          const float* coc = src.coc[f]->row(0, y);
          const float* z = src.depth[f]->row(0, y);
          const int s = f > 0;
          std::fill(rm.begin(), rm.end(), 0.0);
          std::fill(ru.begin(), ru.end(), 0.0);
          std::fill(rx0.begin(), rx0.end(), w);
          std::fill(rx1.begin(), rx1.end(), -1);
          std::uint8_t* sl = &b_sliced[s][static_cast<std::size_t>(b) * k];
          const std::size_t row = static_cast<std::size_t>(y) * w;
          std::int16_t* slice = &pr.slice[f * n + row];
          float* tt = &pr.t[f * n + row];
          std::uint8_t* flags = &pr.flags[f * n + row];
          const float* wt = f > 0 ? &pr.weight[(f - 1) * n + row] : nullptr;
          int hl = 0, small = 0;
          for (int x = 0; x < w; ++x) {
            int j;
            float t;
            plan.member_fast(coc[x], j, t);
            slice[x] = static_cast<std::int16_t>(j);
            tt[x] = t;
            const float u = inv_depth(z[x]);
            if (f == 0) pr.inv_z[row + x] = u;
            if (wt && !(wt[x] > 0.0f)) {
              flags[x] = 0;
              continue;
            }
            std::uint8_t fl = flags[x] | kExists;
            const float rho = std::max(std::fabs(coc[x]), 0.5f);
            rmax = std::max(rmax, rho);
            if (fl & kDirect) {
              if (!(rho < r0)) {
                fl |= kHighlight;
                ++hl;
              } else if (rho > 0.5f || f > 0) {
                fl |= kSmall;
                ++small;
              }
            }
            flags[x] = fl;
            const float h0 = 1.0f - t;
            rm[j] += h0;
            ru[j] += static_cast<double>(h0) * u;
            rx0[j] = std::min(rx0[j], x);
            rx1[j] = x;
            if (!(fl & kDirect)) sl[j] = 1;
            if (t > 0.0f && j + 1 < k) {
              rm[j + 1] += t;
              ru[j + 1] += static_cast<double>(t) * u;
              rx0[j + 1] = std::min(rx0[j + 1], x);
              rx1[j + 1] = x;
              if (!(fl & kDirect)) sl[j + 1] = 1;
            }
          }
          pr.row_hl[y] += hl;
          pr.row_small[y] += small;
          for (int j = 0; j < k; ++j) {
            if (rx1[j] < 0) continue;
            ms[j] += rm[j];
            us[j] += ru[j];
            const std::size_t bj = static_cast<std::size_t>(b) * k + j;
            b_ylo[s][bj] = std::min(b_ylo[s][bj], y);
            b_yhi[s][bj] = y;
            b_xlo[s][bj] = std::min(b_xlo[s][bj], rx0[j]);
            b_xhi[s][bj] = std::max(b_xhi[s][bj], rx1[j]);
          }
        }
      brho[b] = rmax;
    }
  });
  pr.mass.assign(k, 0.0);
  pr.u_sum.assign(k, 0.0);
  for (int s = 0; s < 2; ++s) {
    pr.ylo[s].assign(k, h);
    pr.yhi[s].assign(k, -1);
    pr.xlo[s].assign(k, w);
    pr.xhi[s].assign(k, -1);
    pr.sliced[s].assign(k, 0);
  }
  pr.rho_max = 0.5f;
  for (int b = 0; b < blocks; ++b) {
    for (int j = 0; j < k; ++j) {
      const std::size_t bj = static_cast<std::size_t>(b) * k + j;
      pr.mass[j] += bmass[bj];
      pr.u_sum[j] += bu[bj];
      for (int s = 0; s < 2; ++s) {
        pr.ylo[s][j] = std::min(pr.ylo[s][j], b_ylo[s][bj]);
        pr.yhi[s][j] = std::max(pr.yhi[s][j], b_yhi[s][bj]);
        pr.xlo[s][j] = std::min(pr.xlo[s][j], b_xlo[s][bj]);
        pr.xhi[s][j] = std::max(pr.xhi[s][j], b_xhi[s][bj]);
        pr.sliced[s][j] |= b_sliced[s][bj];
      }
    }
    pr.rho_max = std::max(pr.rho_max, brho[b]);
  }
  pr.pad = opt.shape.reach(pr.rho_max) + 1;
  // Highlights (direct sources too large for the tiles' small-source window), per padded row
  // in padded-column order: the mirror copies of a row's highlights (few) in order of x'.
  const int pad = pr.pad;
  const int rows = h + 2 * pad;
  std::vector<int> count(rows, 0);
  for (int yp = -pad; yp < h + pad; ++yp) {
    const int y = mirror(yp, h);
    if (pr.row_hl[y] == 0) continue;
    for (int f = 0; f < nf; ++f) {
      const std::uint8_t* fl = &pr.flags[f * n + static_cast<std::size_t>(y) * w];
      if (pad > w) {  // a frame narrower than the padding: reflections repeat
        for (int xp = -pad; xp < w + pad; ++xp) count[yp + pad] += (fl[mirror(xp, w)] & kHighlight) != 0;
        continue;
      }
      for (int x = 0; x < w; ++x)
        if (fl[x] & kHighlight) count[yp + pad] += 1 + (x < pad) + (x >= w - pad);
    }
  }
  pr.hl_start.assign(static_cast<std::size_t>(rows) + 1, 0);
  for (int r = 0; r < rows; ++r) pr.hl_start[r + 1] = pr.hl_start[r] + count[r];
  pr.hl_x.resize(pr.hl_start[rows]);
  pr.hl_q.resize(pr.hl_start[rows]);
  core::parallel_for(rows, [&](int a, int b) {
    for (int r = a; r < b; ++r) {
      if (count[r] == 0) continue;
      const int y = mirror(r - pad, h);
      int e = pr.hl_start[r];
      for (int f = 0; f < nf; ++f) {
        const std::size_t base = f * n + static_cast<std::size_t>(y) * w;
        const std::uint8_t* fl = &pr.flags[base];
        auto put = [&](int xp, int x) {
          pr.hl_x[e] = xp;
          pr.hl_q[e] = base + x;
          ++e;
        };
        if (pad > w) {
          for (int xp = -pad; xp < w + pad; ++xp)
            if (fl[mirror(xp, w)] & kHighlight) put(xp, mirror(xp, w));
          continue;
        }
        for (int x = std::min(pad, w) - 1; x >= 0; --x)  // left copies: x' = −1 − x
          if (fl[x] & kHighlight) put(-1 - x, x);
        for (int x = 0; x < w; ++x)
          if (fl[x] & kHighlight) put(x, x);
        for (int x = w - 1; x >= std::max(0, w - pad); --x)  // right copies: x' = 2w − 1 − x
          if (fl[x] & kHighlight) put(2 * w - 1 - x, x);
      }
    }
  });
}

}  // namespace dofkit::detail::lens
