// Shared CLI pieces (see cli_common.hpp).
#include "cli_common.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <sstream>
#include <tuple>

#include "budget.hpp"
#include "dofkit/error.hpp"
#include "dofkit/render.hpp"
#include "io/image_io.hpp"
#include "io/layers_io.hpp"

namespace fs = std::filesystem;

namespace dofkit::cli {

namespace {

bool given(const CLI::Option* o) { return o && o->count() > 0; }

const std::vector<std::string> kStarcraftRows = {"--starcraft", "--starcraft", "--starcraft", "--starcraft AMOUNT"};

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

}  // namespace

std::vector<double> parse_numbers(const std::string& text, std::size_t count, const std::string& flag,
                                  const std::string& form, const std::vector<std::string>& rows) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  std::string part;
  auto fail = [&] {
    throw_usage(flag + ": expected " + form + " (" + std::to_string(count) + " comma-separated numbers), got '" + text +
                "'");
  };
  while (std::getline(ss, part, ',')) {
    part = trim(part);
    if (part.empty()) fail();
    parts.push_back(part);
  }
  if (!text.empty() && text.back() == ',') fail();
  if (parts.size() != count) fail();
  std::vector<double> v;
  for (std::size_t i = 0; i < count; ++i) {
    const std::string& row = rows.size() == 1 ? rows[0] : rows.at(i);
    try {
      v.push_back(parse_number(row, parts[i]));
    } catch (const Error& e) {
      // The range's message, said of the flag and the whole value.
      const std::string m = e.what(), after = m.substr(m.find(": ") + 2);
      if (m.find("not a number") != std::string::npos) fail();
      throw_usage(flag + " " + text + ": " +
                  (count > 1 ? "value " + std::to_string(i + 1) + " (" + parts[i] + ") " : "") + after);
    }
  }
  return v;
}

CLI::Validator range_check(const std::string& row) {
  // Throws dofkit's own usage error (CLI11 lets it through) so that the message is the
  // table's: "--f-number 1e-320: must be 0.1 to 10000". The value is handed on to CLI11 in
  // a form its own conversion reads the same (it would read "010" as octal).
  return CLI::Validator(
      [row](std::string& value) -> std::string {
        const double v = parse_number(row, value);
        if (numeric_range(row).integer) {
          value = std::to_string(static_cast<long long>(v));
        } else {
          char buf[40];
          std::snprintf(buf, sizeof buf, "%.17g", v);
          value = buf;
        }
        return {};
      },
      "", "range " + row);
}

void BudgetFlags::add(CLI::App* cmd, bool pixels) {
  if (pixels)
    add_number(cmd, "--max-pixels", max_pixels,
               "refuse input files whose header declares more than this many pixels (width x height), checked "
               "before any pixel memory is allocated (default 268435456 = 2^28)");
  add_number(cmd, "--max-memory", max_memory_mib,
             "refuse work whose estimated peak memory is above this many MiB, before any pixel is read or made "
             "(default: 3/4 of the machine's memory; see docs/robustness.md)");
}

void BudgetFlags::apply() const {
  io::set_pixel_budget(max_pixels);
  set_memory_budget_mib(max_memory_mib);
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
  focus_ = add_number(cmd, "--focus", focus_m_,
                      "focus distance, metres (scene units): the depth that is sharp. Used with --f-number and "
                      "--blur-at-infinity")
               ->group(group);
  focus_at_ = cmd->add_option("--focus-at", focus_at_text_,
                              "X,Y: focus on the median depth of the 7x7 pixels around pixel (X, Y) (pixels from the "
                              "top-left corner); replaces --focus, and refocuses --planes/--starcraft/--near-far")
                  ->group(group);
  focus_keys_ = cmd->add_option("--focus-keys", focus_keys_text_,
                                "FRAME:METRES,FRAME:METRES,...: animate the focus distance over --frames (rack focus), "
                                "eased in and out between keys (docs/cli.md); replaces --focus")
                    ->group(group);
  focus_at_keys_ = cmd->add_option("--focus-at-keys", focus_at_keys_text_,
                                   "FRAME:X,Y,FRAME:X,Y,...: as --focus-keys, each key's distance measured like "
                                   "--focus-at on the frame's depth; replaces --focus-at")
                       ->group(group);
  f_number_ = add_number(cmd, "--f-number", f_number_v_,
                         "MODEL physical thin lens: aperture f-number N (> 0), e.g. 2.8. With --focus, "
                         "--focal-length, --sensor-width")
                  ->group(group);
  f_number_keys_ = cmd->add_option("--f-number-keys", f_number_keys_text_,
                                   "FRAME:N,FRAME:N,...: MODEL as --f-number with the f-number animated over --frames, "
                                   "eased in and out between keys like --focus-keys; replaces --f-number")
                       ->group(group);
  focal_length_ =
      add_number(cmd, "--focal-length", focal_length_mm_, "thin lens focal length, millimetres (default 50)")
          ->group(group);
  sensor_width_ = add_number(cmd, "--sensor-width", sensor_width_mm_,
                             "thin lens sensor width, millimetres (default 36, full frame); the image width spans it")
                      ->group(group);
  blur_inf_ = add_number(cmd, "--blur-at-infinity", blur_inf_px_,
                         "MODEL thin lens given by K, the blur radius of a point at infinity, pixels (>= 0): "
                         "r(z) = K (focus/z - 1). With --focus")
                  ->group(group);
  blur_inf_keys_ = cmd->add_option("--blur-at-infinity-keys", blur_inf_keys_text_,
                                   "FRAME:PX,FRAME:PX,...: MODEL as --blur-at-infinity with K animated over --frames, "
                                   "eased in and out between keys like --focus-keys; replaces --blur-at-infinity")
                       ->group(group);
  planes_ =
      cmd->add_option("--planes", planes_text_,
                      "MODEL four-plane artist model NB,NS,FS,FB, metres, 0 < NB < NS <= FS < FB (FB may be inf): "
                      "blur ramps from --near-radius at NB to 0 at NS, and from 0 at FS to --far-radius at FB")
          ->group(group);
  near_radius_ = add_number(cmd, "--near-radius", near_radius_px_, "--planes: maximum near blur radius, pixels (>= 0)")
                     ->group(group);
  far_radius_ =
      add_number(cmd, "--far-radius", far_radius_px_, "--planes: maximum far blur radius, pixels (>= 0)")->group(group);
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
  max_radius_ = add_number(cmd, "--max-radius", max_radius_px_,
                           "--starcraft / --near-far: radius of full blur, pixels (>= 0; default 16 for "
                           "--starcraft, 12 for --near-far)")
                    ->group(group);
  max_coc_ = add_number(cmd, "--max-coc", max_coc_px_,
                        "clamp every CoC radius to this many pixels (> 0; default: none). Radii are also capped at a "
                        "quarter of the image width (at least 8 px)")
                 ->group(group);
  reference_width_ = add_number(cmd, "--reference-width", reference_width_px_,
                                "image width, pixels, at which pixel radii are given (default: the input's width); "
                                "radii scale with the input width / this")
                         ->group(group);
}

bool CameraFlags::model_given() const {
  return given(f_number_) || given(blur_inf_) || given(planes_) || given(starcraft_) || given(near_far_) ||
         given(f_number_keys_) || given(blur_inf_keys_);
}

bool CameraFlags::focus_missing() const {
  const bool thin = given(f_number_) || given(blur_inf_) || given(f_number_keys_) || given(blur_inf_keys_);
  return thin && !given(focus_) && !given(focus_at_) && !given(focus_keys_) && !given(focus_at_keys_);
}

std::optional<std::pair<int, int>> CameraFlags::focus_at() const {
  if (!given(focus_at_)) return std::nullopt;
  const std::vector<double> v = parse_numbers(focus_at_text_, 2, "--focus-at", "X,Y pixel coordinates", {"--focus-at"});
  return std::make_pair(static_cast<int>(v[0]), static_cast<int>(v[1]));
}

void CameraFlags::check(bool focus_from_input) const {
  std::vector<std::string> models;
  if (given(f_number_)) models.push_back("--f-number");
  if (given(f_number_keys_)) models.push_back("--f-number-keys");
  if (given(blur_inf_)) models.push_back("--blur-at-infinity");
  if (given(blur_inf_keys_)) models.push_back("--blur-at-infinity-keys");
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
  // A key flag is its model's flag animated: the same companions apply.
  const std::string model = models[0] == "--f-number-keys"           ? "--f-number"
                            : models[0] == "--blur-at-infinity-keys" ? "--blur-at-infinity"
                                                                     : models[0];
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
  {
    std::vector<const char*> focus_flags;
    if (given(focus_)) focus_flags.push_back("--focus");
    if (given(focus_at_)) focus_flags.push_back("--focus-at");
    if (given(focus_keys_)) focus_flags.push_back("--focus-keys");
    if (given(focus_at_keys_)) focus_flags.push_back("--focus-at-keys");
    if (focus_flags.size() > 1)
      throw_usage(std::string(focus_flags[0]) + " and " + focus_flags[1] + ": give only one of them");
  }
  if (focus_missing() && !focus_from_input)
    throw_usage(models[0] + ": needs --focus M (focus distance in metres), --focus-at X,Y or --focus-keys");
  focus_keys();  // syntax and order
  if (given(f_number_keys_)) value_keys("--f-number-keys", f_number_keys_text_, "--f-number");
  if (given(blur_inf_keys_)) value_keys("--blur-at-infinity-keys", blur_inf_keys_text_, "--blur-at-infinity");
  if (model == "--planes" && (!given(near_radius_) || !given(far_radius_)))
    throw_usage("--planes: needs --near-radius PX and --far-radius PX");
  if (model == "--planes") parse_numbers(planes_text_, 4, "--planes", "NB,NS,FS,FB in metres", {"--planes"});
  if (model == "--starcraft")
    parse_numbers(starcraft_text_, 4, "--starcraft", "FOCUS,FULL,NONE,AMOUNT", kStarcraftRows);
  if (model == "--near-far") parse_numbers(near_far_text_, 4, "--near-far", "NB,NE,FB,FE in metres", {"--near-far"});
  focus_at();  // syntax
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
  if (given(f_number_) || given(f_number_keys_)) {
    ThinLens t;
    // Keys: the first key's value stands in until build() knows the frame.
    t.f_number =
        given(f_number_) ? f_number_v_ : value_keys("--f-number-keys", f_number_keys_text_, "--f-number")[0].second;
    t.focal_length_mm = focal_length_mm_;
    t.sensor_width_mm = sensor_width_mm_;
    t.focus_distance_m = focus;
    cam.model = t;
  } else if (given(blur_inf_) || given(blur_inf_keys_)) {
    cam.model = BlurAtInfinity{
        focus, given(blur_inf_)
                   ? blur_inf_px_
                   : value_keys("--blur-at-infinity-keys", blur_inf_keys_text_, "--blur-at-infinity")[0].second};
  } else if (given(planes_)) {
    const auto v = parse_numbers(planes_text_, 4, "--planes", "NB,NS,FS,FB in metres", {"--planes"});
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
    const auto v = parse_numbers(starcraft_text_, 4, "--starcraft", "FOCUS,FULL,NONE,AMOUNT", kStarcraftRows);
    StarCraft s;
    s.focus_distance_m = v[0];
    s.full_focus_range_m = v[1];
    s.no_focus_range_m = v[2];
    s.amount = v[3];
    if (given(max_radius_)) s.max_radius_px = max_radius_px_;
    cam.model = s;
  } else {
    const auto v = parse_numbers(near_far_text_, 4, "--near-far", "NB,NE,FB,FE in metres", {"--near-far"});
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

void CameraFlags::require_focus(const std::optional<double>& recorded_focus_m, const std::string& input) const {
  if (focus_missing() && !recorded_focus_m)
    throw_usage(std::string(given(f_number_) || given(f_number_keys_) ? "--f-number" : "--blur-at-infinity") +
                ": needs --focus M (focus distance in metres), --focus-at X,Y or --focus-keys (" + input +
                " records no focus distance)");
}

bool CameraFlags::animated() const {
  return given(focus_keys_) || given(focus_at_keys_) || given(f_number_keys_) || given(blur_inf_keys_);
}

namespace {
// A frame number of a key: digits only, 0 to 999999999.
long parse_key_frame(const std::string& flag, const std::string& text, const std::string& whole) {
  if (text.empty() || text.size() > 9 ||
      !std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); }))
    throw_usage(flag + " " + whole + ": frame '" + text + "' is not a frame number (0 to 999999999)");
  return std::stol(text);
}

// The comma-separated parts of a key flag's text, trimmed (a trailing comma gives an empty
// last part, which no key form accepts).
std::vector<std::string> key_parts(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ',')) parts.push_back(trim(part));
  if (text.empty() || text.back() == ',') parts.push_back("");
  return parts;
}

// Keys must come in increasing frame order: `frame` after `previous` (none: -1).
void check_key_order(const std::string& flag, const std::string& text, long previous, long frame) {
  if (previous >= 0 && frame <= previous)
    throw_usage(flag + " " + text + ": frame " + std::to_string(frame) +
                (frame == previous ? " is given twice" : " comes after frame " + std::to_string(previous)) +
                "; keys must be in increasing frame order");
}

// A key's value error (parse_number's "FLAG VALUE: why") restated for the key flag.
[[noreturn]] void bad_key_value(const std::string& flag, const std::string& text, long frame, const Error& e) {
  const std::string m = e.what();
  throw_usage(flag + " " + text + ": key at frame " + std::to_string(frame) + ": " + m.substr(m.find(": ") + 2));
}
}  // namespace

std::vector<FocusKey> CameraFlags::focus_keys() const {
  std::vector<FocusKey> keys;
  const bool at = given(focus_at_keys_);
  if (!at && !given(focus_keys_)) return keys;
  const std::string flag = at ? "--focus-at-keys" : "--focus-keys";
  const std::string& text = at ? focus_at_keys_text_ : focus_keys_text_;
  const std::string form = at ? "FRAME:X,Y,FRAME:X,Y,..." : "FRAME:METRES,FRAME:METRES,...";
  const std::vector<std::string> parts = key_parts(text);
  const std::size_t per_key = at ? 2 : 1;
  if (parts.size() % per_key != 0) throw_usage(flag + " " + text + ": expected " + form);
  for (std::size_t i = 0; i < parts.size(); i += per_key) {
    const auto colon = parts[i].find(':');
    if (colon == std::string::npos || (at && parts[i + 1].find(':') != std::string::npos))
      throw_usage(flag + " " + text + ": expected " + form);
    FocusKey k;
    k.frame = parse_key_frame(flag, parts[i].substr(0, colon), text);
    const std::string value = parts[i].substr(colon + 1);
    try {
      if (at) {
        k.x = static_cast<int>(parse_number("--focus-at", value));
        k.y = static_cast<int>(parse_number("--focus-at", parts[i + 1]));
      } else {
        k.focus_m = parse_number("--focus", value);
      }
    } catch (const Error& e) {
      bad_key_value(flag, text, k.frame, e);
    }
    check_key_order(flag, text, keys.empty() ? -1 : keys.back().frame, k.frame);
    keys.push_back(k);
  }
  return keys;
}

std::vector<std::pair<long, double>> CameraFlags::value_keys(const std::string& flag, const std::string& text,
                                                             const std::string& value_flag) const {
  std::vector<std::pair<long, double>> keys;
  for (const std::string& key : key_parts(text)) {
    const auto colon = key.find(':');
    if (colon == std::string::npos) throw_usage(flag + " " + text + ": expected FRAME:VALUE,FRAME:VALUE,...");
    const long frame = parse_key_frame(flag, key.substr(0, colon), text);
    double value = 0;
    try {
      value = parse_number(value_flag, key.substr(colon + 1));
    } catch (const Error& e) {
      bad_key_value(flag, text, frame, e);
    }
    check_key_order(flag, text, keys.empty() ? -1 : keys.back().first, frame);
    keys.emplace_back(frame, value);
  }
  return keys;
}

double eased_focus(const std::vector<double>& key_focus_m, const std::vector<long>& key_frames, long frame) {
  if (frame <= key_frames.front()) return key_focus_m.front();
  if (frame >= key_frames.back()) return key_focus_m.back();
  std::size_t i = 0;
  while (key_frames[i + 1] < frame) ++i;
  if (key_frames[i + 1] == frame) return key_focus_m[i + 1];
  const double t = static_cast<double>(frame - key_frames[i]) / static_cast<double>(key_frames[i + 1] - key_frames[i]);
  const double s = t * t * (3.0 - 2.0 * t);
  return key_focus_m[i] + (key_focus_m[i + 1] - key_focus_m[i]) * s;
}

CameraModel CameraFlags::build(const Image* depth, long frame, std::optional<double> recorded_focus_m) const {
  check(recorded_focus_m.has_value());
  CameraModel cam = assemble();
  if (animated() && frame < 0) {
    const char* flag = given(focus_keys_)      ? "--focus-keys"
                       : given(focus_at_keys_) ? "--focus-at-keys"
                       : given(f_number_keys_) ? "--f-number-keys"
                                               : "--blur-at-infinity-keys";
    throw_usage(std::string(flag) + ": needs --frames");
  }
  // Animated aperture: the eased f-number or blur at infinity of this frame.
  for (const auto& [opt, flag, value_flag] :
       {std::tuple{f_number_keys_, "--f-number-keys", "--f-number"},
        std::tuple{blur_inf_keys_, "--blur-at-infinity-keys", "--blur-at-infinity"}}) {
    if (!given(opt)) continue;
    const auto keys = value_keys(flag, opt == f_number_keys_ ? f_number_keys_text_ : blur_inf_keys_text_, value_flag);
    std::vector<double> v;
    std::vector<long> f;
    for (const auto& [kf, kv] : keys) {
      f.push_back(kf);
      v.push_back(kv);
    }
    const double value = eased_focus(v, f, frame);
    std::visit(
        [value](auto& m) {
          using T = std::decay_t<decltype(m)>;
          if constexpr (std::is_same_v<T, ThinLens>) m.f_number = value;
          if constexpr (std::is_same_v<T, BlurAtInfinity>) m.blur_at_infinity_px = value;
        },
        cam.model);
  }
  std::optional<double> focus_z;
  if (focus_missing()) focus_z = *recorded_focus_m;  // check() refused it without one
  if (given(focus_keys_) || given(focus_at_keys_)) {
    const std::vector<FocusKey> keys = focus_keys();
    std::vector<double> z;
    std::vector<long> f;
    for (const FocusKey& k : keys) {
      f.push_back(k.frame);
      if (given(focus_keys_)) {
        z.push_back(k.focus_m);
      } else {
        if (!depth) throw_usage("--focus-at-keys: needs a depth map");
        z.push_back(focus_from_depth(*depth, k.x, k.y));
      }
    }
    focus_z = eased_focus(z, f, frame);
  } else if (const auto at = focus_at()) {
    if (!depth) throw_usage("--focus-at: needs a depth map");
    focus_z = focus_from_depth(*depth, at->first, at->second);
  }
  if (focus_z) {
    const double z = *focus_z;
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
  kind_opt_ =
      cmd->add_option(
             "--depth-kind", kind_,
             "how the depth file encodes depth: z (planar distance along the view axis, default), distance "
             "(radial distance from the camera; needs --fov-deg), disparity (z = --disparity-scale / value; 8/16-bit "
             "files: normalised, bright = near), ndc or ndc-reversed (window depth in [0,1]; needs --clip), linear "
             "(z = NEAR + value (FAR - NEAR), value in [0,1]; needs --clip)")
          ->check(CLI::IsMember({"z", "distance", "disparity", "ndc", "ndc-reversed", "linear"}))
          ->group(group);
  fov_ = add_number(cmd, "--fov-deg", fov_deg_, "horizontal field of view, degrees, for --depth-kind distance")
             ->group(group);
  scale_ = add_number(cmd, "--disparity-scale", disparity_scale_,
                      "z = SCALE / disparity, scene units (> 0; default 1), for --depth-kind disparity")
               ->group(group);
  clip_ = cmd->add_option("--clip", clip_text_,
                          "NEAR,FAR clip distances, scene units (FAR may be inf), for --depth-kind ndc / ndc-reversed "
                          "(default 0.1,1000) and linear (finite FAR, no default)")
              ->group(group);
  cmd->add_option("--depth-channel", channel_,
                  "NAME of the depth channel of a multi-channel file (exact, else ignoring case); default: chosen by "
                  "name (Z, depth.Z, *depth*.Z, other <layer>.Z; never N.*, P.* or motion passes; see docs/cli.md)")
      ->group(group);
  depth_scale_ = add_number(cmd, "--depth-scale", depth_scale_v_,
                            "file depth x SCALE = metres (default 1), e.g. 0.01 for a depth in centimetres; applied "
                            "after --depth-kind's conversion")
                     ->group(group);
  depth_units_ = cmd->add_option("--depth-units", units_,
                                 "unit of the depth file: m (default), cm, mm, in or ft (sets --depth-scale)")
                     ->check(CLI::IsMember({"m", "cm", "mm", "in", "ft"}))
                     ->group(group);
  cmd->add_option("--depth-upsample", upsample_,
                  "a depth map smaller than the colour: nearest, bilinear (in 1/z) or guided (default: edge-aware, "
                  "colour-guided; depth edges follow colour edges, the two sides never blend; docs/cli.md has the "
                  "measurement); guided-filter: He et al.'s guided filter, the measured alternative")
      ->check(CLI::IsMember({"nearest", "bilinear", "guided", "guided-filter"}))
      ->group(group);
  cmd->add_flag("--depth-refine", refine_,
                "re-snap a soft depth map of the colour's size to the colour's edges (phone maps blur hair and "
                "silhouettes into halos): reduced 4x and brought back by the guided upsampling")
      ->group(group);
  cmd->add_option("--depth-fit", fit_,
                  "a smaller depth map of another aspect ratio: refused (same-aspect, default) or scaled per axis "
                  "(stretch)")
      ->check(CLI::IsMember({"same-aspect", "stretch"}))
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
  const bool linear = o.kind == io::DepthKind::linear;
  if (given(clip_) && !ndc && !linear)
    throw_usage("--clip: only applies with --depth-kind ndc, ndc-reversed or linear");
  if (linear && !given(clip_)) throw_usage("--depth-kind linear: needs --clip NEAR,FAR (the depths of 0 and 1)");
  o.fov_deg = fov_deg_;
  o.disparity_scale = disparity_scale_;
  if (given(clip_)) {
    const auto v = parse_numbers(clip_text_, 2, "--clip", "NEAR,FAR in scene units (FAR may be inf)", {"--clip"});
    o.clip_near = v[0];
    o.clip_far = v[1];
  }
  if (o.kind == io::DepthKind::distance && !given(fov_))
    throw_usage("--depth-kind distance: needs --fov-deg (horizontal field of view in degrees)");
  if (ndc && !(std::isfinite(o.clip_near) && o.clip_far > o.clip_near))
    throw_usage("--clip " + clip_text_ + ": need NEAR < FAR (FAR may be inf)");
  o.invalid_as_far = invalid_ == "far";
  o.channel = channel_;
  o.upsample = io::parse_depth_upsample(upsample_);
  o.stretch = fit_ == "stretch";
  o.refine = refine_;
  if (given(depth_scale_) && given(depth_units_)) throw_usage("--depth-scale and --depth-units: give only one of them");
  if (given(depth_units_)) {
    static const std::map<std::string, double> kUnits = {
        {"m", 1.0}, {"cm", 0.01}, {"mm", 0.001}, {"in", 0.0254}, {"ft", 0.3048}};
    o.scale = kUnits.at(units_);
  } else {
    o.scale = depth_scale_v_;
  }
  return o;
}

// --- the focus-zone picture ---

Image focus_zone_picture(const Image& coc) {
  constexpr float kNear[3] = {1.0f, 0.55f, 0.0f}, kFar[3] = {0.0f, 0.45f, 1.0f}, kFocus = 0.5f;
  float largest = 0;
  for (const float r : coc.data())
    if (std::isfinite(r)) largest = std::max(largest, std::fabs(r));
  Image pic(coc.width(), coc.height(), 3);
  for (std::size_t i = 0; i < coc.plane_size(); ++i) {
    const float r = coc.plane(0)[i];
    if (!(std::fabs(r) >= 0.5f)) {  // in focus (NaN too)
      for (int c = 0; c < 3; ++c) pic.plane(c)[i] = kFocus;
      continue;
    }
    const float t = std::isfinite(r) ? std::fabs(r) / largest : 1.0f;
    const float* hue = r > 0 ? kNear : kFar;
    for (int c = 0; c < 3; ++c) pic.plane(c)[i] = hue[c] * t;
  }
  return pic;
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

CLI::Option* add_threads(CLI::App* cmd, int& threads, const std::string& help) {
  return add_number(cmd, "--threads", threads, help);
}

void out_of_memory(const std::string& what) {
  throw_bad_input("out of memory while " + what +
                  " (the machine has less free memory than --max-memory allowed for: lower --max-memory or the "
                  "image size)");
}

Backend parse_backend(const std::string& text) {
  if (text == "cpu") return Backend::cpu;
  if (text == "vulkan") return Backend::vulkan;
  throw_usage("--backend " + text + ": must be cpu or vulkan");
}

void ApertureFlags::add(CLI::App* cmd, bool rotation_alias, const std::string& group) {
  add_number(cmd, "--blades", shape_.blades,
             "aperture blades: 0 = circle (default), 3..16 = a regular polygon whose vertices lie on the circle "
             "of radius |r| (Blender Cycles' convention)")
      ->group(group);
  add_number(cmd, rotation_alias ? "--blade-rotation,--rotation" : "--blade-rotation", shape_.rotation_deg,
             "polygon rotation, degrees counter-clockwise on screen; 0 = a flat edge facing +x behind the focus "
             "(in front of it the bokeh is turned by 180 degrees), as Blender's aperture rotation" +
                 std::string(rotation_alias ? "; --rotation is the older spelling" : ""),
             "--blade-rotation")
      ->group(group);
  add_number(cmd, "--blade-curvature", shape_.curvature,
             "0 = straight blades (default) .. 1 = circle; in between the edges bulge out (vertices fixed)")
      ->group(group);
  add_number(cmd, "--anamorphic", shape_.anamorphic,
             "anamorphic squeeze 0.1..10: bokeh width = height / RATIO (Blender's aperture ratio; 1 = round, "
             "e.g. 1.33 or 2 for oval bokeh)")
      ->group(group);
  add_number(cmd, "--cat-eye", shape_.cat_eye,
             "optical vignetting 0..1 (0 = off): off-axis bokeh is clipped by a second circle displaced toward "
             "the frame centre, by AMOUNT x the radius at the corners")
      ->group(group);
  cmd->add_option("--aperture-image", image_,
                  "FILE: a grey or RGB image (<= 1024x1024) used as the bokeh kernel instead of --blades (RGB: one "
                  "kernel per colour channel; each normalised to unit energy); its longer side spans the bokeh's "
                  "diameter, its top is the top of the bokeh behind the focus; 8/16-bit files are sRGB-decoded")
      ->group(group);
}

void ApertureFlags::check() const {
  validate(shape_);
  if (!image_.empty() && shape_.blades != 0) throw_usage("--aperture-image: replaces --blades; give one of them");
}

ApertureShape ApertureFlags::build() const {
  check();
  ApertureShape a = shape_;
  if (!image_.empty()) {
    Image rgba;
    try {
      rgba = io::read_color(image_);
    } catch (const Error& e) {
      throw Error(e.kind(), "--aperture-image " + std::string(e.what()));
    }
    // Premultiplied RGB: a transparent pixel passes no light.
    auto img = std::make_shared<Image>(rgba.width(), rgba.height(), 3);
    for (int c = 0; c < 3; ++c) std::copy(rgba.plane(c), rgba.plane(c) + rgba.plane_size(), img->plane(c));
    a.image = std::move(img);
    try {
      validate(a);
    } catch (const Error& e) {
      throw Error(e.kind(), std::string(e.what()) + " (" + image_ + ")");
    }
  }
  return a;
}

std::string ApertureFlags::text() const {
  std::ostringstream s;
  if (shape_.blades) s << " --blades " << shape_.blades;
  if (shape_.rotation_deg != 0) s << " --blade-rotation " << shape_.rotation_deg;
  if (shape_.curvature != 0) s << " --blade-curvature " << shape_.curvature;
  if (shape_.anamorphic != 1) s << " --anamorphic " << shape_.anamorphic;
  if (shape_.cat_eye != 0) s << " --cat-eye " << shape_.cat_eye;
  if (!image_.empty()) s << " --aperture-image " << image_;
  const std::string t = s.str();
  return t.empty() ? t : t.substr(1);
}

void HighlightFlags::add(CLI::App* cmd, const std::string& group) {
  add_number(cmd, "--highlight-threshold", h_.threshold,
             "display value in [0, 1) above which a pixel counts as clipped (default 0.9)")
      ->group(group);
  boost_opt_ = add_number(cmd, "--highlight-boost", h_.boost,
                          "energy a fully clipped pixel gets back: its linear colour x (1 + BOOST), ramping in "
                          "from the threshold (>= 0; 0 = off). Default: " +
                              std::to_string(static_cast<int>(kDefaultDisplayBoost)) +
                              " for 8/16-bit colour files (display-referred, clipped at 1; measured, see "
                              "docs/methods/highlights.md), 0 for float files (EXR, float TIFF)")
                   ->group(group);
  cmd->add_flag("--highlight-restore", h_.restore,
                "map the result back through the inverse of the boost curve (display-referred output); without it "
                "the boosted highlights stay above 1 (scene-referred)")
      ->group(group);
}

void HighlightFlags::check() const { validate(h_); }

std::string HighlightFlags::text() const {
  std::ostringstream s;
  if (h_.threshold != 0.9) s << " --highlight-threshold " << h_.threshold;
  if (given(boost_opt_)) s << " --highlight-boost " << h_.boost;
  if (h_.restore) s << " --highlight-restore";
  const std::string t = s.str();
  return t.empty() ? t : t.substr(1);
}

HighlightRecovery HighlightFlags::build(bool display_referred) const {
  check();
  HighlightRecovery h = h_;
  if (!given(boost_opt_)) h.boost = display_referred ? kDefaultDisplayBoost : 0.0;
  return h;
}

Frame read_layered_frame(const std::string& color, const std::string& depth, const std::string& layers,
                         const io::DepthOptions& depth_opt, const std::vector<std::string>& color_channels,
                         int max_layers, io::DepthFacts* facts) {
  Frame frame;
  if (!color.empty()) frame.color = io::read_color(color, color_channels);
  if (!depth.empty()) frame.depth = io::read_depth(depth, depth_opt, facts);
  io::read_layers(layers, frame, max_layers);
  if (frame.depth.empty() && !color.empty()) {
    // --color without --depth: its own Z channel if it has one, else the layers' depth.
    if (!depth_opt.channel.empty() || io::has_depth_channel(color))
      frame.depth = io::read_depth(color, depth_opt, facts);
  }
  if (!frame.depth.same_size(frame.color))
    throw_bad_input((depth.empty() ? layers : depth) + ": depth is " + std::to_string(frame.depth.width()) + "x" +
                    std::to_string(frame.depth.height()) + " but colour is " + std::to_string(frame.color.width()) +
                    "x" + std::to_string(frame.color.height()));
  validate_frame(frame, (color.empty() ? layers : color).c_str());
  return frame;
}

}  // namespace dofkit::cli
