// render_masked(): depth of field for key transparencies (StarCraft II, docs/methods/starcraft.md).
//
// A deferred renderer runs its depth-dependent post effects on the opaque scene, so a
// translucent object drawn afterwards is either left sharp (it never wrote depth) or its
// depth destroys the opaque depth behind it. The chapter's fix: let key transparencies
// write their depth in a pre-pass and run depth of field a second time over the area they
// cover. The library form, for any method: render the frame as given (opaque depth), render
// it again with the depth replaced by `mask_depth` wherever the mask covers, and blend the
// second result in by the mask. The mask is the transparency's coverage (its alpha), so a
// 50 % pane takes half of its look from each render — the opaque scene behind it keeps the
// blur of its own depth, the pane's contribution gets the pane's blur.
#include <algorithm>
#include <cmath>
#include <string>

#include "core/parallel.hpp"
#include "dofkit/render.hpp"

namespace dofkit {

namespace {

std::string size_of(const Image& img) { return std::to_string(img.width()) + "x" + std::to_string(img.height()); }

void validate_mask(const Frame& frame, const Image& mask, const Image& mask_depth) {
  if (mask.channels() != 1 || !mask.same_size(frame.color))
    throw_bad_input("--mask: must be one plane of " + size_of(frame.color) + " (the colour's size), is " +
                    std::to_string(mask.channels()) + " plane(s) of " + size_of(mask));
  if (mask_depth.channels() != 1 || !mask_depth.same_size(frame.color))
    throw_bad_input("--mask-depth: must be one plane of " + size_of(frame.color) + " (the colour's size), is " +
                    std::to_string(mask_depth.channels()) + " plane(s) of " + size_of(mask_depth));
  const int w = mask.width();
  for (std::size_t i = 0; i < mask.plane_size(); ++i) {
    const float m = mask.plane(0)[i];
    if (!(m >= 0.0f && m <= 1.0f))
      throw_bad_input("--mask: value " + std::to_string(m) + " at pixel (" + std::to_string(i % w) + ", " +
                      std::to_string(i / w) + ") is outside [0, 1]");
    const float z = mask_depth.plane(0)[i];
    if (m > 0.0f && !(z > 0.0f))
      throw_bad_input("--mask-depth: depth " + std::to_string(z) + " at masked pixel (" + std::to_string(i % w) + ", " +
                      std::to_string(i / w) + ") must be > 0");
  }
}

}  // namespace

RenderResult render_masked(const Frame& frame, const Image& mask, const Image& mask_depth,
                           const RenderSettings& settings) {
  validate_frame(frame);
  validate_mask(frame, mask, mask_depth);

  RenderResult base = render(frame, settings);
  const float* m = mask.plane(0);
  const bool any = std::any_of(m, m + mask.plane_size(), [](float v) { return v > 0.0f; });
  if (!any) return base;

  // The same frame with the transparency's depth where it covers (the pre-pass of §4.4).
  Frame substituted;
  substituted.color = frame.color;
  substituted.depth = frame.depth;
  for (std::size_t i = 0; i < mask.plane_size(); ++i)
    if (m[i] > 0.0f) substituted.depth.plane(0)[i] = mask_depth.plane(0)[i];
  RenderResult over = render(substituted, settings);

  // out = (1 − m)·base + m·over, per plane; the CoC map is blended the same way so it
  // reports the radius each pixel's result was made with (mixed where 0 < m < 1).
  const int w = frame.width(), h = frame.height();
  core::with_threads(settings.threads, [&] {
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y) {
            const float* mr = mask.row(0, y);
            for (int c = 0; c < 4; ++c) {
              float* b = base.image.row(c, y);
              const float* o = over.image.row(c, y);
              for (int x = 0; x < w; ++x) b[x] += mr[x] * (o[x] - b[x]);
            }
            float* bc = base.coc.row(0, y);
            const float* oc = over.coc.row(0, y);
            for (int x = 0; x < w; ++x) bc[x] += mr[x] * (oc[x] - bc[x]);
          }
        },
        16);
  });
  // The debug view (if any) is the masked re-render's: the pass this entry point adds.
  if (!settings.debug_view.empty()) base.debug = std::move(over.debug);
  return base;
}

}  // namespace dofkit
