// The quality run (see quality_run.hpp).
#include "quality_run.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "core/parallel.hpp"
#include "dofkit/error.hpp"
#include "dofkit/render.hpp"
#include "io/atomic_write.hpp"
#include "io/image_io.hpp"
#include "metrics/metrics.hpp"
#include "scene/scene.hpp"

namespace dofkit::cli {

namespace {

std::string available_methods() {
  std::string s;
  for (const auto& m : methods()) s += (s.empty() ? "" : ", ") + m.name;
  return s + ", input";
}

bool known_method(const std::string& name) {
  if (name == "input") return true;
  for (const auto& m : methods())
    if (m.name == name) return true;
  return false;
}

/// Progress on stderr: one line redrawn in place on a terminal, else one line per step.
class Progress {
 public:
  Progress() : tty_(isatty(fileno(stderr)) != 0), t0_(std::chrono::steady_clock::now()) {}
  ~Progress() { finish(); }
  bool animated() const { return tty_; }
  /// Fraction of the current step done (thread-safe; redraws only on a terminal, at most
  /// once per percent).
  void partial(double fraction) {
    if (!tty_) return;
    std::lock_guard<std::mutex> lock(mutex_);
    const int pct = static_cast<int>(fraction * 100);
    if (pct == last_pct_) return;
    last_pct_ = pct;
    step_locked(done_, total_, what_ + " " + std::to_string(pct) + " %");
  }
  void step(int done, int total, const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex_);
    done_ = done;
    total_ = total;
    what_ = what;
    last_pct_ = -1;
    step_locked(done, total, what);
  }
  void finish() {
    if (open_) std::fprintf(stderr, "\r\033[K");
    open_ = false;
  }

 private:
  void step_locked(int done, int total, const std::string& what) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    const int width = 24, filled = total > 0 ? width * done / total : 0;
    if (tty_) {
      const std::string bar = std::string(filled, '#') + std::string(width - filled, '.');
      std::fprintf(stderr, "\r\033[K[%s] %d/%d %5.1fs  %s", bar.c_str(), done, total, s, what.c_str());
      open_ = true;
    } else {
      std::fprintf(stderr, "[%d/%d %.1fs] %s\n", done, total, s, what.c_str());
    }
    std::fflush(stderr);
  }

  bool tty_;
  std::mutex mutex_;
  int done_ = 0, total_ = 0, last_pct_ = -1;
  std::string what_;
  bool open_ = false;
  std::chrono::steady_clock::time_point t0_;
};

nlohmann::json json_number(double v) {
  if (std::isnan(v)) return nullptr;
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

std::string fmt_db(double v) {
  if (std::isnan(v)) return "-";
  if (std::isinf(v)) return "inf";
  return fmt::format("{:.2f}", v);
}

void write_text(const std::string& path, const std::string& text) {
  io::write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f << text;
    f.close();
    if (!f) throw_bad_input(path + ": cannot write");
  });
}

/// Adds key=value to a spec; `input_layers` is the quality run's own key (the input frame's
/// hidden fragments), everything else goes to the method.
void add_param(MethodSpec& m, const std::string& key, const std::string& value, const std::string& list) {
  if (key == "input_layers") {
    char* end = nullptr;
    const long n = std::strtol(value.c_str(), &end, 10);
    if (value.empty() || *end != '\0' || n < 0 || n > 16)
      throw_usage("--methods " + list + ": input_layers=" + value + ": expected 0..16");
    m.input_layers = static_cast<int>(n);
  } else {
    m.params[key] = value;
  }
}

// Error heat map scale: display-value difference (mean over R, G, B) drawn white.
constexpr float kHeatMax = 0.2f;

}  // namespace

std::vector<MethodSpec> parse_method_list(const std::string& list) {
  std::vector<MethodSpec> out;
  std::istringstream in(list);
  std::string piece;
  while (std::getline(in, piece, ',')) {
    if (piece.empty()) throw_usage("--methods " + list + ": empty entry");
    const bool is_param = piece.find('=') != std::string::npos && piece.find(':') == std::string::npos;
    if (is_param) {
      // "key=value" continuing the previous "name:key=value".
      if (out.empty() || (out.back().params.empty() && out.back().input_layers < 0))
        throw_usage("--methods " + list + ": " + piece + " is not a method (write name:key=value,key=value)");
      const auto eq = piece.find('=');
      add_param(out.back(), piece.substr(0, eq), piece.substr(eq + 1), list);
      out.back().label += "," + piece;
      continue;
    }
    MethodSpec m;
    m.label = piece;
    const auto colon = piece.find(':');
    m.name = piece.substr(0, colon);
    if (colon != std::string::npos) {
      const std::string kv = piece.substr(colon + 1);
      const auto eq = kv.find('=');
      if (eq == std::string::npos || eq == 0)
        throw_usage("--methods " + list + ": " + piece + ": expected name:key=value");
      add_param(m, kv.substr(0, eq), kv.substr(eq + 1), list);
    }
    if (!known_method(m.name))
      throw_usage("--methods: unknown method " + m.name + " (available: " + available_methods() + ")");
    if (m.name == "input" && (!m.params.empty() || m.input_layers >= 0))
      throw_usage("--methods: input takes no parameters");
    out.push_back(std::move(m));
  }
  if (out.empty()) throw_usage("--methods: empty list");
  return out;
}

std::vector<MethodSpec> default_method_list() {
  std::vector<MethodSpec> out{{"input", "input", {}}};
  for (const auto& m : methods()) out.push_back({m.name, m.name, {}});
  return out;
}

void parse_size(const std::string& text, const char* option, int& width, int& height) {
  int w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') || w < 1 || h < 1 ||
      w > 16384 || h > 16384)
    throw_usage(std::string(option) + " " + text + ": expected WxH with 1 <= W, H <= 16384");
  width = w;
  height = h;
}

void parse_set(const std::string& text, std::map<std::string, std::map<std::string, std::string>>& set) {
  const auto dot = text.find('.'), eq = text.find('=');
  if (dot == std::string::npos || eq == std::string::npos || dot == 0 || eq < dot + 2)
    throw_usage("--set " + text + ": expected method.key=value (e.g. mcguire.samples=16)");
  const std::string method = text.substr(0, dot);
  if (!known_method(method) || method == "input")
    throw_usage("--set " + text + ": unknown method " + method + " (available: " + available_methods() + ")");
  set[method][text.substr(dot + 1, eq - dot - 1)] = text.substr(eq + 1);
}

QualityResult run_quality(const QualityOptions& opt) {
  namespace fs = std::filesystem;
  const std::vector<MethodSpec> specs = opt.methods.empty() ? default_method_list() : opt.methods;
  const std::vector<std::string> scenes = opt.scenes.empty() ? scene::scene_names() : opt.scenes;
  if (opt.out_dir.empty()) throw_usage("--out: no output folder given");
  if (opt.threads < 0) throw_usage("--threads: must be >= 0");
  if (opt.samples < 0) throw_usage("--samples: must be >= 0");
  const auto known_scenes = scene::scene_names();
  for (const auto& s : scenes)
    if (std::find(known_scenes.begin(), known_scenes.end(), s) == known_scenes.end()) {
      std::string list;
      for (const auto& k : known_scenes) list += (list.empty() ? "" : ", ") + k;
      throw_usage("--scenes: unknown scene " + s + " (available: " + list + ")");
    }

  // Settings per row; a tiny render first so that a bad --set or parameter fails now, not
  // after minutes of ground truth.
  std::vector<RenderSettings> settings(specs.size());
  for (std::size_t i = 0; i < specs.size(); ++i) {
    if (specs[i].name == "input") continue;
    RenderSettings& s = settings[i];
    s.method = specs[i].name;
    if (auto it = opt.set.find(s.method); it != opt.set.end()) s.params = it->second;
    for (const auto& [k, v] : specs[i].params) s.params[k] = v;
    s.threads = opt.threads;
    s.backend = opt.backend;
    Frame probe;
    probe.color = Image(16, 16, 4, 0.5f);
    probe.depth = Image(16, 16, 1, 2.0f);
    s.camera.model = BlurAtInfinity{2.0, 4.0};
    render(probe, s);
  }

  std::error_code ec;
  fs::create_directories(opt.out_dir, ec);
  if (ec || !fs::is_directory(opt.out_dir))
    throw_bad_input("--out " + opt.out_dir + ": cannot create the folder (" + ec.message() + ")");

  if (opt.layers < 0 || opt.layers > 16) throw_usage("--layers: expected 0..16");
  int max_layers = opt.layers;
  for (const auto& m : specs) max_layers = std::max(max_layers, m.input_layers);

  QualityResult result;
  Progress progress;
  const int total = static_cast<int>(scenes.size() * (specs.size() + 1));
  int done = 0;
  for (const std::string& name : scenes) {
    progress.step(done, total, name + ": ground truth (thin-lens ray tracing)");
    scene::SceneOptions so;
    so.width = opt.width;
    so.height = opt.height;
    so.samples = opt.samples;
    so.threads = opt.threads;
    so.layers = max_layers;
    so.progress = [&progress](double f) { progress.partial(f); };
    scene::SceneRender sr;
    core::with_threads(opt.threads, [&] { sr = scene::render_scene(name, so); });
    ++done;
    const Image& gt = sr.ground_truth;
    const Image band = metrics::edge_band(sr.pinhole.depth, metrics::kEdgeBandPx, metrics::kEdgeJump);

    // Contact sheet tiles at most 640 px wide; labels twice as big from 480 px.
    const int factor = std::max(1, (opt.width + 639) / 640);
    const int tile_w = opt.width / factor;
    const int font = tile_w >= 480 ? 2 : 1;
    std::vector<metrics::SheetCell> cells;
    cells.push_back({"ground truth (thin lens)", metrics::downsample(gt, factor), "depth (near bright), edge band blue",
                     metrics::downsample(metrics::depth_view(sr.pinhole.depth, &band), factor)});

    for (std::size_t i = 0; i < specs.size(); ++i) {
      const MethodSpec& spec = specs[i];
      progress.step(done, total, name + ": " + spec.label);
      Image out;
      double ms = std::numeric_limits<double>::quiet_NaN();
      if (spec.name == "input") {
        out = sr.pinhole.color;
      } else {
        RenderSettings s = settings[i];
        s.camera = sr.camera;
        // This row's input: the pinhole frame with at most `want` hidden fragments.
        const int want = spec.input_layers >= 0 ? spec.input_layers : opt.layers;
        Frame trimmed;
        const Frame* input = &sr.pinhole;
        if (static_cast<int>(sr.pinhole.layer_color.size()) > want) {
          trimmed.color = sr.pinhole.color;
          trimmed.depth = sr.pinhole.depth;
          if (want > 0) {
            trimmed.layer_color.assign(sr.pinhole.layer_color.begin(), sr.pinhole.layer_color.begin() + want);
            trimmed.layer_depth.assign(sr.pinhole.layer_depth.begin(), sr.pinhole.layer_depth.begin() + want);
          }
          input = &trimmed;
        }
        const auto t0 = std::chrono::steady_clock::now();
        RenderResult r = render(*input, s);
        const auto t1 = std::chrono::steady_clock::now();
        ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
        out = std::move(r.image);
      }
      const metrics::Scores sc = metrics::compare_with_mask(gt, out, &band);
      result.rows.push_back({name, spec.label, sc.psnr_db, sc.ssim, sc.edge_psnr_db, ms});
      const std::string title = spec.name == "input"
                                    ? std::string("input (pinhole)")
                                    : spec.label + (std::isnan(ms) ? "" : fmt::format("  {:.0f} ms", ms));
      const std::string caption =
          fmt::format("psnr {} ssim {:.3f} edge {}", fmt_db(sc.psnr_db), sc.ssim, fmt_db(sc.edge_psnr_db));
      const Image heat = metrics::heat_map(metrics::abs_error_map(gt, out), kHeatMax);
      metrics::SheetCell cell{title, metrics::downsample(out, factor), caption, metrics::downsample(heat, factor)};
      if (spec.name == "input")
        cells.insert(cells.begin(), std::move(cell));
      else
        cells.push_back(std::move(cell));
      ++done;
    }
    const std::string heading = fmt::format(
        "{} {}x{} - top: image; bottom: |error| vs ground truth, mean over RGB of sRGB values: black 0, red, yellow, "
        "white >= {:.1f}",
        name, opt.width, opt.height, kHeatMax);
    const int columns = std::min<int>(cells.size(), tile_w <= 400 ? 5 : 4);
    const Image sheet = metrics::contact_sheet(heading, cells, columns, font);
    const std::string path = (fs::path(opt.out_dir) / (name + ".png")).string();
    io::write_image(path, sheet);
    result.files.push_back(path);
  }
  progress.step(done, total, "writing tables");
  progress.finish();

  result.rows = metrics::with_means(result.rows);
  std::string md = "# dofkit quality\n\n";
  md += fmt::format(
      "Scenes rendered at {}x{}, ground truth with {} lens samples per pixel; scores against the "
      "thin-lens ground truth (PSNR and SSIM of clipped sRGB; edge PSNR within {} px of a depth "
      "edge; see docs/quality.md). Input frames carry {} depth layers (0 = plain RGB-D) unless a "
      "row says input_layers=N. Time = one render() call, {} threads.\n\n",
      opt.width, opt.height, opt.samples > 0 ? std::to_string(opt.samples) : std::string("the scene's default"),
      metrics::kEdgeBandPx, opt.layers, opt.threads > 0 ? std::to_string(opt.threads) : std::string("all"));
  if (!opt.command_line.empty()) md += "Regenerate: `" + opt.command_line + "`\n\n";
  md += metrics::markdown_table(result.rows);
  const std::string md_path = (fs::path(opt.out_dir) / "quality.md").string();
  write_text(md_path, md);
  result.files.push_back(md_path);

  nlohmann::json j;
  j["width"] = opt.width;
  j["height"] = opt.height;
  j["samples"] = opt.samples;
  j["layers"] = opt.layers;
  j["threads"] = opt.threads;
  j["command"] = opt.command_line;
  j["rows"] = nlohmann::json::array();
  for (const auto& r : result.rows)
    j["rows"].push_back({{"scene", r.scene},
                         {"method", r.method},
                         {"psnr_db", json_number(r.psnr_db)},
                         {"ssim", json_number(r.ssim)},
                         {"edge_psnr_db", json_number(r.edge_psnr_db)},
                         {"time_ms", json_number(r.time_ms)}});
  const std::string json_path = (fs::path(opt.out_dir) / "quality.json").string();
  write_text(json_path, j.dump(2) + "\n");
  result.files.push_back(json_path);
  return result;
}

}  // namespace dofkit::cli
