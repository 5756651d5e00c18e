// Shared pieces of the AO commands (ssao_common.hpp) and the AO quality run.
#include "ssao_common.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <sstream>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "core/parallel.hpp"
#include "dofkit/ao.hpp"
#include "dofkit/error.hpp"
#include "effects/ssao/ssao.hpp"
#include "io/atomic_write.hpp"
#include "io/image_io.hpp"
#include "metrics/ao_metrics.hpp"
#include "metrics/metrics.hpp"
#include "metrics/report.hpp"
#include "scene/raytracer.hpp"
#include "scene/scene.hpp"

namespace dofkit::cli {

namespace fs = std::filesystem;

std::array<double, 16> parse_view_matrix(const nlohmann::json& j, const std::string& where) {
  std::array<double, 16> m{};
  if (!j.is_array() || j.size() != 16)
    throw_bad_input(where + ": must be an array of 16 numbers (a row-major 4x4 world-to-camera matrix)");
  for (int k = 0; k < 16; ++k) {
    if (!j[k].is_number() || !std::isfinite(j[k].get<double>()))
      throw_bad_input(where + ": element " + std::to_string(k) + " is not a finite number");
    m[k] = j[k].get<double>();
  }
  if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1) throw_bad_input(where + ": the last row must be 0 0 0 1");
  // The upper 3x3 must be a rotation (lights keep their radii): R·Rᵀ = I, det = +1.
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double d = 0;
      for (int k = 0; k < 3; ++k) d += m[4 * a + k] * m[4 * b + k];
      if (std::abs(d - (a == b ? 1.0 : 0.0)) > 1e-6)
        throw_bad_input(where + ": the upper 3x3 is not a rotation (orthonormal rows needed; no scale or shear)");
    }
  const double det =
      m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) + m[2] * (m[4] * m[9] - m[5] * m[8]);
  if (det < 0) throw_bad_input(where + ": the upper 3x3 is a reflection (determinant -1), not a rotation");
  return m;
}

CameraFile read_camera_file(const std::string& path, int width, int height) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw_bad_input("--camera " + path + ": cannot open the file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const std::exception& e) {
    throw_bad_input("--camera " + path + ": not valid JSON (" + std::string(e.what()).substr(0, 120) + ")");
  }
  if (!j.is_object() || !j.contains("hfov_deg") || !j["hfov_deg"].is_number())
    throw_bad_input("--camera " + path + ": no field of view (a number hfov_deg, degrees)");
  CameraFile c;
  c.hfov_deg = j["hfov_deg"].get<double>();
  if (!(c.hfov_deg > 0 && c.hfov_deg < 180))
    throw_bad_input("--camera " + path + ": hfov_deg must be in (0, 180) degrees");
  for (const char* key : {"width", "height"}) {
    if (!j.contains(key)) continue;
    const int want = key[0] == 'w' ? width : height;
    if (!j[key].is_number_integer() || j[key].get<long long>() != want)
      throw_bad_input("--camera " + path + ": " + key + " " + j[key].dump() + " does not match the depth's " +
                      std::to_string(width) + "x" + std::to_string(height));
  }
  if (j.contains("view_matrix")) {
    c.view = parse_view_matrix(j["view_matrix"], "--camera " + path + ": view_matrix");
    c.has_view = true;
  }
  return c;
}

double read_camera_fov(const std::string& path, int width, int height) {
  return read_camera_file(path, width, height).hfov_deg;
}

std::string ssao_params_help() {
  std::string s = "\nAO methods, their --set parameters (units, defaults, ranges) and debug views:\n";
  for (const MethodInfo& m : ao_methods()) {
    s += "\n  " + m.name + ": " + m.summary + "\n";
    for (const ParamInfo& p : m.params)
      s += "    " + p.name + " (" + param_kind(p) + ", default " + p.default_value + "): " + p.help + "\n";
    s += "    debug views:";
    for (const DebugViewInfo& v : m.debug_views) s += " " + v.name;
    s += "\n";
  }
  return s;
}

std::vector<AoSpec> parse_ao_method_list(const std::string& list) {
  std::vector<AoSpec> out;
  std::istringstream in(list);
  std::string piece;
  while (std::getline(in, piece, ',')) {
    if (piece.empty()) throw_usage("--methods " + list + ": empty entry");
    const auto eq = piece.find('='), colon = piece.find(':');
    if (eq != std::string::npos && colon == std::string::npos) {
      if (out.empty() || out.back().params.empty())
        throw_usage("--methods " + list + ": " + piece + " is not a method (write name:key=value,key=value)");
      out.back().params[piece.substr(0, eq)] = piece.substr(eq + 1);
      out.back().label += "," + piece;
      continue;
    }
    AoSpec a;
    a.label = piece;
    a.name = piece.substr(0, colon);
    if (colon != std::string::npos) {
      const std::string kv = piece.substr(colon + 1);
      const auto e = kv.find('=');
      if (e == std::string::npos || e == 0)
        throw_usage("--methods " + list + ": " + piece + ": expected name:key=value");
      a.params[kv.substr(0, e)] = kv.substr(e + 1);
    }
    if (a.name != "sc2" && a.name != "gtao")
      throw_usage("--methods: unknown AO method " + a.name + " (available: sc2, gtao)");
    out.push_back(std::move(a));
  }
  if (out.empty()) throw_usage("--methods: empty list");
  // Every row's parameters are checked now, not after minutes of ground truth.
  for (const AoSpec& a : out) {
    AoSettings s;
    s.method = a.name;
    s.hfov_deg = 60;
    s.params = a.params;
    AoRenderer check(s);
  }
  return out;
}

namespace {

// One scored case: a depth (+ normals) with its reference AO.
struct AoCase {
  std::string name;
  double radius_m = 0, hfov_deg = 0;
  Image depth, normals, reference;
};

std::string radius_text(double r) { return fmt::format("{:g}", r); }

AoCase scene_case(const std::string& name, double radius, const AoQualityOptions& opt) {
  const scene::Scene sc = scene::build_scene(name);
  scene::SceneOptions so;
  so.width = opt.width;
  so.height = opt.height;
  const scene::LensCamera cam = scene::camera_for(sc, so);
  AoCase c;
  c.name = name + " r=" + radius_text(radius);
  c.radius_m = radius;
  c.hfov_deg = cam.hfov_deg;
  // The reference takes minutes at 640x360 with 4096 rays: --ao-cache keeps it between runs
  // (named by everything it depends on).
  const std::string cached = opt.cache_dir.empty()
                                 ? std::string()
                                 : (fs::path(opt.cache_dir) / fmt::format("ao_{}_{}x{}_r{}_n{}.exr", name, opt.width,
                                                                          opt.height, radius_text(radius), opt.rays))
                                       .string();
  core::with_threads(opt.threads, [&] {
    scene::GBuffer g = scene::render_gbuffer(sc, cam);
    c.depth = std::move(g.z);
    c.normals = std::move(g.normal);
    if (!cached.empty() && fs::exists(cached)) {
      c.reference = io::read_mask(cached);
      if (c.reference.same_size(c.depth)) return;
    }
    c.reference = scene::render_ao(sc, cam, radius, opt.rays, 1);
    if (!cached.empty()) {
      io::WriteOptions w;
      w.channel_name = "Y";
      io::write_image(cached, c.reference, w);
    }
  });
  return c;
}

// A folder rendered by another renderer: pinhole_depth.exr (Z), normal.exr (camera space
// X right, Y up, Z towards the camera), ao.exr (one channel) and params.json giving
// ao_distance_m and f_px (or hfov_deg).
AoCase external_case(const std::string& dir) {
  const fs::path d(dir);
  std::ifstream f(d / "params.json", std::ios::binary);
  if (!f) throw_bad_input("--external " + dir + ": no params.json");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const std::exception&) {
    throw_bad_input("--external " + dir + ": params.json is not valid JSON");
  }
  AoCase c;
  c.depth = io::read_depth((d / "pinhole_depth.exr").string(), {});
  c.normals = io::read_normals((d / "normal.exr").string());
  c.reference = io::read_mask((d / "ao.exr").string());
  if (!c.normals.same_size(c.depth) || !c.reference.same_size(c.depth))
    throw_bad_input("--external " + dir + ": pinhole_depth.exr, normal.exr and ao.exr differ in size");
  if (!j.contains("ao_distance_m") || !j["ao_distance_m"].is_number())
    throw_bad_input("--external " + dir + ": params.json has no ao_distance_m");
  c.radius_m = j["ao_distance_m"].get<double>();
  if (j.contains("hfov_deg") && j["hfov_deg"].is_number())
    c.hfov_deg = j["hfov_deg"].get<double>();
  else if (j.contains("f_px") && j["f_px"].is_number())
    c.hfov_deg = 2 * std::atan(0.5 * c.depth.width() / j["f_px"].get<double>()) * 180 / std::numbers::pi;
  else
    throw_bad_input("--external " + dir + ": params.json gives neither hfov_deg nor f_px");
  c.name = fs::path(dir).lexically_normal().filename().string();
  if (c.name.empty()) c.name = fs::path(dir).lexically_normal().parent_path().filename().string();
  c.name += " r=" + radius_text(c.radius_m) + " (external)";
  return c;
}

Image run_method(const AoSpec& m, const AoCase& c, const AoQualityOptions& opt, double* ms) {
  AoSettings s;
  s.method = m.name;
  s.params = m.params;
  s.radius_m = c.radius_m;
  s.hfov_deg = c.hfov_deg;
  s.threads = opt.threads;
  AoRenderer r(s);
  const auto t0 = std::chrono::steady_clock::now();
  Image out = r.render(c.depth, opt.no_normals ? nullptr : &c.normals).ao;
  if (ms) *ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

double mse_of(const Image& ref, const Image& test, const Image& depth) {
  double s = 0, n = 0;
  for (std::size_t i = 0; i < ref.plane_size(); ++i) {
    if (std::isinf(depth.plane(0)[i])) continue;
    const double d = static_cast<double>(test.plane(0)[i]) - ref.plane(0)[i];
    s += d * d;
    n += 1;
  }
  return n > 0 ? s / n : 0;
}

// An AO plane as an RGBA picture whose display value is the AO value (so the sheet, which
// sRGB-encodes, shows AO 0.5 as mid grey 128).
Image ao_picture(const Image& ao) {
  Image p(ao.width(), ao.height(), 4, 1.0f);
  for (std::size_t i = 0; i < ao.plane_size(); ++i) {
    const float v = metrics::linear_from_display(std::clamp(ao.plane(0)[i], 0.0f, 1.0f));
    p.plane(0)[i] = p.plane(1)[i] = p.plane(2)[i] = v;
  }
  return p;
}

using detail_sc2_start = std::map<std::string, double>;

// The artist values sc2 would use for these parameters (preset + overrides).
detail_sc2_start sc2_start_values(const std::map<std::string, std::string>& params) {
  const detail::ao::Sc2Params p = detail::ao::parse_sc2(params);
  return {{"small_radius", p.small.radius},
          {"small_full_occlusion", p.small.full_occlusion},
          {"small_no_occlusion", p.small.no_occlusion},
          {"small_occlusion_power", p.small.occlusion_power},
          {"full_occlusion", p.wide.full_occlusion},
          {"no_occlusion", p.wide.no_occlusion},
          {"occlusion_power", p.wide.occlusion_power}};
}

// Coordinate descent over sc2's artist parameters, in log steps, for the lowest mean MSE over
// the cases; prints the fitted values.
// The fit starts from `base` (the first sc2 row's parameters: its preset, or the chapter
// values, and any other key it sets, which stays fixed).
std::map<std::string, std::string> fit_sc2(const std::vector<AoCase>& cases, const AoQualityOptions& opt,
                                           const std::map<std::string, std::string>& base) {
  struct Knob {
    const char* key;
    double value, lo, hi;
  };
  std::vector<Knob> knobs = {{"small_radius", 0, 0.02, 1},       {"small_full_occlusion", 0, 0, 4},
                             {"small_no_occlusion", 0, 0.01, 8}, {"small_occlusion_power", 0, 0.1, 8},
                             {"full_occlusion", 0, 0, 4},        {"no_occlusion", 0, 0.01, 8},
                             {"occlusion_power", 0, 0.1, 8}};
  // Start values: the base row's, else its preset's (the defaults ao_methods() lists are the
  // chapter preset's; a tuned base starts from the tuned values via parse).
  {
    const detail_sc2_start start = sc2_start_values(base);
    for (Knob& k : knobs) k.value = start.at(k.key);
  }
  const auto params_of = [&](const std::vector<Knob>& k) {
    std::map<std::string, std::string> p = base;
    for (const Knob& x : k) p[x.key] = fmt::format("{:.4g}", x.value);
    return p;
  };
  const auto cost = [&](const std::vector<Knob>& k) {
    for (std::size_t i = 0; i < k.size(); ++i)
      if (!(k[i].value >= k[i].lo && k[i].value <= k[i].hi)) return 1e9;
    if (!(k[2].value > k[1].value) || !(k[5].value > k[4].value)) return 1e9;
    AoSpec m{"sc2", "sc2", params_of(k)};
    double sum = 0;
    for (const AoCase& c : cases) sum += mse_of(c.reference, run_method(m, c, opt, nullptr), c.depth);
    return sum / static_cast<double>(cases.size());
  };
  double best = cost(knobs);
  std::cerr << fmt::format("fit: start mse {:.6f}\n", best);
  double step = 1.6;
  for (int round = 0; round < 12 && step > 1.04; ++round) {
    bool improved = false;
    for (std::size_t i = 0; i < knobs.size(); ++i) {
      for (double f : {step, 1 / step}) {
        std::vector<Knob> trial = knobs;
        // Thresholds that start at 0 move additively.
        trial[i].value = knobs[i].value == 0 ? (f > 1 ? 0.02 : 0) : knobs[i].value * f;
        const double c = cost(trial);
        if (c < best) {
          best = c;
          knobs = trial;
          improved = true;
        }
      }
    }
    std::string line;
    for (const Knob& k : knobs) line += fmt::format(" {}={:.4g}", k.key, k.value);
    std::cerr << fmt::format("fit: round {} step {:.3f} mse {:.6f}{}\n", round, step, best, line);
    if (!improved) step = std::sqrt(step);
  }
  return params_of(knobs);
}

nlohmann::json json_number(double v) {
  if (std::isnan(v)) return nullptr;
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

void write_text(const std::string& path, const std::string& text) {
  io::write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f << text;
    f.close();
    if (!f) throw_bad_input(path + ": cannot write");
  });
}

}  // namespace

void run_ao_quality(const AoQualityOptions& opt) {
  if (opt.out_dir.empty()) throw_usage("--out: no output folder given");
  if (opt.rays < 1 || opt.rays > (1 << 20)) throw_usage("--ao-rays: must be 1..1048576");
  for (double r : opt.radii)
    if (!(r > 0) || !std::isfinite(r)) throw_usage("--radii: each radius must be a finite number of metres > 0");
  const std::vector<std::string> known = scene::ao_scene_names();
  const std::vector<std::string> scenes = opt.scenes.empty() ? known : opt.scenes;
  for (const std::string& s : scenes)
    if (std::find(known.begin(), known.end(), s) == known.end())
      throw_usage("--scenes: " + s + " is not an AO scene (AO scenes: ao_corner, ao_shelf)");
  std::vector<AoSpec> methods = opt.methods;
  if (methods.empty()) methods = parse_ao_method_list("sc2,sc2:preset=tuned,gtao");
  std::error_code ec;
  fs::create_directories(opt.out_dir, ec);
  if (ec || !fs::is_directory(opt.out_dir))
    throw_bad_input("--out " + opt.out_dir + ": cannot create the folder (" + ec.message() + ")");

  std::vector<AoCase> own, external;
  for (const std::string& s : scenes) {
    const double own_radius = scene::build_scene(s).ao_radius_m;
    for (double r : opt.radii.empty() ? std::vector<double>{own_radius} : opt.radii) {
      std::cerr << fmt::format("{} r={}: ground truth ({} rays per pixel)\n", s, radius_text(r), opt.rays);
      own.push_back(scene_case(s, r, opt));
    }
  }
  for (const std::string& dir : opt.external) external.push_back(external_case(dir));

  if (opt.fit) {
    std::map<std::string, std::string> base;
    for (const AoSpec& m : methods)
      if (m.name == "sc2") {
        base = m.params;
        break;
      }
    const std::map<std::string, std::string> p = fit_sc2(own, opt, base);
    std::string line;
    for (const auto& [k, v] : p) line += (line.empty() ? "" : ",") + k + "=" + v;
    std::cout << "fitted sc2 parameters: " << line << "\n";
    methods.push_back({"sc2:fitted", "sc2", p});
  }

  struct Row {
    std::string scene, method;
    metrics::AoScores s;
    double ms = std::numeric_limits<double>::quiet_NaN();
  };
  std::vector<Row> rows;
  std::vector<AoCase*> cases;
  for (AoCase& c : own) cases.push_back(&c);
  for (AoCase& c : external) cases.push_back(&c);
  for (AoCase* c : cases) {
    std::vector<metrics::SheetCell> cells;
    cells.push_back({"reference AO", ao_picture(c->reference), "", Image()});
    // The image of the reference's mean AO (over the non-sky pixels): what no spatial
    // information at all scores.
    double mean = 0, n = 0;
    for (std::size_t i = 0; i < c->depth.plane_size(); ++i)
      if (!std::isinf(c->depth.plane(0)[i])) {
        mean += c->reference.plane(0)[i];
        n += 1;
      }
    Image flat(c->depth.width(), c->depth.height(), 1, n > 0 ? static_cast<float>(mean / n) : 1.0f);
    for (std::size_t i = 0; i < flat.plane_size(); ++i)
      if (std::isinf(c->depth.plane(0)[i])) flat.plane(0)[i] = 1.0f;
    rows.push_back({c->name, "mean AO (constant)", metrics::compare_ao(c->reference, flat, c->depth)});
    for (const AoSpec& m : methods) {
      double ms = 0;
      const Image out = run_method(m, *c, opt, &ms);
      const metrics::AoScores s = metrics::compare_ao(c->reference, out, c->depth);
      rows.push_back({c->name, m.label, s, ms});
      Image err(out.width(), out.height(), 1);
      for (std::size_t i = 0; i < err.plane_size(); ++i)
        err.plane(0)[i] = std::abs(out.plane(0)[i] - c->reference.plane(0)[i]);
      cells.push_back({fmt::format("{}  {:.0f} ms", m.label, ms), ao_picture(out),
                       fmt::format("psnr {:.2f} ssim {:.3f} mean err {:+.3f}", s.psnr_db, s.ssim, s.mean_error),
                       metrics::heat_map(err, 0.2f)});
    }
    std::string file = c->name;
    for (char& ch : file)
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.' && ch != '_') ch = '_';
    const std::string path = (fs::path(opt.out_dir) / ("ao_" + file + ".png")).string();
    io::write_image(path, metrics::contact_sheet(c->name + " - top: AO; bottom: |error| (white >= 0.2)", cells,
                                                 std::min<int>(4, cells.size()), c->depth.width() >= 480 ? 2 : 1));
    std::cerr << "wrote " << path << "\n";
  }

  // Means over the own scenes (the external cases are reported on their own).
  std::vector<Row> means;
  for (const Row& r : rows) {
    if (r.scene.find("(external)") != std::string::npos) continue;
    if (std::find_if(means.begin(), means.end(), [&](const Row& m) { return m.method == r.method; }) != means.end())
      continue;
    Row m{"mean of own scenes", r.method, {}, 0};
    int count = 0;
    double edge = 0;
    int edge_n = 0;
    for (const Row& q : rows)
      if (q.method == r.method && q.scene.find("(external)") == std::string::npos) {
        m.s.psnr_db += q.s.psnr_db;
        m.s.ssim += q.s.ssim;
        m.s.mean_error += q.s.mean_error;
        m.ms += std::isnan(q.ms) ? 0 : q.ms;
        if (!std::isnan(q.s.edge_psnr_db)) {
          edge += q.s.edge_psnr_db;
          ++edge_n;
        }
        ++count;
      }
    m.s.psnr_db /= count;
    m.s.ssim /= count;
    m.s.mean_error /= count;
    m.s.edge_psnr_db = edge_n ? edge / edge_n : std::numeric_limits<double>::quiet_NaN();
    m.ms = std::isnan(r.ms) ? r.ms : m.ms / count;
    means.push_back(m);
  }
  rows.insert(rows.end(), means.begin(), means.end());

  const auto num = [](double v, const char* f) {
    if (std::isnan(v)) return std::string("–");
    if (std::isinf(v)) return std::string("inf");
    return fmt::format(fmt::runtime(f), v);
  };
  std::string md = "# dofkit AO quality\n\n";
  md += fmt::format(
      "Built-in AO scenes at {}x{}, reference AO ray-traced with {} cosine-weighted quasi-random rays per pixel; "
      "external folders scored against their own ao.exr. Scores of the linear AO (PSNR peak 1 and mean signed "
      "error over the non-sky pixels, SSIM of the values, edge PSNR within 12 px of a depth edge). Methods get the "
      "{}. Time = one render, {} threads.\n\n",
      opt.width, opt.height, opt.rays, opt.no_normals ? "depth only (normals reconstructed)" : "depth and the normals",
      opt.threads > 0 ? std::to_string(opt.threads) : std::string("all"));
  if (!opt.command_line.empty()) md += "Regenerate: `" + opt.command_line + "`\n\n";
  md +=
      "| scene | method | PSNR dB | SSIM | edge PSNR dB | mean error | time ms |\n|---|---|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows)
    md += fmt::format("| {} | {} | {} | {} | {} | {} | {} |\n", r.scene, r.method, num(r.s.psnr_db, "{:.2f}"),
                      num(r.s.ssim, "{:.4f}"), num(r.s.edge_psnr_db, "{:.2f}"), num(r.s.mean_error, "{:+.4f}"),
                      num(r.ms, "{:.1f}"));
  std::cout << md;
  write_text((fs::path(opt.out_dir) / "ao_quality.md").string(), md);
  nlohmann::json j;
  j["width"] = opt.width;
  j["height"] = opt.height;
  j["rays"] = opt.rays;
  j["command"] = opt.command_line;
  j["rows"] = nlohmann::json::array();
  for (const Row& r : rows)
    j["rows"].push_back({{"scene", r.scene},
                         {"method", r.method},
                         {"psnr_db", json_number(r.s.psnr_db)},
                         {"ssim", json_number(r.s.ssim)},
                         {"edge_psnr_db", json_number(r.s.edge_psnr_db)},
                         {"mean_error", json_number(r.s.mean_error)},
                         {"time_ms", json_number(r.ms)}});
  write_text((fs::path(opt.out_dir) / "ao_quality.json").string(), j.dump(2) + "\n");
}

}  // namespace dofkit::cli
