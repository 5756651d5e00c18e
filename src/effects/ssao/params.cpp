// AO parameters: the tables ao_methods() lists (names, units, defaults, ranges), the sc2
// presets, and parsing of `--set` values into Sc2Params / GtaoParams.
//
// sc2's names follow the chapter (§5.5): the artist's sampling radius (radius_m), the
// *full occlusion* and *no occlusion* thresholds and the *occlusion power* of each of the two
// sample sets, the screen-space radius limiter, the smart blur's depth and normal thresholds.
// Thresholds are in units of their set's radius, so that one preset serves every radius.
#include <algorithm>
#include <sstream>

#include "effects/ssao/ssao.hpp"
#include "methods/method.hpp"

namespace dofkit::detail::ao {

namespace {

// The `chapter` preset: the chapter's structure with artist values it leaves open, chosen as
// an artist would start (docs/methods/ssao.md, "Parameters"): the small set a quarter of the
// radius with a steep function, the wide set the whole radius with a linear one.
Sc2Params chapter_preset() {
  Sc2Params p;
  p.preset = "chapter";
  p.small = {0.25, 0.1, 0.5, 1.0};
  p.wide = {1.0, 0.1, 1.0, 1.0};
  return p;
}

// The `tuned` preset: chapter_preset() with the artist parameters fitted for the lowest mean
// squared error against ray-traced AO on the built-in AO scenes at three radii
// (`dofkit quality --effect ao --fit`, docs/methods/ssao.md "The tuned preset").
Sc2Params tuned_preset() {
  Sc2Params p = chapter_preset();
  p.preset = "tuned";
  p.small = {0.3772, 1.78, 2.172, 1.6};
  p.wide = {1.0, 1.327, 1.509, 0.625};
  return p;
}

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::vector<ParamInfo> blur_infos(const BlurParams& b) {
  return {
      {"blur_passes", num(b.passes),
       "smart Gaussian blur passes (each a horizontal and a vertical sweep), 0..8; the chapter applies "
       "\"several\""},
      {"blur_radius_px", num(b.radius_px), "blur taps per side, full-res px, 1..16 (Gaussian sigma = radius / 2)"},
      {"blur_depth_threshold", num(b.depth_threshold),
       "a tap whose depth differs from the centre's by more than this fraction of the centre's depth gets weight "
       "0, 0.001..10"},
      {"blur_normal_threshold", num(b.normal_threshold),
       "a tap whose normal has a dot product with the centre's below this gets weight 0, -1..1"},
  };
}

BlurParams parse_blur(const Params& p, const BlurParams& d) {
  BlurParams b;
  b.passes = p.get_int("blur_passes", d.passes, 0, 8);
  b.radius_px = p.get_int("blur_radius_px", d.radius_px, 1, 16);
  b.depth_threshold = p.get_double("blur_depth_threshold", d.depth_threshold, 0.001, 10);
  b.normal_threshold = p.get_double("blur_normal_threshold", d.normal_threshold, -1, 1);
  return b;
}

ParamInfo resolution_info() {
  return {"resolution", "full",
          "full (every pixel sampled, as the chapter) or half (the samples and the blur on every other pixel "
          "- a quarter of the work - then a depth-aware upsampling; blur_radius_px and noise_size_px are then in "
          "half-res px)"};
}

bool parse_half(const Params& p) { return p.get_choice("resolution", "full", {"full", "half"}) == "half"; }

std::vector<DebugViewInfo> blur_views(const std::string& prefix) {
  std::vector<DebugViewInfo> v;
  for (int k = 1; k <= 8; ++k)
    v.push_back({"blur" + std::to_string(k), prefix + " after blur pass " + std::to_string(k) + " (if run)"});
  return v;
}

}  // namespace

std::vector<MethodInfo> method_infos();

namespace {

// Every key must be one of the method's parameters.
void check_keys(const std::string& method, const std::map<std::string, std::string>& values) {
  const std::vector<MethodInfo> infos = method_infos();
  for (const auto& [key, value] : values) {
    bool known = false;
    for (const MethodInfo& m : infos)
      if (m.name == method)
        for (const ParamInfo& i : m.params) known = known || i.name == key;
    if (!known)
      throw_usage("--set " + key + "=" + value + ": unknown parameter of AO method " + method +
                  " (see dofkit ssao --help)");
  }
}

}  // namespace

std::vector<MethodInfo> method_infos() {
  const Sc2Params c = chapter_preset();
  MethodInfo sc2;
  sc2.name = "sc2";
  sc2.summary =
      "StarCraft II SSAO (Filion & McNaughton 2008, 5.5): view-space offsets reflected through a tiled random "
      "vector, flipped into the normal's hemisphere, depth-compared on a quarter-res depth through the artist "
      "occlusion function, two sample sets (small + steep, wide + gentle; darker kept), smart Gaussian blur";
  sc2.params = {
      {"preset", "chapter",
       "chapter (artist values an artist would start from) or tuned (the artist values fitted to ray-traced AO on "
       "the built-in AO scenes); other keys override it"},
      {"samples", num(c.samples), "offset vectors per pixel, 8..32, a multiple of 4 (a quarter in the small set)"},
      {"small_radius", num(c.small.radius), "small set's sampling radius, x radius_m, 0.02..1"},
      {"small_full_occlusion", num(c.small.full_occlusion),
       "small set: depth deltas in (0, this] occlude fully; x the small set's radius, 0..4"},
      {"small_no_occlusion", num(c.small.no_occlusion),
       "small set: depth deltas >= this occlude nothing; x the small set's radius, > small_full_occlusion, "
       "0.01..8"},
      {"small_occlusion_power", num(c.small.occlusion_power),
       "small set: the linear fall-off between the thresholds is raised to this power, 0.1..8"},
      {"full_occlusion", num(c.wide.full_occlusion), "wide set: full-occlusion threshold, x radius_m, 0..4"},
      {"no_occlusion", num(c.wide.no_occlusion),
       "wide set: no-occlusion threshold, x radius_m, > full_occlusion, 0.01..8"},
      {"occlusion_power", num(c.wide.occlusion_power), "wide set: occlusion power, 0.1..8"},
      {"max_screen_radius", num(c.max_screen_radius),
       "screen-space radius limiter for close-ups: the wide radius covers at most this x the image width, "
       "0.005..1"},
      {"noise_size_px", num(c.noise_size_px), "side of the tiled random-vector texture, px, 2..16"},
      {"depth_downsample", c.depth_downsample,
       "how a 4x4 block of depth becomes one quarter-res texel: min (nearest surface), max, mean or nearest "
       "(the texel's pixel (1, 1))"},
  };
  for (auto& b : blur_infos(c.blur)) sc2.params.push_back(b);
  sc2.params.push_back(resolution_info());
  sc2.params.push_back({"impl", "fast", "fast (Highway kernels, threads) or plain (the scalar oracle)"});
  sc2.debug_views = {
      {"normals", "the normals used (RGB = 0.5 + 0.5 N, camera space X right, Y up, Z towards the camera)"},
      {"quarter_depth", "the depth reduced to ceil(W/4) x ceil(H/4), metres"},
      {"raw", "the occlusion term before the blur: 1 - max(small set, wide set)"},
      {"small_set", "1 - the small set's mean occlusion"},
      {"wide_set", "1 - the wide set's mean occlusion"},
  };
  for (auto& v : blur_views("the AO")) sc2.debug_views.push_back(v);

  const GtaoParams g;
  MethodInfo gtao;
  gtao.name = "gtao";
  gtao.summary =
      "ground-truth-based AO after Jimenez et al. 2016: per pixel, screen slices through the view vector, each "
      "searched on the full-res depth for what occludes within the radius, the cosine-weighted visibility "
      "integrated per slice in closed form; by default every depth sample is a 0.2 m thick occluder marking "
      "sectors of the slice (occluder_thickness_m=0: the paper's horizons); same smart blur";
  gtao.params = {
      {"slices", num(g.slices), "screen directions per pixel, 1..16 (rotated per pixel by the noise tile)"},
      {"steps", num(g.steps), "depth samples per slice side, 1..32"},
      {"step_power", num(g.step_power),
       "sample j of a side lies at ((j + jitter) / steps)^step_power of the screen radius, 1..4"},
      {"occluder_thickness_m", num(g.occluder_thickness_m),
       "0: the paper's horizons (every depth sample an infinitely thick occluder); > 0: each sample stands for a "
       "segment this many metres deep along its eye ray, and the part of it within the radius occludes its sectors "
       "of the slice (32 per slice), 0..100"},
      {"falloff", num(g.falloff),
       "horizon mode: a sample's weight in its horizon fades to 0 over the last falloff x radius_m (0 = a hard cut "
       "at the radius, as a ray-traced AO), 0..1"},
      {"offscreen", g.clamp_edges ? "edge" : "skip",
       "samples off screen: edge (read the nearest edge pixel: the border's geometry extended) or skip (no "
       "occlusion)"},
      {"max_screen_radius", num(g.max_screen_radius),
       "the screen radius covers at most this x the image width, 0.005..1"},
      {"noise_size_px", num(g.noise_size_px), "side of the tiled slice-rotation / step-jitter texture, px, 2..16"},
  };
  for (auto& b : blur_infos(g.blur)) gtao.params.push_back(b);
  gtao.params.push_back(resolution_info());
  gtao.params.push_back({"impl", "fast", "fast (Highway kernels, threads) or plain (the scalar oracle)"});
  gtao.debug_views = {
      {"normals", "the normals used (RGB = 0.5 + 0.5 N, camera space X right, Y up, Z towards the camera)"},
      {"raw", "the visibility before the blur"},
  };
  for (auto& v : blur_views("the AO")) gtao.debug_views.push_back(v);
  return {gtao, sc2};
}

std::vector<std::string> debug_view_names(const std::string& method) {
  std::vector<std::string> out;
  for (const MethodInfo& m : method_infos())
    if (m.name == method)
      for (const DebugViewInfo& v : m.debug_views) out.push_back(v.name);
  return out;
}

Sc2Params parse_sc2(const std::map<std::string, std::string>& values) {
  check_keys("sc2", values);
  const Params p("sc2", values);
  const std::string preset = p.get_choice("preset", "chapter", {"chapter", "tuned"});
  const Sc2Params d = preset == "tuned" ? tuned_preset() : chapter_preset();
  Sc2Params s = d;
  s.samples = p.get_int("samples", d.samples, 8, 32);
  if (s.samples % 4 != 0)
    throw_usage("--set samples=" + values.at("samples") + ": must be a multiple of 4 (ao method sc2)");
  const auto set = [&](const std::string& prefix, const SampleSet& def, SampleSet& out) {
    out.full_occlusion = p.get_double(prefix + "full_occlusion", def.full_occlusion, 0, 4);
    out.no_occlusion = p.get_double(prefix + "no_occlusion", def.no_occlusion, 0.01, 8);
    out.occlusion_power = p.get_double(prefix + "occlusion_power", def.occlusion_power, 0.1, 8);
    if (!(out.no_occlusion > out.full_occlusion))
      throw_usage("--set " + prefix + "no_occlusion: must be greater than " + prefix + "full_occlusion (" +
                  num(out.no_occlusion) + " <= " + num(out.full_occlusion) + ", ao method sc2)");
  };
  s.small.radius = p.get_double("small_radius", d.small.radius, 0.02, 1);
  set("small_", d.small, s.small);
  s.wide.radius = 1;
  set("", d.wide, s.wide);
  s.max_screen_radius = p.get_double("max_screen_radius", d.max_screen_radius, 0.005, 1);
  s.noise_size_px = p.get_int("noise_size_px", d.noise_size_px, 2, 16);
  s.depth_downsample = p.get_choice("depth_downsample", d.depth_downsample, {"min", "max", "mean", "nearest"});
  s.blur = parse_blur(p, d.blur);
  s.half = parse_half(p);
  s.plain = p.get_choice("impl", "fast", {"fast", "plain"}) == "plain";
  return s;
}

GtaoParams parse_gtao(const std::map<std::string, std::string>& values) {
  check_keys("gtao", values);
  const Params p("gtao", values);
  const GtaoParams d;
  GtaoParams g;
  g.slices = p.get_int("slices", d.slices, 1, 16);
  g.steps = p.get_int("steps", d.steps, 1, 32);
  g.step_power = p.get_double("step_power", d.step_power, 1, 4);
  g.occluder_thickness_m = p.get_double("occluder_thickness_m", d.occluder_thickness_m, 0, 100);
  g.falloff = p.get_double("falloff", d.falloff, 0, 1);
  g.clamp_edges = p.get_choice("offscreen", d.clamp_edges ? "edge" : "skip", {"skip", "edge"}) == "edge";
  g.max_screen_radius = p.get_double("max_screen_radius", d.max_screen_radius, 0.005, 1);
  g.noise_size_px = p.get_int("noise_size_px", d.noise_size_px, 2, 16);
  g.blur = parse_blur(p, d.blur);
  g.half = parse_half(p);
  g.plain = p.get_choice("impl", "fast", {"fast", "plain"}) == "plain";
  return g;
}

}  // namespace dofkit::detail::ao
