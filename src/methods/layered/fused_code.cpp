// Code pass of the fused stack (oracle: LayerPlan::weight and near_limit, anchors.cpp, as
// matting.cpp applies them; tests/layered compare every layer's matte and whole renders with
// impl=plain bit for bit). Input: one fragment per pixel (colour, CoC) and the layer plan.
// Output (CodePlanes): per pixel the only layers with a non-zero matte and from which layer on
// it is a hole; per row block the summaries FusedLayer reads to skip empty work.
//
// A fragment of CoC r has a non-zero matte in at most two adjacent layers (its plateau layer
// at weight 1 and the nearer one on the ramp; anchors.cpp). With j the first layer whose
// anchor a_j <= r, only j − 1 and j can be non-zero: for k <= j − 2, r < a_{k+1} makes u <= 0
// in the ramp branch, and for k >= j + 1, r >= a_{k−1} makes u >= 1 (rounding is monotonic)
// in the farther branch, both exactly 0. Those are evaluated with the plan's own arithmetic
// (Matte) and stored as (j0, w_{j0}, w_{j0+1} = 1?). The holes of the visible fragment,
// r > near_limit(k), are an up-set k >= hk because near_limit decreases with k. Anything
// unexpected makes the pass report !ok, and the frame goes down the per-layer path.
#include <algorithm>
#include <atomic>
#include <bit>
#include <vector>

#include "core/parallel.hpp"
#include "methods/layered/fused_passes.hpp"

namespace dofkit::detail::layered {

namespace {

// The codes of a CoC value r (they depend on r only).
struct RCodes {
  unsigned j0 = kNoLayer;  // first layer with a non-zero matte
  float wv = 0.0f;         // its matte
  bool second = false;     // layer j0 + 1 has matte 1
  unsigned hk = 0;         // a hole from layer hk on (K: none)
  bool bad = false;        // the mattes or holes do not have the form above
  std::uint16_t code() const { return static_cast<std::uint16_t>(j0 | (second ? 32u : 0u) | (hk << 6)); }
};

// The plan's numbers the code of one pixel needs.
struct Coder {
  int K;
  double anchor[16];
  const std::vector<Matte>& mattes;
  const std::vector<double>& nl;  // near_limit(k)
  bool do_fill;

  RCodes of(float r) const {
    RCodes c;
    int j = 0;
    while (j < K && !(anchor[j] <= r)) ++j;
    for (int k = std::max(j - 1, 0); k <= std::min(j, K - 1); ++k) {
      const float wk = mattes[k](r);
      if (!(wk > 0)) continue;
      if (c.j0 == kNoLayer) {
        c.j0 = static_cast<unsigned>(k);
        c.wv = wk;
      } else if (k == static_cast<int>(c.j0) + 1 && wk == 1.0f && !c.second) {
        c.second = true;
      } else {
        c.bad = true;
      }
    }
    c.hk = static_cast<unsigned>(K);
    if (do_fill) {
      // Only near_limit(j), near_limit(j + 1) can lie on either side of r: for k <= j − 1
      // near_limit(k) >= a_k > r, for k >= j + 2 near_limit(k) <= a_{k−1} < a_j <= r.
      const bool hj = j < K && r > nl[j];
      const bool hj1 = j + 1 < K && r > nl[j + 1];
      if (hj && !hj1 && j + 1 < K) c.bad = true;
      c.hk = static_cast<unsigned>(std::min(K, hj ? j : (hj1 ? j + 1 : j + 2)));
    }
    return c;
  }
};

// Block summaries of row y and the non-empty layers (ne), from the codes of the row.
void summarise_row(const CodePlanes& p, int w, int y, const float* alpha, std::uint32_t& ne) {
  const std::size_t base = static_cast<std::size_t>(y) * w;
  for (int b = 0; b < p.nb; ++b) {
    const int x0 = b * kBlock, n = std::min(w, x0 + kBlock) - x0;
    const std::size_t i = static_cast<std::size_t>(y) * p.nb + b;
    std::uint32_t cm[kBlock / 16], chk[kBlock / 16];
    kern::code_summary(p.code + base + x0, p.w0 + base + x0, alpha + x0, n, &p.bpres[i], &p.bhk[i], &ne, cm, chk);
    block_spans(cm, n, p.bspan + 16 * i);
    hole_spans(chk, n, p.bhk[i], p.bhole + 16 * i);
  }
}

}  // namespace

CodeSummary code_pass(const Image& color, const Image& coc, const LayerPlan& plan, bool do_fill,
                      const CodePlanes& out) {
  const int w = color.width(), h = color.height(), K = plan.count;
  std::vector<Matte> mattes;
  std::vector<double> nl(K);
  for (int k = 0; k < K; ++k) {
    mattes.emplace_back(plan, k);
    nl[k] = plan.near_limit(k);
  }
  std::atomic<std::uint32_t> nonempty{0}, holes{0};
  std::atomic<bool> bail{false};
  std::uint16_t* code = out.code;
  float* w0 = out.w0;
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        std::uint32_t ne = 0, ho = 0;
        bool bad = false;
        Coder coder{K, {}, mattes, nl, do_fill};
        for (int k = 0; k < K; ++k) coder.anchor[k] = plan.anchor[k];
        bool have = false;
        std::uint32_t last_bits = 0;
        RCodes cur;
        for (int y = y0; y < y1; ++y) {
          const float* al = color.row(3, y);
          const float* rr = coc.row(0, y);
          const std::size_t base = static_cast<std::size_t>(y) * w;
          for (int x = 0; x < w; ++x) {
            // Runs of 16 pixels that change nothing (each transparent or of the last CoC) are
            // written by one vectorised kernel with the codes the loop below would write.
            while (have && x + 16 <= w &&
                   kern::code_run16(al + x, rr + x, last_bits, cur.code(), cur.wv, code + base + x, w0 + base + x))
              x += 16;
            if (x >= w) break;
            const float a = al[x];
            if (!(a > 0)) {
              code[base + x] = static_cast<std::uint16_t>(kNoLayer | (31u << 6));
              w0[base + x] = 0.0f;
              continue;
            }
            const float r = rr[x];
            const std::uint32_t rbits = std::bit_cast<std::uint32_t>(r);
            if (!have || rbits != last_bits) {  // the codes depend on r only: reuse along flat runs
              have = true;
              last_bits = rbits;
              cur = coder.of(r);
              bad |= cur.bad;
              if (do_fill) ho |= ((1u << K) - 1u) & ~((1u << cur.hk) - 1u);
            }
            code[base + x] = cur.code();
            w0[base + x] = cur.wv;
          }
          summarise_row(out, w, y, al, ne);
        }
        if (ne) nonempty.fetch_or(ne, std::memory_order_relaxed);
        if (ho) holes.fetch_or(ho, std::memory_order_relaxed);
        if (bad) bail.store(true, std::memory_order_relaxed);
      },
      4);
  CodeSummary s;
  s.ok = !bail.load();
  s.nonempty = nonempty.load();
  s.holes = holes.load();
  return s;
}

}  // namespace dofkit::detail::layered
