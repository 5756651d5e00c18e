// The lights file and the G-buffer reading of the lighting commands (light_common.hpp).
#include "light_common.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "cli_common.hpp"
#include "dofkit/error.hpp"
#include "io/atomic_write.hpp"
#include "io/exr_direct.hpp"
#include "io/image_io.hpp"

namespace dofkit::cli {

namespace {

std::array<double, 3> vec3(const nlohmann::json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3) throw_bad_input(where + ": must be an array of 3 numbers");
  std::array<double, 3> v{};
  for (int k = 0; k < 3; ++k) {
    if (!j[k].is_number()) throw_bad_input(where + ": element " + std::to_string(k) + " is not a number");
    v[k] = j[k].get<double>();
    if (!std::isfinite(v[k])) throw_bad_input(where + ": element " + std::to_string(k) + " is not finite");
  }
  return v;
}

double number(const nlohmann::json& j, const std::string& where) {
  if (!j.is_number()) throw_bad_input(where + ": must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw_bad_input(where + ": not a finite number");
  return v;
}

std::array<double, 3> apply(const std::array<double, 16>& m, const std::array<double, 3>& v, bool point) {
  std::array<double, 3> o{};
  for (int r = 0; r < 3; ++r)
    o[r] = m[4 * r] * v[0] + m[4 * r + 1] * v[1] + m[4 * r + 2] * v[2] + (point ? m[4 * r + 3] : 0.0);
  return o;
}

std::array<double, 16> mul4(const std::array<double, 16>& a, const std::array<double, 16>& b) {
  std::array<double, 16> o{};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 4; ++k) o[4 * r + c] += a[4 * r + k] * b[4 * k + c];
  return o;
}

// The inverse of a rotation + translation: Rᵀ, −Rᵀ·t.
std::array<double, 16> rigid_inverse(const std::array<double, 16>& m) {
  std::array<double, 16> inv{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) inv[4 * r + c] = m[4 * c + r];
  for (int r = 0; r < 3; ++r) inv[4 * r + 3] = -(inv[4 * r] * m[3] + inv[4 * r + 1] * m[7] + inv[4 * r + 2] * m[11]);
  inv[15] = 1;
  return inv;
}

// A light's "shadow" entry (docs/lighting.md): the maps and the matrices, in the light's space
// (`to_camera`: that space → camera space).
std::shared_ptr<const ShadowMaps> read_shadow(const nlohmann::json& e, const std::string& where,
                                              const std::string& lights_path, const std::array<double, 16>& to_camera) {
  if (!e.is_object()) throw_bad_input(where + ": must be an object");
  static const std::set<std::string> keys = {"maps",    "opaque_depth", "translucent_depth", "translucent_color",
                                             "size_px", "view_matrix",  "projection_matrix", "bias_m",
                                             "comment"};
  for (const auto& [k, v] : e.items())
    if (!keys.count(k)) throw_bad_input(where + ": unknown key \"" + k + "\"");
  for (const char* k : {"view_matrix", "projection_matrix", "size_px"})
    if (!e.contains(k)) throw_bad_input(where + "." + k + ": required");
  auto m = std::make_shared<ShadowMaps>();
  const std::array<double, 16> view = parse_view_matrix(e["view_matrix"], where + ".view_matrix");
  m->view = mul4(view, to_camera);
  const nlohmann::json& pj = e["projection_matrix"];
  if (!pj.is_array() || pj.size() != 16) throw_bad_input(where + ".projection_matrix: must be an array of 16 numbers");
  for (int k = 0; k < 16; ++k) {
    if (!pj[k].is_number() || !std::isfinite(pj[k].get<double>()))
      throw_bad_input(where + ".projection_matrix: element " + std::to_string(k) + " is not a finite number");
    m->projection[k] = pj[k].get<double>();
  }
  const nlohmann::json& sz = e["size_px"];
  if (!sz.is_array() || sz.size() != 2 || !sz[0].is_number_integer() || !sz[1].is_number_integer())
    throw_bad_input(where + ".size_px: must be [width, height] in texels");
  const long long sw = sz[0].get<long long>(), sh = sz[1].get<long long>();
  if (sw < 1 || sh < 1 || sw > kMaxShadowMapSide || sh > kMaxShadowMapSide)
    throw_bad_input(where + ".size_px: each side must be 1.." + std::to_string(kMaxShadowMapSide));
  if (e.contains("bias_m")) m->bias_m = number(e["bias_m"], where + ".bias_m");
  if (!(m->bias_m >= 0)) throw_bad_input(where + ".bias_m: must be >= 0 metres");
  std::string def;
  if (e.contains("maps")) {
    if (!e["maps"].is_string()) throw_bad_input(where + ".maps: must be a file name");
    def = e["maps"].get<std::string>();
  }
  const std::filesystem::path base = std::filesystem::path(lights_path).parent_path();
  // One map: its own file (default channel names, else the plain ones) or the "maps" file.
  const auto read = [&](const char* field, std::vector<std::string> names, std::vector<std::string> plain,
                        bool required, Image& out) {
    std::string file = def;
    bool own = false;
    if (e.contains(field)) {
      if (!e[field].is_string()) throw_bad_input(where + "." + field + ": must be a file name");
      file = e[field].get<std::string>();
      own = true;
    }
    if (file.empty()) {
      if (required) throw_bad_input(where + "." + field + ": required (or \"maps\")");
      return;
    }
    const std::string path = (base / file).string();
    const std::string role = where + "." + field;
    std::vector<std::string> miss;
    Image im = io::read_named_channels(path, role.c_str(), names, std::vector<bool>(names.size(), true), &miss);
    if (!miss.empty() && own) {
      miss.clear();
      names = plain;
      im = io::read_named_channels(path, role.c_str(), names, std::vector<bool>(names.size(), true), &miss);
    }
    if (!miss.empty()) {
      if (required || own || miss.size() != names.size())
        throw_bad_input(role + ": " + path + " has no channel " + miss.front());
      return;  // an optional map absent from the shared file
    }
    if (im.width() != sw || im.height() != sh)
      throw_bad_input(role + ": " + path + " is " + std::to_string(im.width()) + "x" + std::to_string(im.height()) +
                      ", size_px says " + std::to_string(sw) + "x" + std::to_string(sh));
    out = std::move(im);
  };
  read("opaque_depth", {"opaque.Z"}, {"Z"}, true, m->opaque_depth);
  read("translucent_depth", {"translucent.Z"}, {"Z"}, e.contains("translucent_color"), m->translucent_depth);
  read("translucent_color", {"translucent.R", "translucent.G", "translucent.B"}, {"R", "G", "B"},
       e.contains("translucent_depth"), m->translucent_color);
  validate_shadow_maps(*m, where);
  return m;
}

const char* kind_name(Light::Kind k) {
  switch (k) {
    case Light::Kind::point:
      return "point";
    case Light::Kind::spot:
      return "spot";
    case Light::Kind::directional:
      return "directional";
    case Light::Kind::ambient:
      return "ambient";
  }
  return "point";
}

}  // namespace

std::vector<Light> read_lights_file(const std::string& path, const CameraFile* camera) {
  const std::string file = "--lights " + path;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw_bad_input(file + ": not a readable regular file");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || static_cast<long long>(size) > kMaxLightsFileBytes)
    throw_bad_input(file + ": larger than the limit of " + std::to_string(kMaxLightsFileBytes) + " bytes");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw_bad_input(file + ": cannot open the file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const std::exception& e) {
    std::string what = e.what();
    for (char& c : what)
      if (c == '\n') c = ' ';
    throw_bad_input(file + ": not valid JSON (" + what.substr(0, 120) + ")");
  }
  if (!j.is_object()) throw_bad_input(file + ": must be a JSON object with a \"lights\" array");
  static const std::set<std::string> top_keys = {"version", "space", "view_matrix", "lights", "comment", "files"};
  for (const auto& [k, v] : j.items())
    if (!top_keys.count(k)) throw_bad_input(file + ": unknown key \"" + k + "\"");
  if (j.contains("version") && (!j["version"].is_number_integer() || j["version"].get<long long>() != 1))
    throw_bad_input(file + ": version: only version 1 is known");
  std::string default_space = "camera";
  if (j.contains("space")) {
    if (!j["space"].is_string() || (j["space"] != "camera" && j["space"] != "world"))
      throw_bad_input(file + ": space: must be \"camera\" or \"world\"");
    default_space = j["space"].get<std::string>();
  }
  bool has_view = false;
  std::array<double, 16> view{};
  if (j.contains("view_matrix")) {
    view = parse_view_matrix(j["view_matrix"], file + ": view_matrix");
    has_view = true;
  } else if (camera && camera->has_view) {
    view = camera->view;
    has_view = true;
  }
  if (!j.contains("lights") || !j["lights"].is_array()) throw_bad_input(file + ": lights: must be an array");
  const nlohmann::json& arr = j["lights"];
  if (static_cast<long long>(arr.size()) > kMaxLights)
    throw_bad_input(file + ": lights: " + std::to_string(arr.size()) + " lights, more than the limit of " +
                    std::to_string(kMaxLights));
  static const std::set<std::string> keys = {"type",  "name",      "space",    "position_m", "direction",
                                             "color", "intensity", "radius_m", "inner_deg",  "outer_deg",
                                             "ao",    "shadow",    "comment"};
  std::vector<Light> out;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string where = file + ": lights[" + std::to_string(i) + "]";
    const nlohmann::json& e = arr[i];
    if (!e.is_object()) throw_bad_input(where + ": must be an object");
    for (const auto& [k, v] : e.items())
      if (!keys.count(k)) throw_bad_input(where + ": unknown key \"" + k + "\"");
    Light l;
    if (!e.contains("type") || !e["type"].is_string())
      throw_bad_input(where + ".type: required (point, spot, directional or ambient)");
    const std::string type = e["type"].get<std::string>();
    if (type == "point")
      l.kind = Light::Kind::point;
    else if (type == "spot")
      l.kind = Light::Kind::spot;
    else if (type == "directional")
      l.kind = Light::Kind::directional;
    else if (type == "ambient")
      l.kind = Light::Kind::ambient;
    else
      throw_bad_input(where + ".type: \"" + type + "\" is not point, spot, directional or ambient");
    const bool local = l.kind == Light::Kind::point || l.kind == Light::Kind::spot;
    const bool directed = l.kind == Light::Kind::spot || l.kind == Light::Kind::directional;
    if (e.contains("name")) {
      if (!e["name"].is_string()) throw_bad_input(where + ".name: must be a string");
      l.name = e["name"].get<std::string>();
    }
    std::string space = default_space;
    if (e.contains("space")) {
      if (!e["space"].is_string() || (e["space"] != "camera" && e["space"] != "world"))
        throw_bad_input(where + ".space: must be \"camera\" or \"world\"");
      space = e["space"].get<std::string>();
    }
    const auto require = [&](const char* key, bool needed) {
      if (needed && !e.contains(key)) throw_bad_input(where + "." + key + ": required for a " + type + " light");
      if (!needed && e.contains(key)) throw_bad_input(where + "." + key + ": not used by a " + type + " light");
    };
    require("position_m", local);
    require("radius_m", local);
    require("direction", directed);
    if (l.kind != Light::Kind::spot) {
      require("inner_deg", false);
      require("outer_deg", false);
    } else {
      require("outer_deg", true);
    }
    if (local) {
      l.position_m = vec3(e["position_m"], where + ".position_m");
      l.radius_m = number(e["radius_m"], where + ".radius_m");
    }
    if (directed) l.direction = vec3(e["direction"], where + ".direction");
    if (l.kind == Light::Kind::spot) {
      l.outer_deg = number(e["outer_deg"], where + ".outer_deg");
      l.inner_deg = e.contains("inner_deg") ? number(e["inner_deg"], where + ".inner_deg") : 0.0;
    }
    if (e.contains("color")) l.color = vec3(e["color"], where + ".color");
    if (e.contains("intensity")) l.intensity = number(e["intensity"], where + ".intensity");
    l.ao = l.kind == Light::Kind::ambient;
    if (e.contains("ao")) {
      if (!e["ao"].is_boolean()) throw_bad_input(where + ".ao: must be true or false");
      l.ao = e["ao"].get<bool>();
    }
    if (space == "world" && l.kind != Light::Kind::ambient) {
      if (!has_view)
        throw_bad_input(where +
                        ".space: world-space light but no view_matrix (in the lights file or the --camera "
                        "file)");
      l.position_m = apply(view, l.position_m, true);
      l.direction = apply(view, l.direction, false);
    }
    if (e.contains("shadow")) {
      if (l.kind == Light::Kind::ambient) throw_bad_input(where + ".shadow: an ambient light casts no shadow");
      static const std::array<double, 16> identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
      l.shadow = read_shadow(e["shadow"], where + ".shadow", path, space == "world" ? rigid_inverse(view) : identity);
      l.casts_shadows = true;
    }
    // Field names in the messages are the file's ("lights[3].radius_m: …").
    validate_light(l, where);
    out.push_back(std::move(l));
  }
  return out;
}

nlohmann::json lights_json(const std::vector<Light>& lights, bool world, const std::array<double, 16>& m,
                           const std::vector<std::string>& shadow_files) {
  nlohmann::json j;
  j["version"] = 1;
  j["space"] = world ? "world" : "camera";
  if (world) j["view_matrix"] = m;
  j["lights"] = nlohmann::json::array();
  const std::array<double, 16> inv = rigid_inverse(m);
  for (std::size_t k = 0; k < lights.size(); ++k) {
    const Light& l = lights[k];
    nlohmann::json e;
    e["type"] = kind_name(l.kind);
    if (!l.name.empty()) e["name"] = l.name;
    const bool local = l.kind == Light::Kind::point || l.kind == Light::Kind::spot;
    if (local) {
      e["position_m"] = world ? apply(inv, l.position_m, true) : l.position_m;
      e["radius_m"] = l.radius_m;
    }
    if (l.kind == Light::Kind::spot || l.kind == Light::Kind::directional)
      e["direction"] = world ? apply(inv, l.direction, false) : l.direction;
    if (l.kind == Light::Kind::spot) {
      e["inner_deg"] = l.inner_deg;
      e["outer_deg"] = l.outer_deg;
    }
    e["color"] = l.color;
    e["intensity"] = l.intensity;
    e["ao"] = l.ao;
    if (l.shadow && k < shadow_files.size() && !shadow_files[k].empty()) {
      const ShadowMaps& sm = *l.shadow;
      nlohmann::json sj;
      sj["maps"] = shadow_files[k];
      sj["size_px"] = {sm.opaque_depth.width(), sm.opaque_depth.height()};
      // The file's view matrix maps the light's own space (world here) to light space.
      sj["view_matrix"] = world ? mul4(sm.view, m) : sm.view;
      sj["projection_matrix"] = sm.projection;
      sj["bias_m"] = sm.bias_m;
      e["shadow"] = sj;
    }
    j["lights"].push_back(e);
  }
  return j;
}

void write_shadow_maps(const std::string& path, const ShadowMaps& m) {
  std::vector<io::exr::OutChannel> ch = {{"opaque.Z", m.opaque_depth.plane(0)}};
  if (!m.translucent_depth.empty()) {
    ch.push_back({"translucent.Z", m.translucent_depth.plane(0)});
    ch.push_back({"translucent.R", m.translucent_color.plane(0)});
    ch.push_back({"translucent.G", m.translucent_color.plane(1)});
    ch.push_back({"translucent.B", m.translucent_color.plane(2)});
  }
  io::write_atomically(path, [&](const std::string& tmp) {
    io::exr::write_scanline(tmp, path, m.opaque_depth.width(), m.opaque_depth.height(), ch, false, "zip");
  });
}

GBufferRef GBufferImages::ref() const {
  GBufferRef r;
  r.depth = &depth;
  r.normals = &normals;
  r.albedo = &albedo;
  r.specular = has_specular ? &specular : nullptr;
  r.gloss = has_gloss ? &gloss : nullptr;
  r.emissive = has_emissive ? &emissive : nullptr;
  return r;
}

namespace {

struct BufferSpec {
  const char* name;
  const std::string* file;
  std::vector<std::string> defaults;
  bool optional;
};

std::vector<std::string> split_names(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string p;
  while (std::getline(in, p, ',')) out.push_back(p);
  return out;
}

std::map<std::string, std::vector<std::string>> parse_maps(const std::vector<std::string>& maps) {
  std::map<std::string, std::vector<std::string>> out;
  static const std::map<std::string, int> counts = {{"depth", 1},    {"normals", 3}, {"albedo", 3},
                                                    {"specular", 3}, {"gloss", 1},   {"emissive", 3}};
  for (const std::string& m : maps) {
    const auto eq = m.find('=');
    if (eq == std::string::npos) throw_usage("--channels " + m + ": expected BUFFER=NAME[,NAME,NAME]");
    const std::string buf = m.substr(0, eq);
    const auto it = counts.find(buf);
    if (it == counts.end())
      throw_usage("--channels " + m + ": unknown buffer " + buf +
                  " (depth, normals, albedo, specular, gloss, emissive)");
    std::vector<std::string> names = split_names(m.substr(eq + 1));
    if (static_cast<int>(names.size()) != it->second ||
        std::any_of(names.begin(), names.end(), [](const std::string& n) { return n.empty(); }))
      throw_usage("--channels " + m + ": " + buf + " takes " + std::to_string(it->second) + " channel name(s)");
    out[buf] = names;
  }
  return out;
}

}  // namespace

void check_gbuffer_flags(const GBufferFiles& f) {
  parse_maps(f.channel_maps);
  const std::pair<const char*, const std::string*> needed[] = {
      {"--depth", &f.depth}, {"--normals", &f.normals}, {"--albedo", &f.albedo}};
  for (const auto& [flag, file] : needed)
    if (file->empty() && f.gbuffer.empty())
      throw_usage(std::string(flag) + ": no file (give --gbuffer FILE, or " + flag + " FILE)");
}

GBufferImages read_gbuffer(const GBufferFiles& f) {
  const auto maps = parse_maps(f.channel_maps);
  GBufferImages g;
  const auto file_of = [&](const std::string& own) { return own.empty() ? f.gbuffer : own; };
  const auto read = [&](const char* buf, const std::string& own, std::vector<std::string> defaults,
                        std::vector<std::string> fallback, bool optional, Image& out) -> bool {
    const std::string path = file_of(own);
    if (path.empty()) return false;
    const auto it = maps.find(buf);
    std::vector<std::string> names = it != maps.end() ? it->second : defaults;
    const std::string role = std::string(buf);
    // A file of its own without a channel map: the G-buffer names, else plain R, G, B (Y).
    if (it == maps.end() && !own.empty()) {
      std::vector<std::string> miss;
      Image probe = io::read_named_channels(path, role.c_str(), names, std::vector<bool>(names.size(), true), &miss);
      if (miss.empty()) {
        out = std::move(probe);
        return true;
      }
      names = fallback;
    }
    std::vector<std::string> miss;
    Image im = io::read_named_channels(path, role.c_str(), names, std::vector<bool>(names.size(), optional), &miss);
    if (!miss.empty()) {
      for (const std::string& m : miss) g.missing.push_back(std::string(buf) + " (" + m + ")");
      return false;
    }
    out = std::move(im);
    return true;
  };
  if (!f.depth.empty() && maps.find("depth") == maps.end())
    g.depth = io::read_depth(f.depth, {});
  else
    read("depth", f.depth, {"Z"}, {"Y"}, false, g.depth);
  if (!f.normals.empty() && maps.find("normals") == maps.end())
    g.normals = io::read_normals(f.normals);
  else
    read("normals", f.normals, {"N.X", "N.Y", "N.Z"}, {"X", "Y", "Z"}, false, g.normals);
  read("albedo", f.albedo, {"albedo.R", "albedo.G", "albedo.B"}, {"R", "G", "B"}, false, g.albedo);
  g.has_specular =
      read("specular", f.specular, {"specular.R", "specular.G", "specular.B"}, {"R", "G", "B"}, true, g.specular);
  g.has_gloss = read("gloss", f.gloss, {"gloss"}, {"Y"}, true, g.gloss);
  g.has_emissive =
      read("emissive", f.emissive, {"emissive.R", "emissive.G", "emissive.B"}, {"R", "G", "B"}, true, g.emissive);
  const struct {
    const Image* im;
    bool present;
    const char* name;
    const std::string* own;
  } all[] = {{&g.normals, true, "normals", &f.normals},
             {&g.albedo, true, "albedo", &f.albedo},
             {&g.specular, g.has_specular, "specular", &f.specular},
             {&g.gloss, g.has_gloss, "gloss", &f.gloss},
             {&g.emissive, g.has_emissive, "emissive", &f.emissive}};
  for (const auto& b : all)
    if (b.present && !b.im->same_size(g.depth))
      throw_bad_input(file_of(*b.own) + ": " + b.name + " is " + std::to_string(b.im->width()) + "x" +
                      std::to_string(b.im->height()) + ", the depth " + std::to_string(g.depth.width()) + "x" +
                      std::to_string(g.depth.height()));
  return g;
}

}  // namespace dofkit::cli
