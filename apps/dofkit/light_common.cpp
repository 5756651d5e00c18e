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
  static const std::set<std::string> keys = {"type",      "name",      "space",     "position_m",
                                             "direction", "color",     "intensity", "radius_m",
                                             "inner_deg", "outer_deg", "ao",        "comment"};
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
    // Field names in the messages are the file's ("lights[3].radius_m: …").
    validate_light(l, where);
    out.push_back(std::move(l));
  }
  return out;
}

nlohmann::json lights_json(const std::vector<Light>& lights, bool world, const std::array<double, 16>& m) {
  nlohmann::json j;
  j["version"] = 1;
  j["space"] = world ? "world" : "camera";
  if (world) j["view_matrix"] = m;
  j["lights"] = nlohmann::json::array();
  // The inverse of a rotation + translation: Rᵀ, −Rᵀ·t.
  std::array<double, 16> inv{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) inv[4 * r + c] = m[4 * c + r];
  for (int r = 0; r < 3; ++r) inv[4 * r + 3] = -(inv[4 * r] * m[3] + inv[4 * r + 1] * m[7] + inv[4 * r + 2] * m[11]);
  inv[15] = 1;
  for (const Light& l : lights) {
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
    j["lights"].push_back(e);
  }
  return j;
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
