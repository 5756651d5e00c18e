// The fused Gaussian stack (render_gaussian_fused, see fast.hpp): the order of its passes —
// the code pass, then per non-empty layer a composite pass (with the next layer's push-pull
// pull in the same pass) and the blur of the accumulator at the resolution it runs at, then
// the final composite — and the buffers they share. The passes are in fused_code.cpp,
// fused_composite.cpp, fused_pull.cpp, fast_push_pull.cpp and fused_final.cpp. Oracle:
// impl=plain (layered.cpp's per-layer path over matting.cpp, inpaint.cpp, composite.cpp);
// tests/layered/fast_test.cpp compare the two bit for bit.
#include <atomic>
#include <cmath>
#include <string>
#include <vector>

#include "core/filters.hpp"
#include "core/pass_profile.hpp"
#include "methods/layered/fast.hpp"
#include "methods/layered/fast_push_pull.hpp"
#include "methods/layered/fused_passes.hpp"

namespace dofkit::detail::layered {

namespace {
std::atomic<std::uint64_t> g_fused_renders{0};
}  // namespace

std::uint64_t fused_render_count() { return g_fused_renders.load(); }

bool render_gaussian_fused(const MethodContext& ctx, const Fragments& frags, const LayerPlan& plan, bool half_res,
                           bool quarter_res, bool do_fill, bool fill_under, Image& out) {
  if (frags.color.size() != 1 || plan.count > 16) return false;
  // Debug views need the stored layers and accumulators: the per-layer path provides them.
  for (const char* v : {"front", "back"})
    if (ctx.debug.wants(v)) return false;
  for (int k = 0; k < 16; ++k)
    for (const char* suffix : {"_matted", "_blurred"})
      if (ctx.debug.wants(("layer_" + std::to_string(k) + suffix).c_str())) return false;

  const Image& color = *frags.color[0];
  const Image& coc = *frags.coc[0];
  const int w = color.width(), h = color.height(), K = plan.count;
  Workspace& ws = ctx.workspace;
  const std::size_t npix = static_cast<std::size_t>(w) * h;
  float* w0 = ws.image("layered.w0", w, h, 1).plane(0);
  std::uint16_t* code = ws.plane<std::uint16_t>("layered.code", npix);

  // Code pass (fused_code.cpp): the layers each pixel has a non-zero matte in, its holes.
  const int nb = (w + kBlock - 1) / kBlock;
  const std::size_t nblocks = static_cast<std::size_t>(nb) * h;
  std::uint32_t* bpres = ws.plane<std::uint32_t>("layered.block_layers", nblocks);
  std::uint32_t* bhk = ws.plane<std::uint32_t>("layered.block_holes", nblocks);
  std::uint32_t* bspan = ws.plane<std::uint32_t>("layered.spans", 16 * nblocks);
  std::uint32_t* bhole = ws.plane<std::uint32_t>("layered.holes", 16 * nblocks);
  CodeSummary codes;
  {
    core::PassScope pass("code pass");
    codes = code_pass(color, coc, plan, do_fill, {w0, code, bpres, bhk, bspan, bhole, nb});
  }
  if (!codes.ok) return false;
  const std::uint32_t ne = codes.nonempty, ho = codes.holes;
  auto is_full = [&](int k) { return ((ne >> k) & 1u) != 0; };

  auto layer_gen = [&](int k, bool opaque) {
    FusedLayer L;
    L.color = &color;
    L.w0 = w0;
    L.code = code;
    L.w = w;
    L.h = h;
    L.k = k;
    L.fill = do_fill && is_full(k) && ((ho >> k) & 1u);
    L.opaque = opaque;
    L.under = fill_under;
    L.bpres = bpres;
    L.bhk = bhk;
    L.bspan = bspan;
    L.bhole = bhole;
    L.nb = nb;
    return L;
  };

  // The recursion of composite.cpp's Accumulator, as a list of composite jobs: each non-empty
  // layer is composited, then blurred by what plain applies at its next flush — the variance
  // of the steps up to the next non-empty layer of that side, summed in plain's order — so
  // the composite can be written straight at the resolution that blur runs at.
  struct Job {
    int k;
    bool back;
    double var;
  };
  std::vector<Job> jobs;
  auto add_side = [&](const std::vector<int>& order, bool back_side) {
    std::vector<double> var_after(K, 0.0);
    double pend = 0;
    int last = -1;
    for (int k : order) {
      if (is_full(k)) {
        if (last >= 0) var_after[last] = pend;
        pend = 0;
        last = k;
      }
      if (last >= 0) pend += plan.step_sigma[k] * plan.step_sigma[k];
    }
    if (last >= 0) var_after[last] = pend;
    for (int k : order)
      if (is_full(k)) jobs.push_back({k, back_side, var_after[k]});
  };
  std::vector<int> back_order, front_order;
  for (int k = K - 1; k > plan.focus; --k) back_order.push_back(k);
  for (int k = 0; k < plan.focus; ++k) front_order.push_back(k);
  add_side(back_order, true);
  const std::size_t n_back = jobs.size();
  add_side(front_order, false);
  const bool focus_full = is_full(plan.focus);

  // The layers in processing order (jobs, then the focus layer for the final pass). The
  // first back layer and, without back layers, the focus layer are filled opaque.
  std::vector<FusedLayer> units;
  for (std::size_t i = 0; i < jobs.size(); ++i) units.push_back(layer_gen(jobs[i].k, jobs[i].back && i == 0));
  if (focus_full) units.push_back(layer_gen(plan.focus, n_back == 0));
  // Two push-pull pyramids: layer i + 1's level 1 is pulled during layer i's composite pass.
  const Pyramid pyr[2] = {make_pyramid(ws, w, h, "layered.pp"), make_pyramid(ws, w, h, "layered.pq")};
  const bool pyramid = pyr[0].levels > 1;
  auto needs_pull = [&](std::size_t u) { return u < units.size() && units[u].fill && pyramid; };
  // Level 2 (if the pyramid has one) is pulled in the pass that pulls level 1.
  const bool has_l2 = pyr[0].levels > 2;
  auto finish_pull = [&](std::size_t u) {
    pull_push_upper(pyr[u % 2], has_l2 ? 3 : 2);
    units[u].l1 = pyr[u % 2].val[1];
  };
  if (needs_pull(0)) {
    core::PassScope pass("fill pull");
    pull_from_layer(units[0], *pyr[0].val[1], *pyr[0].wgt[1], has_l2 ? pyr[0].val[2] : nullptr,
                    has_l2 ? pyr[0].wgt[2] : nullptr);
    finish_pull(0);
  }

  struct Side {
    const Image* full = nullptr;
    const Image* half = nullptr;  // reduced by `factor`
    int factor = 2;
    bool has = false;
    int flip = 0, flip_q = 0;
    ZeroMap zero;  // where `half` is +0 (valid while `half` is)
  };
  // Zero maps of the two sides (one byte per coarse row and column block).
  const int nbz = (w + kBlock - 1) / kBlock;
  // One size for both reductions (the half-resolution row count), so no buffer is resized.
  auto zero_store = [&](const std::string& name) {
    return ws.plane<std::uint8_t>(name, static_cast<std::size_t>(nbz) * ((h + 1) / 2));
  };
  Side B, F;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    const Job& job = jobs[i];
    Side& s = job.back ? B : F;
    const std::string name = job.back ? "layered.fb" : "layered.ff";
    const FusedLayer& L = units[i];
    NextPull next;
    if (needs_pull(i + 1)) {
      const Pyramid& p = pyr[(i + 1) % 2];
      next = {&units[i + 1], p.val[1], p.wgt[1], has_l2 ? p.val[2] : nullptr, has_l2 ? p.wgt[2] : nullptr};
    }
    const AccRows A(s.has ? s.full : nullptr, s.has ? s.half : nullptr, s.factor, &s.zero);
    const double var = job.var;
    const double sigma = std::sqrt(var);
    if (var > 0 && half_res && quarter_res && sigma >= 8.0) {
      const int qw = (w + 3) / 4, qh = (h + 3) / 4;
      Image& dst = ws.image(name + ".quarter" + std::to_string(s.flip_q), qw, qh, 4);
      s.flip_q ^= 1;
      {
        core::PassScope pass("layer composite");
        composite_pass({L, A, job.back, {nullptr, nullptr, &dst}, next});
      }
      const double v = (sigma * sigma - 1.25 - 8.0 / 3.0) / 16.0;
      core::PassScope pass("layer blur");
      if (v > 0) core::gaussian_blur(dst, static_cast<float>(std::sqrt(v)));
      s.full = nullptr;
      s.half = &dst;
      s.factor = 4;
      s.zero = build_zero_map(dst, 4, w, zero_store(name + ".nz"));
    } else if (var > 0 && half_res && sigma >= 4.0) {
      const int hw = (w + 1) / 2, hh = (h + 1) / 2;
      Image& dst = ws.image(name + ".half" + std::to_string(s.flip), hw, hh, 4);
      s.flip ^= 1;
      {
        core::PassScope pass("layer composite");
        composite_pass({L, A, job.back, {nullptr, &dst, nullptr}, next});
      }
      const double v = (sigma * sigma - 0.25 - 2.0 / 3.0) / 4.0;
      core::PassScope pass("layer blur");
      if (v > 0) core::gaussian_blur(dst, static_cast<float>(std::sqrt(v)));
      s.full = nullptr;
      s.half = &dst;
      s.factor = 2;
      s.zero = build_zero_map(dst, 2, w, zero_store(name + ".nz"));
    } else {
      Image& dst = ws.image(name + ".full", w, h, 4);
      {
        core::PassScope pass("layer composite");
        composite_pass({L, A, job.back, {&dst, nullptr, nullptr}, next});
      }
      core::PassScope pass("layer blur");
      if (var > 0) core::gaussian_blur(dst, static_cast<float>(sigma));
      s.full = &dst;
      s.half = nullptr;
      s.zero = ZeroMap();
    }
    s.has = true;
    if (next.L) {
      core::PassScope pass("fill pull");
      finish_pull(i + 1);
    }
  }

  // I = F over L_focus over B (final_composite's arithmetic; the focus layer on the fly).
  const FusedLayer* Lf = focus_full ? &units.back() : nullptr;
  const AccRows BR(B.full, B.half, B.factor, &B.zero), FR(F.full, F.half, F.factor, &F.zero);
  out.resize(w, h, 4);
  {
    core::PassScope pass("final composite");
    final_pass(Lf, BR, FR, out);
  }
  g_fused_renders.fetch_add(1);
  return true;
}

}  // namespace dofkit::detail::layered
