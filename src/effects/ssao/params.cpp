// AO parameters: the tables ao_methods() lists (names, units, defaults, ranges), the sc2
// presets, and parsing of `--set` values into Sc2Params / GtaoParams.
//
// sc2's names follow the chapter (§5.5): the artist's sampling radius (radius_m), the
// *full occlusion* and *no occlusion* thresholds and the *occlusion power* of each of the two
// sample sets, the screen-space radius limiter, the smart blur's depth and normal thresholds.
// Thresholds are in units of their set's radius, so that one preset serves every radius.
#include <algorithm>
#include <set>
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

// A default from the presets: one value when both presets agree, else one per preset.
template <class Get>
ParamDefault by_preset(Get get) {
  const auto c = get(chapter_preset()), t = get(tuned_preset());
  if (c == t) return c;
  return param_by("preset", {{"chapter", c}, {"tuned", t}});
}

std::vector<ParamInfo> blur_infos(const BlurParams& b) {
  return {
      int_param("blur_passes", b.passes, 0, 8, "",
                "smart Gaussian blur passes (each a horizontal and a vertical sweep); the chapter applies "
                "\"several\""),
      int_param("blur_radius_px", b.radius_px, 1, 16, "px",
                "blur taps per side, full-res px (Gaussian sigma = radius / 2)"),
      float_param("blur_depth_threshold", b.depth_threshold, 0.001, 10, "",
                  "a tap whose depth differs from the centre's by more than this fraction of the centre's depth "
                  "gets weight 0"),
      float_param("blur_normal_threshold", b.normal_threshold, -1, 1, "",
                  "a tap whose normal has a dot product with the centre's below this gets weight 0"),
  };
}

BlurParams parse_blur(const Params& p) {
  BlurParams b;
  b.passes = p.get_int("blur_passes");
  b.radius_px = p.get_int("blur_radius_px");
  b.depth_threshold = p.get_double("blur_depth_threshold");
  b.normal_threshold = p.get_double("blur_normal_threshold");
  return b;
}

ParamInfo resolution_info() {
  return choice_param("resolution", "full", {"full", "half"},
                      "full (every pixel sampled, as the chapter) or half (the samples and the blur on every other "
                      "pixel - a quarter of the work - then a depth-aware upsampling; blur_radius_px and "
                      "noise_size_px are then in half-res px)");
}

ParamInfo impl_info() {
  return choice_param("impl", "fast", {"fast", "plain"},
                      "fast (Highway kernels, threads) or plain (the scalar oracle)");
}

bool parse_half(const Params& p) { return p.get_choice("resolution") == "half"; }

std::vector<DebugViewInfo> blur_views(const std::string& prefix) {
  std::vector<DebugViewInfo> v;
  for (int k = 1; k <= 8; ++k)
    v.push_back({"blur" + std::to_string(k), prefix + " after blur pass " + std::to_string(k) + " (if run)"});
  return v;
}

}  // namespace

std::vector<MethodInfo> method_infos();

namespace {

// The table of AO method `method` (a reference into a static copy).
const std::vector<ParamInfo>& table(const std::string& method) {
  static const std::vector<MethodInfo> infos = method_infos();
  for (const MethodInfo& m : infos)
    if (m.name == method) return m.params;
  throw_internal("no AO method " + method);
}

// Every key must be one of the method's parameters (the AO form of the unknown-key message).
void check_keys(const std::string& method, const std::map<std::string, std::string>& values) {
  const std::vector<ParamInfo>& declared = table(method);
  for (const auto& [key, value] : values) {
    bool known = false;
    for (const ParamInfo& i : declared) known = known || i.name == key;
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
      choice_param("preset", "chapter", {"chapter", "tuned"},
                   "chapter (artist values an artist would start from) or tuned (the artist values fitted to "
                   "ray-traced AO on the built-in AO scenes); other keys override it"),
      int_param("samples", by_preset([](const Sc2Params& p) { return p.samples; }), 8, 32, "",
                "offset vectors per pixel, a multiple of 4 (a quarter in the small set)"),
      float_param("small_radius", by_preset([](const Sc2Params& p) { return p.small.radius; }), 0.02, 1, "",
                  "small set's sampling radius, x radius_m"),
      float_param("small_full_occlusion", by_preset([](const Sc2Params& p) { return p.small.full_occlusion; }), 0, 4,
                  "", "small set: depth deltas in (0, this] occlude fully; x the small set's radius"),
      float_param("small_no_occlusion", by_preset([](const Sc2Params& p) { return p.small.no_occlusion; }), 0.01, 8, "",
                  "small set: depth deltas >= this occlude nothing; x the small set's radius, > "
                  "small_full_occlusion"),
      float_param("small_occlusion_power", by_preset([](const Sc2Params& p) { return p.small.occlusion_power; }), 0.1,
                  8, "", "small set: the linear fall-off between the thresholds is raised to this power"),
      float_param("full_occlusion", by_preset([](const Sc2Params& p) { return p.wide.full_occlusion; }), 0, 4, "",
                  "wide set: full-occlusion threshold, x radius_m"),
      float_param("no_occlusion", by_preset([](const Sc2Params& p) { return p.wide.no_occlusion; }), 0.01, 8, "",
                  "wide set: no-occlusion threshold, x radius_m, > full_occlusion"),
      float_param("occlusion_power", by_preset([](const Sc2Params& p) { return p.wide.occlusion_power; }), 0.1, 8, "",
                  "wide set: occlusion power"),
      float_param("max_screen_radius", by_preset([](const Sc2Params& p) { return p.max_screen_radius; }), 0.005, 1, "",
                  "screen-space radius limiter for close-ups: the wide radius covers at most this x the image "
                  "width"),
      int_param("noise_size_px", by_preset([](const Sc2Params& p) { return p.noise_size_px; }), 2, 16, "px",
                "side of the tiled random-vector texture"),
      choice_param("depth_downsample", by_preset([](const Sc2Params& p) { return p.depth_downsample; }),
                   {"min", "max", "mean", "nearest"},
                   "how a 4x4 block of depth becomes one quarter-res texel: min (nearest surface), max, mean or "
                   "nearest (the texel's pixel (1, 1))"),
  };
  for (auto& b : blur_infos(c.blur)) sc2.params.push_back(b);
  sc2.params.push_back(resolution_info());
  sc2.params.push_back(impl_info());
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
      int_param("slices", g.slices, 1, 16, "", "screen directions per pixel (rotated per pixel by the noise tile)"),
      int_param("steps", g.steps, 1, 32, "", "depth samples per slice side"),
      float_param("step_power", g.step_power, 1, 4, "",
                  "sample j of a side lies at ((j + jitter) / steps)^step_power of the screen radius"),
      float_param("occluder_thickness_m", g.occluder_thickness_m, 0, 100, "m",
                  "0: the paper's horizons (every depth sample an infinitely thick occluder); > 0: each sample "
                  "stands for a segment this many metres deep along its eye ray, and the part of it within the "
                  "radius occludes its sectors of the slice (32 per slice)"),
      float_param("falloff", g.falloff, 0, 1, "",
                  "horizon mode: a sample's weight in its horizon fades to 0 over the last falloff x radius_m (0 = "
                  "a hard cut at the radius, as a ray-traced AO)"),
      choice_param("offscreen", g.clamp_edges ? "edge" : "skip", {"skip", "edge"},
                   "samples off screen: edge (read the nearest edge pixel: the border's geometry extended) or skip "
                   "(no occlusion)"),
      float_param("max_screen_radius", g.max_screen_radius, 0.005, 1, "",
                  "the screen radius covers at most this x the image width"),
      int_param("noise_size_px", g.noise_size_px, 2, 16, "px",
                "side of the tiled slice-rotation / step-jitter texture"),
  };
  for (auto& b : blur_infos(g.blur)) gtao.params.push_back(b);
  gtao.params.push_back(resolution_info());
  gtao.params.push_back(impl_info());
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

Sc2Params parse_sc2(const std::map<std::string, std::string>& values, std::set<std::string>* keys_read) {
  check_keys("sc2", values);
  const Params p("sc2", table("sc2"), values);
  const std::string preset = p.get_choice("preset");
  Sc2Params s = preset == "tuned" ? tuned_preset() : chapter_preset();
  s.samples = p.get_int("samples", preset);
  if (s.samples % 4 != 0)
    throw_usage("--set samples=" + values.at("samples") + ": must be a multiple of 4 (ao method sc2)");
  const auto set = [&](const std::string& prefix, SampleSet& out) {
    out.full_occlusion = p.get_double(prefix + "full_occlusion", preset);
    out.no_occlusion = p.get_double(prefix + "no_occlusion", preset);
    out.occlusion_power = p.get_double(prefix + "occlusion_power", preset);
    if (!(out.no_occlusion > out.full_occlusion))
      throw_usage("--set " + prefix + "no_occlusion: must be greater than " + prefix + "full_occlusion (" +
                  num(out.no_occlusion) + " <= " + num(out.full_occlusion) + ", ao method sc2)");
  };
  s.small.radius = p.get_double("small_radius", preset);
  set("small_", s.small);
  s.wide.radius = 1;
  set("", s.wide);
  s.max_screen_radius = p.get_double("max_screen_radius", preset);
  s.noise_size_px = p.get_int("noise_size_px", preset);
  s.depth_downsample = p.get_choice("depth_downsample");
  s.blur = parse_blur(p);
  s.half = parse_half(p);
  s.plain = p.get_choice("impl") == "plain";
  if (keys_read) *keys_read = p.keys_read();
  return s;
}

GtaoParams parse_gtao(const std::map<std::string, std::string>& values, std::set<std::string>* keys_read) {
  check_keys("gtao", values);
  const Params p("gtao", table("gtao"), values);
  GtaoParams g;
  g.slices = p.get_int("slices");
  g.steps = p.get_int("steps");
  g.step_power = p.get_double("step_power");
  g.occluder_thickness_m = p.get_double("occluder_thickness_m");
  g.falloff = p.get_double("falloff");
  g.clamp_edges = p.get_choice("offscreen") == "edge";
  g.max_screen_radius = p.get_double("max_screen_radius");
  g.noise_size_px = p.get_int("noise_size_px");
  g.blur = parse_blur(p);
  g.half = parse_half(p);
  g.plain = p.get_choice("impl") == "plain";
  if (keys_read) *keys_read = p.keys_read();
  return g;
}

}  // namespace dofkit::detail::ao
