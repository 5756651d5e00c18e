// Depth-ordered disc scatter (the reference method) — see docs/methods/reference.md.
//
// Each source pixel q with signed CoC r_q spreads its premultiplied colour over the pixels
// p within its disc, with coverage cov = saturate(ρ_q − |p − q| + 0.5), ρ = max(|r|, 0.5),
// and weight w = cov / A(ρ_q) where A is the exact sum of the coverages (so a disc carries
// exactly the energy of its source). A receiver p keeps two sums:
//   F — sources in front of p (they occlude p like a semi-transparent layer),
//   B — p's own surface and everything behind it.
// The output is F + (1 − min(1, ΣF_w)) · B / ΣB_w: front contributions composite "over" the
// normalised rest. The split is soft in inverse depth, so one continuous surface that
// crosses any depth never shows a seam (both halves then give the plain energy sum), and
// normalising B by its weight keeps image borders (clipped discs) at full brightness.
// A source behind the receiver reaches it only in proportion ρ'_p / ρ'_q
// (ρ' = max(|r| − 0.5, 0)): a sharp receiver is never covered by blurred background, a
// receiver blurred as much as the source lets it through.
#include "methods/reference/disc_scatter.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include "dofkit/error.hpp"

#include "core/parallel.hpp"
#include "core/sampling.hpp"
#include "methods/method.hpp"
#include "methods/reference/scatter_band.hpp"

namespace dofkit::detail {

double disc_area(double r) {
  const int n = static_cast<int>(std::ceil(r + 0.5));
  double sum = 0;
  for (int dy = -n; dy <= n; ++dy)
    for (int dx = -n; dx <= n; ++dx) {
      const double c = r - std::sqrt(double(dx) * dx + double(dy) * dy) + 0.5;
      sum += c <= 0 ? 0 : (c >= 1 ? 1 : c);
    }
  return sum;
}

namespace {

// clamp(lround(v), 0, hi) without the libm call: below 0.5 the result clamps to 0; from 0.5
// on, v + 0.5 is exact in float whenever rounding it could cross an integer, so truncating it
// gives lround's result (halves away from zero) bit for bit.
inline int round_clamp(float v, int hi) {
  if (!(v >= 0.5f)) return 0;
  const float t = v + 0.5f;
  return t >= static_cast<float>(hi) ? hi : static_cast<int>(t);
}

// Table of the footprint's weight sum at 1/32 px steps (disc_area for the circle, the aperture
// model's exact sum otherwise); A(r) is piecewise linear in r, so linear interpolation between
// table points is nearly exact.
class AreaTable {
 public:
  AreaTable(float rmax, const core::ApertureModel* model) {
    const int n = static_cast<int>(std::ceil(rmax * kSteps)) + 2;
    table_.resize(n);
    for (int i = 0; i < n; ++i) {
      const double r = double(i) / kSteps;
      // Radii below 0.5 never occur (rho >= 0.5); the model's sum needs rho >= 0.
      table_[i] = static_cast<float>(model ? model->weight_sum(static_cast<float>(r), core::Field::far) : disc_area(r));
    }
  }
  float operator()(float r) const {
    const float f = r * kSteps;
    int i = static_cast<int>(f);
    if (i >= static_cast<int>(table_.size()) - 1) i = static_cast<int>(table_.size()) - 2;
    const float t = f - i;
    return table_[i] + (table_[i + 1] - table_[i]) * t;
  }

 private:
  static constexpr int kSteps = 32;
  std::vector<float> table_;
};

}  // namespace

double scatter_work(const Image& coc) {
  double work = 0;
  const float* r = coc.plane(0);
  for (std::size_t i = 0, n = coc.plane_size(); i < n; ++i) {
    const double side = 2.0 * std::ceil(std::max(std::fabs(static_cast<double>(r[i])), 0.5) + 0.5) - 1.0;
    work += side * side;
  }
  return work;
}

namespace {

// Refuses (Error(usage)) a frame whose discs need more pixel visits than opt.max_work.
void check_work(const Image& coc, const DiscScatterOptions& opt, int channels) {
  // The cost bound first: with radii at the cap of a quarter of the width, the work grows
  // with the fourth power of the width (Σ r² over W·H sources): 55 s at 1280x720, an hour at
  // 4K. Refused before any buffer is made.
  if (opt.max_work > 0) {
    const double work = scatter_work(coc) * channels;
    if (work > opt.max_work) {
      float largest = 0;
      for (std::size_t i = 0; i < coc.plane_size(); ++i) largest = std::max(largest, std::fabs(coc.plane(0)[i]));
      char text[512];
      std::snprintf(text, sizeof text,
                    "%s: this frame's discs need %.3g pixel visits (largest radius %.0f px at %dx%d), more than the "
                    "limit of %.3g (--max-work); lower the blur (--max-coc, --blur-at-infinity, --f-number, "
                    "--near-radius / --far-radius, --max-radius), render a smaller image, use a gather method "
                    "(sterna, mcguire, starcraft) or raise --max-work",
                    opt.depth_order ? "reference" : "scatter", work, static_cast<double>(largest), coc.width(),
                    coc.height(), opt.max_work);
      throw_usage(text);
    }
  }
}

// One scatter with one coverage channel of the aperture (see disc_scatter).
void scatter_channel(const Image& colour, const Image& depth, const Image& coc, const DiscScatterOptions& opt,
                     int channel, Image& out) {
  const int w = colour.width(), h = colour.height();
  const std::size_t n = colour.plane_size();
  const core::ApertureModel* model = opt.aperture && !opt.aperture->is_circle() ? opt.aperture : nullptr;
  // Per-pixel precomputation: disc radius, sharpness, inverse depth, weight per unit coverage.
  // (+16 floats of padding: the SIMD loop may read a vector past the last pixel.)
  std::vector<float> rho(n + 16), sharpness(n + 16, 0.0f), inv_z(n + 16, 0.0f), isu(n + 16, 0.0f), wscale(n + 16);
  float rmax = 0.5f;
  const float soft = opt.depth_softness;
  for (std::size_t i = 0; i < n; ++i) {
    const float r = std::fabs(coc.plane(0)[i]);
    rho[i] = std::max(r, 0.5f);
    sharpness[i] = std::max(r - 0.5f, 0.0f);
    const float z = depth.plane(0)[i];
    inv_z[i] = std::isinf(z) ? 0.0f : 1.0f / z;
    isu[i] = inv_z[i] > 0 ? 1.0f / (soft * inv_z[i]) : 1e30f;
    rmax = std::max(rmax, rho[i]);
  }
  // An aperture image: rasters per radius, each source's radius quantised to the bank's step.
  std::optional<core::KernelBank> bank;
  std::vector<int> bucket;
  if (model && model->has_image()) {
    bank.emplace(*model, rmax, channel, 16);
    bucket.resize(n + 16, 0);
    rmax = 0.5f;
    for (std::size_t i = 0; i < n; ++i) {
      bucket[i] = bank->bucket(rho[i]);
      rho[i] = bank->bucket_rho(bucket[i]);
      rmax = std::max(rmax, rho[i]);
    }
  }
  // The cat's eye: each source's second-circle offset (and its own exact normaliser).
  std::vector<float> eye_x, eye_y;
  if (model && model->position_dependent()) {
    eye_x.resize(n + 16, 0.0f);
    eye_y.resize(n + 16, 0.0f);
    core::parallel_for(h, [&](int y0, int y1) {
      for (int y = y0; y < y1; ++y)
        for (int x = 0; x < w; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * w + x;
          const core::Field f = core::field_of(coc.plane(0)[i]);
          model->eye_offset(rho[i], f, x + 0.5f, y + 0.5f, eye_x[i], eye_y[i]);
          wscale[i] = static_cast<float>(1.0 / model->weight_sum(rho[i], f, x + 0.5f, y + 0.5f, channel));
        }
    });
  } else if (bank) {
    for (std::size_t i = 0; i < n; ++i) wscale[i] = static_cast<float>(1.0 / bank->sum(bucket[i]));
  } else {
    const AreaTable area(rmax + 1, model);
    for (std::size_t i = 0; i < n; ++i) wscale[i] = 1.0f / area(rho[i]);
  }
  const int reach = model ? model->reach(rmax) + 1 : static_cast<int>(std::ceil(rmax + 0.5f));

  // For the SIMD loop: how many rows each source reaches above and below itself, its maximum
  // per block of kSourceBlock sources (whole blocks that cannot reach a band are skipped), and
  // |(dx, dy)| for every integer offset it can meet, computed as the plain loop does
  // (sqrtf of an exact integer), so the coverage is the same bit for bit. With an aperture,
  // the table holds the model's gauge per field instead (rows dy = −reach … reach).
  std::vector<int> ext, block_ext;
  std::vector<float> dist;
  const int dist_half = reach + 16;
  const std::size_t dist_stride = static_cast<std::size_t>(2 * dist_half + 16);
  if (opt.simd) {
    ext.resize(n);
    const int nblk = (w + kSourceBlock - 1) / kSourceBlock;
    block_ext.assign(static_cast<std::size_t>(h) * nblk, 0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        ext[i] = model ? model->reach(rho[i]) : static_cast<int>(std::ceil(rho[i] + 0.5f)) - 1;
        int& be = block_ext[static_cast<std::size_t>(y) * nblk + x / kSourceBlock];
        be = std::max(be, ext[i]);
      }
    if (!model) {
      dist.resize(static_cast<std::size_t>(reach + 1) * dist_stride);
      for (int dy = 0; dy <= reach; ++dy)
        for (std::size_t i = 0; i < dist_stride; ++i) {
          const float dx = static_cast<float>(static_cast<int>(i) - dist_half), fdy = static_cast<float>(dy);
          dist[dy * dist_stride + i] = std::sqrt(dx * dx + fdy * fdy);
        }
    } else if (!bank) {
      const std::size_t rows = static_cast<std::size_t>(2 * reach + 1);
      dist.resize(2 * rows * dist_stride);
      core::parallel_for(static_cast<int>(2 * rows), [&](int r0, int r1) {
        for (int r = r0; r < r1; ++r) {
          const core::Field f = r < static_cast<int>(rows) ? core::Field::far : core::Field::near;
          const int dy = r % static_cast<int>(rows) - reach;
          for (std::size_t i = 0; i < dist_stride; ++i)
            dist[r * dist_stride + i] = model->gauge(static_cast<int>(i) - dist_half, dy, f);
        }
      });
    }
  }

  // Receivers are processed in fixed bands of rows; each band gathers the discs of every
  // source that can reach it, in a fixed order, so the result is the same for any thread count.
  constexpr int kBand = 8;
  const int bands = (h + kBand - 1) / kBand;
  // Hidden background. A blurred receiver is partly transparent: a real lens sees past it to
  // whatever lies behind, which one RGB-D layer does not hold. Where the discs that reach a
  // receiver cover less than all of it (a thin blurred bar over a sharp wall), the rest is
  // filled with an estimate of that hidden surface: the mean colour of the pixels within the
  // receiver's own radius that lie clearly behind it (a fixed 64-point concentric pattern).
  std::vector<float> hidden;  // 4 channels per pixel; alpha < 0 marks "no estimate"
  if (opt.depth_order) {
    hidden.assign(n * 4, 0.0f);
    constexpr int kGrid = 8;
    std::vector<float> ox, oy;  // unit-disc offsets: the concentric map of an 8×8 grid
    for (int j = 0; j < kGrid; ++j)
      for (int i = 0; i < kGrid; ++i) {
        double dx, dy;
        core::concentric_disc((i + 0.5) / kGrid, (j + 0.5) / kGrid, dx, dy);
        ox.push_back(static_cast<float>(dx));
        oy.push_back(static_cast<float>(dy));
      }
    const float min_inv_z = *std::min_element(inv_z.begin(), inv_z.begin() + static_cast<std::ptrdiff_t>(n));
    HiddenJob hj;
    hj.w = w;
    hj.h = h;
    hj.rho = rho.data();
    hj.sharp = sharpness.data();
    hj.inv_z = inv_z.data();
    for (int c = 0; c < 4; ++c) hj.colour[c] = colour.plane(c);
    hj.ox = ox.data();
    hj.oy = oy.data();
    hj.samples = static_cast<int>(ox.size());
    hj.keep = 1.0f - soft;
    hj.min_inv_z = min_inv_z;
    hj.hidden = hidden.data();
    core::parallel_for(h, [&](int y0, int y1) {
      if (opt.simd) {
        hidden_rows_simd(hj, y0, y1);
        return;
      }
      for (int y = y0; y < y1; ++y)
        for (int x = 0; x < w; ++x) {
          const std::size_t p = static_cast<std::size_t>(y) * w + x;
          float* hp = &hidden[p * 4];
          hp[3] = -1.0f;
          if (sharpness[p] <= 0.0f) continue;            // sharp receivers are opaque
          const float limit = inv_z[p] * (1.0f - soft);  // "clearly behind": inverse depth below this
          if (!(limit > min_inv_z)) continue;            // nothing in the image lies behind (e.g. the sky)
          float sum[4] = {0, 0, 0, 0};
          int count = 0;
          for (std::size_t k = 0; k < ox.size(); ++k) {
            const int qx = round_clamp(x + ox[k] * rho[p], w - 1);
            const int qy = round_clamp(y + oy[k] * rho[p], h - 1);
            const std::size_t q = static_cast<std::size_t>(qy) * w + qx;
            if (!(inv_z[q] < limit)) continue;
            for (int c = 0; c < 4; ++c) sum[c] += colour.plane(c)[q];
            ++count;
          }
          if (count == 0) continue;
          for (int c = 0; c < 4; ++c) hp[c] = sum[c] / count;
        }
    });
  }

  out.resize(w, h, 4);
  if (opt.progress) opt.progress->pass(0.05, 1.0, bands);
  const auto band_body = [&](int b0, int b1) {
    // Accumulators: 4 colour channels + weight, for the front (F) and back (B) sums.
    // Rows are padded so the ten accumulator streams do not sit a multiple of 4 KiB apart
    // (which made them collide in the same L1 sets and run 4x slower).
    const std::size_t stride = (static_cast<std::size_t>(w) + 15) / 16 * 16 + 16;
    std::vector<float> acc(static_cast<std::size_t>(kBand) * stride * 10);
    auto acc_row = [&](int k, int row) { return acc.data() + (static_cast<std::size_t>(k) * kBand + row) * stride; };
    for (int b = b0; b < b1; ++b) {
      const int y0 = b * kBand, y1 = std::min(h, y0 + kBand);
      std::fill(acc.begin(), acc.end(), 0.0f);
      BandJob job;
      job.w = w;
      job.h = h;
      job.y0 = y0;
      job.y1 = y1;
      job.reach = reach;
      job.depth_order = opt.depth_order;
      job.softness = soft;
      job.rho = rho.data();
      job.sharp = sharpness.data();
      job.inv_z = inv_z.data();
      job.isu = isu.data();
      job.wscale = wscale.data();
      job.ext = ext.data();
      job.block_ext = block_ext.data();
      job.dist = dist.data();
      job.dist_half = dist_half;
      job.dist_stride = dist_stride;
      if (model) {
        job.model = model;
        job.coc = coc.plane(0);
        job.channel = channel;
        job.bank = bank ? &*bank : nullptr;
        job.bucket = bucket.empty() ? nullptr : bucket.data();
        job.eye_x = eye_x.empty() ? nullptr : eye_x.data();
        job.eye_y = eye_y.empty() ? nullptr : eye_y.data();
      }
      for (int c = 0; c < 4; ++c) job.colour[c] = colour.plane(c);
      job.acc = acc.data();
      job.band = kBand;
      job.stride = stride;
      if (opt.simd)
        scatter_band_simd(job);
      else
        scatter_band_plain(job);
      for (int py = y0; py < y1; ++py) {
        const float* fw = acc_row(4, py - y0);
        const float* bw = acc_row(9, py - y0);
        for (int ch = 0; ch < 4; ++ch) {
          const float* fc = acc_row(ch, py - y0);
          const float* bc = acc_row(5 + ch, py - y0);
          const float* src = colour.row(ch, py);
          float* dst = out.row(ch, py);
          const float* hid = hidden.empty() ? nullptr : &hidden[static_cast<std::size_t>(py) * w * 4];
          for (int px = 0; px < w; ++px) {
            float v;
            // What the discs leave uncovered, the hidden-background estimate fills.
            const float missing = (hid && hid[px * 4 + 3] >= 0.0f) ? std::max(0.0f, 1.0f - fw[px] - bw[px]) : 0.0f;
            if (bw[px] + missing > 0) {
              const float fs = fw[px] > 1.0f ? 1.0f / fw[px] : 1.0f;
              const float back =
                  missing > 0 ? (bc[px] + missing * hid[px * 4 + ch]) / (bw[px] + missing) : bc[px] / bw[px];
              v = fc[px] * fs + (1.0f - std::min(fw[px], 1.0f)) * back;
            } else if (fw[px] > 0) {
              v = fc[px] / fw[px];
            } else {
              v = src[px];
            }
            dst[px] = v;
          }
        }
      }
    }
  };
  core::parallel_for(bands, with_progress(opt.progress, band_body));
}

}  // namespace

void disc_scatter(const Image& colour, const Image& depth, const Image& coc, const DiscScatterOptions& opt,
                  Image& out) {
  check_work(coc, opt, opt.aperture ? opt.aperture->channels() : 1);
  if (!opt.aperture || opt.aperture->channels() == 1) {
    scatter_channel(colour, depth, coc, opt, 0, out);
    return;
  }
  // RGB aperture image: one scatter per colour kernel; each run's colour channel c is kept,
  // and the alpha is the mean of the three runs' alphas.
  Image part;
  out.resize(colour.width(), colour.height(), 4);
  std::fill(out.plane(3), out.plane(3) + out.plane_size(), 0.0f);
  for (int c = 0; c < 3; ++c) {
    scatter_channel(colour, depth, coc, opt, c, part);
    std::copy(part.plane(c), part.plane(c) + part.plane_size(), out.plane(c));
    float* a = out.plane(3);
    const float* pa = part.plane(3);
    for (std::size_t i = 0; i < out.plane_size(); ++i) a[i] += pa[i];
  }
  float* a = out.plane(3);
  for (std::size_t i = 0; i < out.plane_size(); ++i) a[i] /= 3.0f;
}

}  // namespace dofkit::detail
