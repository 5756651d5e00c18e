// Public scene API (scene.hpp) on top of the ray tracer (raytracer.hpp).
#include "scene/scene.hpp"

#include <cmath>

#include "core/parallel.hpp"
#include "dofkit/error.hpp"
#include "scene/raytracer.hpp"

namespace dofkit::scene {

LensCamera camera_for(const Scene& s, const SceneOptions& opt) {
  if (opt.width <= 0 || opt.height <= 0 || opt.width > 32768 || opt.height > 32768)
    throw_usage("--size: width and height must be 1..32768 px");
  if (opt.focus_m < 0 || !std::isfinite(opt.focus_m)) throw_usage("--focus: must be > 0 metres");
  if (opt.blur_at_infinity_px < 0 || !std::isfinite(opt.blur_at_infinity_px))
    throw_usage("--blur-at-infinity: must be >= 0 px");
  if (opt.samples < 0) throw_usage("--samples: must be >= 1 (0 = the scene's default)");
  validate(opt.aperture);
  LensCamera cam;
  cam.width = opt.width;
  cam.height = opt.height;
  cam.hfov_deg = s.hfov_deg;
  cam.focus_m = opt.focus_m > 0 ? opt.focus_m : s.focus_m;
  // The scene's default K is composed at 640 px wide; radii scale with the width so the
  // picture is the same at any resolution. A K given by the user is at the rendered width.
  cam.k_px = opt.blur_at_infinity_px > 0 ? opt.blur_at_infinity_px : s.k_px_at_640 * opt.width / 640.0;
  cam.aperture = opt.aperture;
  return cam;
}

SceneRender render_custom(const Scene& s, const SceneOptions& opt, bool ground_truth) {
  const LensCamera cam = camera_for(s, opt);
  SceneRender r;
  r.name = s.name;
  r.camera.model = BlurAtInfinity{cam.focus_m, cam.k_px};
  r.camera.reference_width_px = cam.width;
  core::with_threads(opt.threads, [&] {
    r.pinhole = render_pinhole(s, cam, opt.layers);
    if (ground_truth)
      r.ground_truth = render_thin_lens(s, cam, opt.samples > 0 ? opt.samples : s.samples, opt.seed, opt.progress);
  });
  return r;
}

std::vector<std::string> scene_names() { return {"occluder", "fence", "ground", "highlights", "portrait", "sky"}; }

std::string scene_description(const std::string& name) { return build_scene(name).description; }

SceneDefaults scene_defaults(const std::string& name, const SceneOptions& opt) {
  const Scene s = build_scene(name);
  const LensCamera cam = camera_for(s, opt);
  SceneDefaults d;
  d.focus_m = cam.focus_m;
  d.blur_at_infinity_px = cam.k_px;
  d.samples = opt.samples > 0 ? opt.samples : s.samples;
  d.hfov_deg = s.hfov_deg;
  return d;
}

SceneRender render_pinhole(const std::string& name, const SceneOptions& opt) {
  return render_custom(build_scene(name), opt, false);
}

SceneRender render_scene(const std::string& name, const SceneOptions& opt) {
  return render_custom(build_scene(name), opt, true);
}

}  // namespace dofkit::scene
