// Shared CLI pieces (see cli_common.hpp).
#include "cli_common.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <sstream>

#include "dofkit/error.hpp"
#include "dofkit/render.hpp"

namespace fs = std::filesystem;

namespace dofkit::cli {

namespace {

bool given(const CLI::Option* o) { return o && o->count() > 0; }

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

}  // namespace

std::vector<double> parse_numbers(const std::string& text, std::size_t count, const std::string& flag,
                                  const std::string& form) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string part;
  auto fail = [&] {
    throw_usage(flag + ": expected " + form + " (" + std::to_string(count) + " comma-separated numbers), got '" + text +
                "'");
  };
  while (std::getline(ss, part, ',')) {
    part = trim(part);
    if (part.empty()) fail();
    errno = 0;
    char* end = nullptr;
    const double d = std::strtod(part.c_str(), &end);
    if (end != part.c_str() + part.size() || errno == ERANGE || std::isnan(d)) fail();
    v.push_back(d);
  }
  if (!text.empty() && text.back() == ',') fail();
  if (v.size() != count) fail();
  return v;
}

std::map<std::string, std::string> parse_sets(const std::vector<std::string>& sets) {
  std::map<std::string, std::string> out;
  for (const std::string& s : sets) {
    const auto eq = s.find('=');
    if (eq == std::string::npos) throw_usage("--set " + s + ": expected KEY=VALUE");
    const std::string key = trim(s.substr(0, eq)), value = trim(s.substr(eq + 1));
    if (key.empty()) throw_usage("--set " + s + ": empty key");
    if (!out.emplace(key, value).second) throw_usage("--set " + key + ": given more than once");
  }
  return out;
}

// --- camera --------------------------------------------------------------------------------

void CameraFlags::add(CLI::App* cmd, const std::string& group) {
  focus_ = cmd->add_option("--focus", focus_m_,
                           "focus distance, metres (scene units): the depth that is sharp. Used with --f-number and "
                           "--blur-at-infinity")
               ->group(group);
  focus_at_ = cmd->add_option("--focus-at", focus_at_text_,
                              "X,Y: focus on the median depth of the 7x7 pixels around pixel (X, Y) (pixels from the "
                              "top-left corner); replaces --focus, and refocuses --planes/--starcraft/--near-far")
                  ->group(group);
  f_number_ = cmd->add_option("--f-number", f_number_v_,
                              "MODEL physical thin lens: aperture f-number N (> 0), e.g. 2.8. With --focus, "
                              "--focal-length, --sensor-width")
                  ->group(group);
  focal_length_ =
      cmd->add_option("--focal-length", focal_length_mm_, "thin lens focal length, millimetres (default 50)")
          ->group(group);
  sensor_width_ =
      cmd->add_option("--sensor-width", sensor_width_mm_,
                      "thin lens sensor width, millimetres (default 36, full frame); the image width spans it")
          ->group(group);
  blur_inf_ = cmd->add_option("--blur-at-infinity", blur_inf_px_,
                              "MODEL thin lens given by K, the blur radius of a point at infinity, pixels (>= 0): "
                              "r(z) = K (focus/z - 1). With --focus")
                  ->group(group);
  planes_ =
      cmd->add_option("--planes", planes_text_,
                      "MODEL four-plane artist model NB,NS,FS,FB, metres, 0 < NB < NS <= FS < FB (FB may be inf): "
                      "blur ramps from --near-radius at NB to 0 at NS, and from 0 at FS to --far-radius at FB")
          ->group(group);
  near_radius_ = cmd->add_option("--near-radius", near_radius_px_, "--planes: maximum near blur radius, pixels (>= 0)")
                     ->group(group);
  far_radius_ =
      cmd->add_option("--far-radius", far_radius_px_, "--planes: maximum far blur radius, pixels (>= 0)")->group(group);
  planes_ramp_ =
      cmd->add_option("--planes-ramp", planes_ramp_v_,
                      "--planes: ramps linear in z (default, as in the sources) or in inverse-z (follows the "
                      "physical lens law between the planes)")
          ->check(CLI::IsMember({"z", "inverse-z"}))
          ->group(group);
  starcraft_ = cmd->add_option("--starcraft", starcraft_text_,
                               "MODEL StarCraft II levels FOCUS,FULL,NONE,AMOUNT: focus distance and ranges in metres "
                               "(sharp within FULL of FOCUS, fully blurred from NONE > FULL), AMOUNT >= 0; level 1 = "
                               "--max-radius pixels")
                   ->group(group);
  near_far_ = cmd->add_option("--near-far", near_far_text_,
                              "MODEL Sterna near/far blend NB,NE,FB,FE, metres, 0 <= NB < NE <= FB < FE: fully "
                              "near-blurred at NB, sharp from NE to FB, fully far-blurred from FE; blend 1 = "
                              "--max-radius pixels")
                  ->group(group);
  max_radius_ = cmd->add_option("--max-radius", max_radius_px_,
                                "--starcraft / --near-far: radius of full blur, pixels (>= 0; default 16 for "
                                "--starcraft, 12 for --near-far)")
                    ->group(group);
  max_coc_ =
      cmd->add_option("--max-coc", max_coc_px_,
                      "clamp every CoC radius to this many pixels (> 0; default: none). Radii are also capped at a "
                      "quarter of the image width (at least 8 px)")
          ->group(group);
  reference_width_ =
      cmd->add_option("--reference-width", reference_width_px_,
                      "image width, pixels, at which pixel radii are given (default: the input's width); "
                      "radii scale with the input width / this")
          ->group(group);
}

bool CameraFlags::model_given() const {
  return given(f_number_) || given(blur_inf_) || given(planes_) || given(starcraft_) || given(near_far_);
}

std::optional<std::pair<int, int>> CameraFlags::focus_at() const {
  if (!given(focus_at_)) return std::nullopt;
  const std::vector<double> v = parse_numbers(focus_at_text_, 2, "--focus-at", "X,Y pixel coordinates");
  for (double c : v)
    if (c != std::floor(c) || c < 0 || c > 1e9)
      throw_usage("--focus-at " + focus_at_text_ + ": X and Y must be whole pixels >= 0");
  return std::make_pair(static_cast<int>(v[0]), static_cast<int>(v[1]));
}

void CameraFlags::check() const {
  std::vector<std::string> models;
  if (given(f_number_)) models.push_back("--f-number");
  if (given(blur_inf_)) models.push_back("--blur-at-infinity");
  if (given(planes_)) models.push_back("--planes");
  if (given(starcraft_)) models.push_back("--starcraft");
  if (given(near_far_)) models.push_back("--near-far");
  if (models.empty())
    throw_usage(
        "no CoC model: give one of --f-number (thin lens), --blur-at-infinity, --planes, --starcraft or --near-far");
  if (models.size() > 1) {
    std::string list;
    for (const auto& m : models) list += (list.empty() ? "" : " and ") + m;
    throw_usage(list + ": choose exactly one CoC model");
  }
  const std::string& model = models[0];
  auto only_with = [&](const CLI::Option* o, const char* name, std::initializer_list<const char*> owners) {
    if (!given(o)) return;
    for (const char* owner : owners)
      if (model == owner) return;
    std::string list;
    for (const char* owner : owners) list += std::string(list.empty() ? "" : " or ") + owner;
    throw_usage(std::string(name) + ": only applies with " + list + " (the chosen model is " + model + ")");
  };
  only_with(focal_length_, "--focal-length", {"--f-number"});
  only_with(sensor_width_, "--sensor-width", {"--f-number"});
  only_with(near_radius_, "--near-radius", {"--planes"});
  only_with(far_radius_, "--far-radius", {"--planes"});
  only_with(planes_ramp_, "--planes-ramp", {"--planes"});
  only_with(max_radius_, "--max-radius", {"--starcraft", "--near-far"});
  only_with(focus_, "--focus", {"--f-number", "--blur-at-infinity"});
  if (given(focus_) && given(focus_at_)) throw_usage("--focus and --focus-at: give only one of them");
  const bool needs_focus = model == "--f-number" || model == "--blur-at-infinity";
  if (needs_focus && !given(focus_) && !given(focus_at_))
    throw_usage(model + ": needs --focus M (focus distance in metres) or --focus-at X,Y");
  if (model == "--planes" && (!given(near_radius_) || !given(far_radius_)))
    throw_usage("--planes: needs --near-radius PX and --far-radius PX");
  if (model == "--planes") parse_numbers(planes_text_, 4, "--planes", "NB,NS,FS,FB in metres");
  if (model == "--starcraft") parse_numbers(starcraft_text_, 4, "--starcraft", "FOCUS,FULL,NONE,AMOUNT");
  if (model == "--near-far") parse_numbers(near_far_text_, 4, "--near-far", "NB,NE,FB,FE in metres");
  focus_at();  // syntax
  if (given(max_coc_) && !(max_coc_px_ > 0)) throw_usage("--max-coc: must be > 0 pixels");
  if (given(reference_width_) && !(reference_width_px_ > 0 && std::isfinite(reference_width_px_)))
    throw_usage("--reference-width: must be > 0 pixels");
  validate(assemble());
}

CameraModel CameraFlags::assemble() const {
  CameraModel cam;
  const double kInf = std::numeric_limits<double>::infinity();
  cam.max_coc_px = given(max_coc_) ? max_coc_px_ : kInf;
  cam.reference_width_px = given(reference_width_) ? reference_width_px_ : 0.0;
  // With --focus-at the focus is only known once the depth is read; until then a stand-in
  // far beyond the focal length lets every other value be validated.
  const double focus = given(focus_) ? focus_m_ : std::max(1000.0, focal_length_mm_ * 0.01);
  if (given(f_number_)) {
    ThinLens t;
    t.f_number = f_number_v_;
    t.focal_length_mm = focal_length_mm_;
    t.sensor_width_mm = sensor_width_mm_;
    t.focus_distance_m = focus;
    cam.model = t;
  } else if (given(blur_inf_)) {
    cam.model = BlurAtInfinity{focus, blur_inf_px_};
  } else if (given(planes_)) {
    const auto v = parse_numbers(planes_text_, 4, "--planes", "NB,NS,FS,FB in metres");
    FourPlane p;
    p.near_blurry_m = v[0];
    p.near_sharp_m = v[1];
    p.far_sharp_m = v[2];
    p.far_blurry_m = v[3];
    p.near_radius_px = near_radius_px_;
    p.far_radius_px = far_radius_px_;
    p.linear_in_inverse_depth = planes_ramp_v_ == "inverse-z";
    cam.model = p;
  } else if (given(starcraft_)) {
    const auto v = parse_numbers(starcraft_text_, 4, "--starcraft", "FOCUS,FULL,NONE,AMOUNT");
    StarCraft s;
    s.focus_distance_m = v[0];
    s.full_focus_range_m = v[1];
    s.no_focus_range_m = v[2];
    s.amount = v[3];
    if (given(max_radius_)) s.max_radius_px = max_radius_px_;
    cam.model = s;
  } else {
    const auto v = parse_numbers(near_far_text_, 4, "--near-far", "NB,NE,FB,FE in metres");
    NearFarBlend b;
    b.near_begin_m = v[0];
    b.near_end_m = v[1];
    b.far_begin_m = v[2];
    b.far_end_m = v[3];
    if (given(max_radius_)) b.max_radius_px = max_radius_px_;
    cam.model = b;
  }
  return cam;
}

CameraModel CameraFlags::build(const Image* depth) const {
  check();
  CameraModel cam = assemble();
  if (const auto at = focus_at()) {
    if (!depth) throw_usage("--focus-at: needs a depth map");
    const double z = focus_from_depth(*depth, at->first, at->second);
    if (given(f_number_) || given(blur_inf_)) {
      std::visit(
          [z](auto& m) {
            using T = std::decay_t<decltype(m)>;
            if constexpr (std::is_same_v<T, ThinLens> || std::is_same_v<T, BlurAtInfinity>) m.focus_distance_m = z;
          },
          cam.model);
    } else {
      cam.model = with_focus(cam.model, z);
    }
  }
  validate(cam);
  return cam;
}

// --- depth ---------------------------------------------------------------------------------

void DepthFlags::add(CLI::App* cmd, const std::string& group) {
  cmd->add_option(
         "--depth-kind", kind_,
         "how the depth file encodes depth: z (planar distance along the view axis, default), distance "
         "(radial distance from the camera; needs --fov-deg), disparity (z = --disparity-scale / value; 8/16-bit "
         "files: normalised, bright = near), ndc or ndc-reversed (window depth in [0,1]; needs --clip)")
      ->check(CLI::IsMember({"z", "distance", "disparity", "ndc", "ndc-reversed"}))
      ->group(group);
  fov_ = cmd->add_option("--fov-deg", fov_deg_, "horizontal field of view, degrees (0..180), for --depth-kind distance")
             ->group(group);
  scale_ = cmd->add_option("--disparity-scale", disparity_scale_,
                           "z = SCALE / disparity, scene units (> 0; default 1), for --depth-kind disparity")
               ->group(group);
  clip_ = cmd->add_option("--clip", clip_text_,
                          "NEAR,FAR clip distances, scene units (FAR may be inf), for --depth-kind ndc / ndc-reversed "
                          "(default 0.1,1000)")
              ->group(group);
  cmd->add_option("--invalid-depth", invalid_,
                  "what to do with NaN, zero or negative depth: error (default; exit 3 naming the count and first "
                  "pixel) or far (treat as infinitely far)")
      ->check(CLI::IsMember({"error", "far"}))
      ->group(group);
}

io::DepthOptions DepthFlags::build() const {
  io::DepthOptions o;
  o.kind = io::parse_depth_kind(kind_);
  if (given(fov_) && o.kind != io::DepthKind::distance)
    throw_usage("--fov-deg: only applies with --depth-kind distance");
  if (given(scale_) && o.kind != io::DepthKind::disparity)
    throw_usage("--disparity-scale: only applies with --depth-kind disparity");
  const bool ndc = o.kind == io::DepthKind::ndc || o.kind == io::DepthKind::ndc_reversed;
  if (given(clip_) && !ndc) throw_usage("--clip: only applies with --depth-kind ndc or ndc-reversed");
  o.fov_deg = fov_deg_;
  o.disparity_scale = disparity_scale_;
  if (given(clip_)) {
    const auto v = parse_numbers(clip_text_, 2, "--clip", "NEAR,FAR in scene units (FAR may be inf)");
    o.clip_near = v[0];
    o.clip_far = v[1];
  }
  if (o.kind == io::DepthKind::distance && !given(fov_))
    throw_usage("--depth-kind distance: needs --fov-deg (horizontal field of view in degrees)");
  if (o.kind == io::DepthKind::distance && !(o.fov_deg > 0 && o.fov_deg < 180))
    throw_usage("--fov-deg: must be between 0 and 180 degrees");
  if (o.kind == io::DepthKind::disparity && !(o.disparity_scale > 0 && std::isfinite(o.disparity_scale)))
    throw_usage("--disparity-scale: must be > 0");
  if (ndc && !(o.clip_near > 0 && std::isfinite(o.clip_near) && o.clip_far > o.clip_near))
    throw_usage("--clip: need 0 < NEAR < FAR (FAR may be inf)");
  o.invalid_as_far = invalid_ == "far";
  return o;
}

// --- paths and outputs ---------------------------------------------------------------------

void check_paths(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs) {
  auto canon = [](const std::string& p) {
    std::error_code ec;
    fs::path c = fs::weakly_canonical(fs::absolute(p), ec);
    return ec ? fs::absolute(p).lexically_normal() : c;
  };
  struct Seen {
    const NamedPath* named;
    fs::path canonical;
    bool input;
  };
  std::vector<Seen> seen;
  for (const auto& in : inputs)
    if (!in.path.empty()) seen.push_back({&in, canon(in.path), true});
  for (const auto& out : outputs) {
    if (out.path.empty()) continue;
    const fs::path c = canon(out.path);
    for (const Seen& other : seen) {
      std::error_code ec;
      const bool same = other.canonical == c || (fs::exists(other.canonical, ec) && fs::exists(c, ec) &&
                                                 fs::equivalent(other.canonical, c, ec));
      if (same)
        throw_usage(out.flag + " " + out.path + ": is the same file as " + other.named->flag + " " + other.named->path +
                    (other.input ? " (refusing to overwrite an input)" : " (two outputs cannot share a file)"));
    }
    const fs::path dir = fs::absolute(out.path).parent_path();
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
      throw_bad_input(out.flag + " " + out.path + ": folder " + dir.string() + " does not exist");
    if (fs::is_directory(c, ec)) throw_bad_input(out.flag + " " + out.path + ": is a folder");
    seen.push_back({&out, c, false});
  }
}

void OutputWriter::add_image(const std::string& path, const Image& img, const io::WriteOptions& opt) {
  set_.add(path, [&](const std::string& temp) { io::encode_image(temp, path, img, opt); });
}

void OutputWriter::add_file(const std::string& path, const std::function<void(const std::string&)>& write) {
  set_.add(path, write);
}

void OutputWriter::commit() { set_.commit(); }

Backend parse_backend(const std::string& text) {
  if (text == "cpu") return Backend::cpu;
  if (text == "vulkan") return Backend::vulkan;
  throw_usage("--backend " + text + ": must be cpu or vulkan");
}

int check_threads(int threads) {
  if (threads < 0) throw_usage("--threads: must be >= 0 (0 = all hardware threads), got " + std::to_string(threads));
  return threads;
}

}  // namespace dofkit::cli
