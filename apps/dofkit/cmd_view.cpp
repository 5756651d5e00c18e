// `dofkit view`: a local web page over one image (or a built-in scene folder) with click to
// focus, a live preview and Save (docs/cli.md#view).
//
// Security model (the server listens on 127.0.0.1 only):
//   - every request carries the random token (?token=… or the cookie the page gets with it);
//   - the Host header must be 127.0.0.1:PORT or localhost:PORT (DNS rebinding);
//   - a body above kMaxBody bytes is refused from its Content-Length before it is read;
//   - the only files read are the inputs given at start; the only files written are inside
//     --save-dir (relative paths without "..", no symlink on the way out of the folder).
// Previews render on one worker thread: a new request cancels the render in flight (the
// library's progress callback) and only the newest request is computed.
#include <httplib.h>
#include <nlohmann/json.hpp>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <sstream>
#include <thread>

#include "cli_common.hpp"
#include "commands.hpp"
#include "dofkit/error.hpp"
#include "dofkit/render.hpp"
#include "io/image_io.hpp"
#include "io/srgb.hpp"
#include "metrics/metrics.hpp"
#include "view_page.hpp"

namespace dofkit::cli {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr std::size_t kMaxBody = 64 * 1024;  // JSON requests only
constexpr int kMaxPreviewWidth = 8192;

struct ViewArgs {
  std::string scene_dir, color, depth, layers, save_dir, method = "lens", debug_view;
  std::vector<std::string> sets;
  int port = 0, threads = 0;
  bool no_browser = false;
  BudgetFlags budget;
  CameraFlags camera;
  DepthFlags depth_flags;
  ApertureFlags aperture;
  HighlightFlags highlights;
  std::vector<std::string> depth_flag_args;  // the depth-convention flags as given, for the command line
};

std::string exact(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  // The shortest text that reads back as the same double.
  for (int p = 1; p <= 17; ++p) {
    char t[64];
    std::snprintf(t, sizeof t, "%.*g", p, v);
    if (std::strtod(t, nullptr) == v) return t;
  }
  return buf;
}

std::string shell_quote(const std::string& s) {
  if (!s.empty() && s.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_./,=+:@%") ==
                        std::string::npos)
    return s;
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// The page's settings: the thin-lens camera (by f-number or blur at infinity), the aperture,
// highlight recovery and the method. Turned into `dofkit render` flags, which are parsed by
// the render command's own flag classes, so the page gets the CLI's validation and Save is
// that very command.
struct ViewState {
  bool f_number_model = true;
  double f_number = 2.8, focal_length_mm = 50, sensor_width_mm = 36, blur_at_infinity_px = 8;
  double focus_m = 5;
  std::optional<std::pair<int, int>> focus_at;
  double max_coc_px = 0, reference_width_px = 0;  // 0 = none / the image width
  int blades = 0;
  double rotation_deg = 0, curvature = 0, anamorphic = 1, cat_eye = 0;
  std::optional<double> highlight_boost;  // none: the CLI's default for the file
  std::string method = "lens", debug_view;
  std::vector<std::string> sets;  // the start's --set (kept while the method is the start's)
};

json to_json(const ViewState& s) {
  json j;
  j["model"] = s.f_number_model ? "f_number" : "blur_at_infinity";
  j["f_number"] = s.f_number;
  j["focal_length_mm"] = s.focal_length_mm;
  j["sensor_width_mm"] = s.sensor_width_mm;
  j["blur_at_infinity_px"] = s.blur_at_infinity_px;
  j["focus_m"] = s.focus_m;
  j["focus_at"] = s.focus_at ? json::array({s.focus_at->first, s.focus_at->second}) : json(nullptr);
  j["max_coc_px"] = s.max_coc_px;
  j["blades"] = s.blades;
  j["blade_rotation_deg"] = s.rotation_deg;
  j["blade_curvature"] = s.curvature;
  j["anamorphic"] = s.anamorphic;
  j["cat_eye"] = s.cat_eye;
  j["highlight_boost"] = s.highlight_boost ? json(*s.highlight_boost) : json(nullptr);
  j["method"] = s.method;
  j["debug_view"] = s.debug_view;
  return j;
}

double num(const json& j, const char* key, double def) {
  if (!j.contains(key) || j[key].is_null()) return def;
  if (!j[key].is_number()) throw_usage(std::string(key) + ": expected a number");
  return j[key].get<double>();
}

ViewState from_json(const json& j, const ViewState& start) {
  if (!j.is_object()) throw_usage("settings: expected a JSON object");
  ViewState s = start;
  if (j.contains("model")) {
    const std::string m = j["model"].is_string() ? j["model"].get<std::string>() : "";
    if (m != "f_number" && m != "blur_at_infinity") throw_usage("model: must be f_number or blur_at_infinity");
    s.f_number_model = m == "f_number";
  }
  s.f_number = num(j, "f_number", s.f_number);
  s.focal_length_mm = num(j, "focal_length_mm", s.focal_length_mm);
  s.sensor_width_mm = num(j, "sensor_width_mm", s.sensor_width_mm);
  s.blur_at_infinity_px = num(j, "blur_at_infinity_px", s.blur_at_infinity_px);
  s.focus_m = num(j, "focus_m", s.focus_m);
  if (j.contains("focus_at")) {
    const json& f = j["focus_at"];
    if (f.is_null()) {
      s.focus_at.reset();
    } else {
      if (!f.is_array() || f.size() != 2 || !f[0].is_number_integer() || !f[1].is_number_integer())
        throw_usage("focus_at: expected [x, y] pixel coordinates");
      s.focus_at = std::make_pair(f[0].get<int>(), f[1].get<int>());
    }
  }
  s.max_coc_px = num(j, "max_coc_px", s.max_coc_px);
  const double blades = num(j, "blades", s.blades);
  if (blades != std::floor(blades) || !(std::fabs(blades) < 1e6)) throw_usage("blades: expected an integer");
  s.blades = static_cast<int>(blades);
  s.rotation_deg = num(j, "blade_rotation_deg", s.rotation_deg);
  s.curvature = num(j, "blade_curvature", s.curvature);
  s.anamorphic = num(j, "anamorphic", s.anamorphic);
  s.cat_eye = num(j, "cat_eye", s.cat_eye);
  if (j.contains("highlight_boost"))
    s.highlight_boost =
        j["highlight_boost"].is_null() ? std::nullopt : std::optional<double>(num(j, "highlight_boost", 0));
  if (j.contains("method")) {
    if (!j["method"].is_string()) throw_usage("method: expected a name");
    s.method = j["method"].get<std::string>();
  }
  if (j.contains("debug_view")) {
    if (!j["debug_view"].is_string()) throw_usage("debug_view: expected a name");
    s.debug_view = j["debug_view"].get<std::string>();
  }
  if (s.method != start.method) s.sets.clear();
  return s;
}

// The camera, aperture, highlight and method flags of a state (no input or output paths).
std::vector<std::string> state_flags(const ViewState& s) {
  std::vector<std::string> f;
  auto add = [&](const char* flag, const std::string& v) {
    f.push_back(flag);
    f.push_back(v);
  };
  if (s.focus_at)
    add("--focus-at", std::to_string(s.focus_at->first) + "," + std::to_string(s.focus_at->second));
  else
    add("--focus", exact(s.focus_m));
  if (s.f_number_model) {
    add("--f-number", exact(s.f_number));
    add("--focal-length", exact(s.focal_length_mm));
    add("--sensor-width", exact(s.sensor_width_mm));
  } else {
    add("--blur-at-infinity", exact(s.blur_at_infinity_px));
  }
  if (s.max_coc_px > 0) add("--max-coc", exact(s.max_coc_px));
  if (s.reference_width_px > 0) add("--reference-width", exact(s.reference_width_px));
  if (s.blades != 0) add("--blades", std::to_string(s.blades));
  if (s.rotation_deg != 0) add("--blade-rotation", exact(s.rotation_deg));
  if (s.curvature != 0) add("--blade-curvature", exact(s.curvature));
  if (s.anamorphic != 1) add("--anamorphic", exact(s.anamorphic));
  if (s.cat_eye != 0) add("--cat-eye", exact(s.cat_eye));
  if (s.highlight_boost) add("--highlight-boost", exact(*s.highlight_boost));
  add("--method", s.method);
  for (const std::string& kv : s.sets) add("--set", kv);
  return f;
}

// Render settings from flags, through the render command's own flag classes: the same
// parsing, ranges and messages as `dofkit render`.
RenderSettings settings_from_flags(const std::vector<std::string>& flags, const Image& depth, bool display_referred,
                                   int threads) {
  CLI::App app{"view"};
  CameraFlags camera;
  ApertureFlags aperture;
  HighlightFlags highlights;
  std::string method = "lens";
  std::vector<std::string> sets;
  camera.add(&app);
  aperture.add(&app);
  highlights.add(&app);
  app.add_option("--method", method);
  app.add_option("--set", sets);
  std::vector<std::string> argv(flags.rbegin(), flags.rend());
  try {
    app.parse(argv);
  } catch (const CLI::ParseError& e) {
    throw_usage(e.what());
  }
  camera.check();
  aperture.check();
  highlights.check();
  RenderSettings s;
  s.method = method;
  s.params = parse_sets(sets);
  s.camera = camera.build(&depth);
  s.aperture = aperture.build();
  s.highlights = highlights.build(display_referred);
  s.threads = threads;
  return s;
}

// --- images ------------------------------------------------------------------------------

// Box-filtered colour and point-sampled depth at `w` × `h` (the depth of the pixel at each
// cell's centre: averaging depths across an edge would invent surfaces). A layered frame is
// point-sampled whole (colour, depth and every layer at the cell's centre pixel), so that each
// preview fragment keeps its own colour, coverage and depth together.
Frame point_sample(const Frame& in, int w, int h) {
  Frame out;
  const int W = in.width(), H = in.height();
  const auto centre = [](int i, int n, int N) {
    const int a = static_cast<int>(static_cast<long long>(i) * N / n);
    const int b = std::max(a + 1, static_cast<int>(static_cast<long long>(i + 1) * N / n));
    return std::min(N - 1, (a + b) / 2);
  };
  std::vector<int> xs(w), ys(h);
  for (int x = 0; x < w; ++x) xs[x] = centre(x, w, W);
  for (int y = 0; y < h; ++y) ys[y] = centre(y, h, H);
  const auto sample = [&](const Image& img) {
    Image o(w, h, img.channels());
    for (int c = 0; c < img.channels(); ++c)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) o.at(x, y, c) = img.at(xs[x], ys[y], c);
    return o;
  };
  out.color = sample(in.color);
  out.depth = sample(in.depth);
  for (const Image& l : in.layer_color) out.layer_color.push_back(sample(l));
  for (const Image& l : in.layer_depth) out.layer_depth.push_back(sample(l));
  return out;
}

Frame downscale(const Frame& in, int w, int h) {
  if (in.has_layers()) return point_sample(in, w, h);
  Frame out;
  out.color.resize(w, h, 4);
  out.depth.resize(w, h, 1);
  const int W = in.color.width(), H = in.color.height();
  for (int y = 0; y < h; ++y) {
    const int y0 = static_cast<int>(static_cast<long long>(y) * H / h);
    const int y1 = std::max(y0 + 1, static_cast<int>(static_cast<long long>(y + 1) * H / h));
    for (int x = 0; x < w; ++x) {
      const int x0 = static_cast<int>(static_cast<long long>(x) * W / w);
      const int x1 = std::max(x0 + 1, static_cast<int>(static_cast<long long>(x + 1) * W / w));
      for (int c = 0; c < 4; ++c) {
        double sum = 0;
        for (int j = y0; j < y1; ++j)
          for (int i = x0; i < x1; ++i) sum += in.color.at(i, j, c);
        out.color.at(x, y, c) = static_cast<float>(sum / ((x1 - x0) * (y1 - y0)));
      }
      out.depth.at(x, y) = in.depth.at(std::min(W - 1, (x0 + x1) / 2), std::min(H - 1, (y0 + y1) / 2));
    }
  }
  return out;
}

Image box_down(const Image& in, int w, int h) {
  Frame f;
  f.color = in;
  f.depth = Image(in.width(), in.height(), 1, 1.0f);
  return downscale(f, w, h).color;
}

// Premultiplied linear RGBA → 8-bit sRGB RGBA (straight alpha), row-major bytes.
void append_rgba8(const Image& img, std::string& out) {
  const std::size_t n = static_cast<std::size_t>(img.width()) * img.height();
  const std::size_t at = out.size();
  out.resize(at + 4 * n);
  auto* p = reinterpret_cast<std::uint8_t*>(&out[at]);
  const int ch = img.channels();
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x, p += 4) {
      const float a = ch >= 4 ? img.at(x, y, 3) : 1.0f;
      for (int c = 0; c < 3; ++c) {
        float v = img.at(x, y, std::min(c, ch - 1));
        if (ch >= 4 && a > 0) v /= a;
        p[c] = io::srgb8_code(v);
      }
      p[3] = static_cast<std::uint8_t>(std::lround(std::clamp(a, 0.0f, 1.0f) * 255));
    }
}

// The focus-zone map: green where |r| <= 0.5 px (sharp), red ramps for the near field, blue for
// the far field, by |r| / 8 px at the preview's size; the image shows through faintly.
void append_coc_map(const Image& coc, std::string& out) {
  const std::size_t at = out.size();
  out.resize(at + 4 * static_cast<std::size_t>(coc.width()) * coc.height());
  auto* p = reinterpret_cast<std::uint8_t*>(&out[at]);
  for (int y = 0; y < coc.height(); ++y)
    for (int x = 0; x < coc.width(); ++x, p += 4) {
      const float r = coc.at(x, y);
      const float t = std::min(1.0f, std::fabs(r) / 8.0f);
      const auto b = static_cast<std::uint8_t>(std::lround(60 + 195 * t));
      if (std::fabs(r) <= 0.5f) {
        p[0] = 40, p[1] = 220, p[2] = 60;
      } else if (r > 0) {
        p[0] = b, p[1] = 40, p[2] = 40;
      } else {
        p[0] = 40, p[1] = 60, p[2] = b;
      }
      p[3] = 255;
    }
}

// Depth as grey: 1/z scaled to the nearest finite depth (white = near, black = infinity).
void append_depth_view(const Image& depth, std::string& out) {
  float zmin = INFINITY;
  for (std::size_t i = 0; i < depth.plane_size(); ++i)
    if (depth.plane(0)[i] > 0) zmin = std::min(zmin, depth.plane(0)[i]);
  const std::size_t at = out.size();
  out.resize(at + 4 * depth.plane_size());
  auto* p = reinterpret_cast<std::uint8_t*>(&out[at]);
  for (std::size_t i = 0; i < depth.plane_size(); ++i, p += 4) {
    const float z = depth.plane(0)[i];
    const float v = std::isfinite(zmin) && z > 0 ? std::clamp(zmin / z, 0.0f, 1.0f) : 0.0f;
    p[0] = p[1] = p[2] = static_cast<std::uint8_t>(std::lround(std::sqrt(v) * 255));
    p[3] = 255;
  }
}

// A debug view shown as an image: planes 1-4, each mapped by its own range to 0..1 where
// it leaves 0..1 (signed values: 0.5 = zero).
Image debug_display(const Image& d) {
  Image out(d.width(), d.height(), 4, 1.0f);
  const int ch = std::min(d.channels(), 3);
  for (int c = 0; c < ch; ++c) {
    float lo = 0, hi = 1;
    for (std::size_t i = 0; i < d.plane_size(); ++i) {
      const float v = d.plane(c)[i];
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    }
    for (std::size_t i = 0; i < d.plane_size(); ++i) {
      const float v = d.plane(c)[i];
      out.plane(c)[i] = std::isfinite(v) ? (v - lo) / (hi - lo) : 0.0f;
    }
  }
  for (int c = ch; c < 3; ++c) std::copy(out.plane(0), out.plane(0) + out.plane_size(), out.plane(c));
  return out;
}

// --- the preview worker ------------------------------------------------------------------

struct PreviewRequest {
  std::uint64_t seq = 0;
  RenderSettings settings;
  std::shared_ptr<const Frame> frame;
  std::shared_ptr<const Image> truth;  // downscaled ground truth (null: none)
  bool coc_map = false;                // append the focus-zone map
};

struct PreviewResult {
  std::uint64_t seq = 0;
  int status = 0;
  std::string body, content_type;
  httplib::Headers headers;
};

class PreviewWorker {
 public:
  PreviewWorker() : thread_([this] { loop(); }) {}
  ~PreviewWorker() {
    {
      const std::lock_guard<std::mutex> lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  std::uint64_t next_seq() { return ++issued_; }
  // Queues `req` (replacing any request not yet started and cancelling the render in flight)
  // and waits for its result; nullopt: a newer request replaced it first.
  std::optional<PreviewResult> run(PreviewRequest req) {
    std::unique_lock<std::mutex> lock(mu_);
    const std::uint64_t seq = req.seq;
    if (seq < newest_) {  // a newer request got here first
      ++skipped_;
      return std::nullopt;
    }
    newest_ = seq;
    newest_atomic_.store(seq);
    if (pending_) ++skipped_;
    pending_ = std::move(req);
    cv_.notify_all();
    cv_.wait_for(lock, std::chrono::seconds(120), [&] { return stop_ || done_.seq == seq || newest_ > seq; });
    if (done_.seq == seq) return done_;
    return std::nullopt;
  }
  json stats() {
    const std::lock_guard<std::mutex> lock(mu_);
    return {{"requests", issued_.load()},
            {"renders_started", started_},
            {"renders_completed", completed_},
            {"renders_cancelled", cancelled_},
            {"requests_skipped", skipped_}};
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(mu_);
    for (;;) {
      cv_.wait(lock, [&] { return stop_ || pending_.has_value(); });
      if (stop_) return;
      PreviewRequest req = std::move(*pending_);
      pending_.reset();
      ++started_;
      lock.unlock();
      PreviewResult res = render(req);
      lock.lock();
      if (res.status == 0) {
        ++cancelled_;
      } else {
        ++completed_;
        done_ = std::move(res);
      }
      cv_.notify_all();
    }
  }

  PreviewResult render(PreviewRequest& req) {
    PreviewResult res;
    res.seq = req.seq;
    const std::uint64_t seq = req.seq;
    req.settings.progress = [this, seq](double) { return newest_atomic_.load() == seq && !stop_flag(); };
    try {
      const auto t0 = std::chrono::steady_clock::now();
      const RenderResult r = dofkit::render(*req.frame, req.settings);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const int w = r.image.width(), h = r.image.height();
      // (X-Render-Ms: the library's render; X-Server-Ms, added below: with the conversion to
      // 8-bit sRGB, the overlays and the PSNR.)
      res.body.reserve(static_cast<std::size_t>(w) * h * 8 + 16);
      append_rgba8(r.image, res.body);
      if (req.coc_map) append_coc_map(r.coc, res.body);
      int dw = 0, dh = 0;
      if (!r.debug.empty()) {
        dw = r.debug.width(), dh = r.debug.height();
        append_rgba8(debug_display(r.debug), res.body);
      }
      res.status = 200;
      res.content_type = "application/octet-stream";
      res.headers = {{"X-Width", std::to_string(w)},
                     {"X-Height", std::to_string(h)},
                     {"X-Coc-Map", req.coc_map ? "1" : "0"},
                     {"X-Debug-Width", std::to_string(dw)},
                     {"X-Debug-Height", std::to_string(dh)},
                     {"X-Seq", std::to_string(seq)},
                     {"X-Render-Ms", exact(std::round(ms * 10) / 10)}};
      if (req.truth)
        res.headers.emplace("X-Psnr-Db", exact(std::round(metrics::psnr(*req.truth, r.image) * 100) / 100));
      const double all = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      res.headers.emplace("X-Server-Ms", exact(std::round(all * 10) / 10));
    } catch (const Cancelled&) {
      res.status = 0;
    } catch (const Error& e) {
      res.status = e.kind() == ErrorKind::internal ? 500 : 400;
      res.content_type = "application/json";
      res.body = json{{"error", e.what()}}.dump();
    } catch (const std::exception& e) {
      res.status = 500;
      res.content_type = "application/json";
      res.body = json{{"error", std::string("internal error: ") + e.what()}}.dump();
    }
    return res;
  }
  bool stop_flag() {
    const std::lock_guard<std::mutex> lock(mu_);
    return stop_;
  }

  std::mutex mu_;
  std::condition_variable cv_;
  std::optional<PreviewRequest> pending_;
  PreviewResult done_;
  std::uint64_t newest_ = 0;
  std::atomic<std::uint64_t> newest_atomic_{0}, issued_{0};
  long started_ = 0, completed_ = 0, cancelled_ = 0, skipped_ = 0;
  bool stop_ = false;
  std::thread thread_;
};

// --- save --------------------------------------------------------------------------------

// `rel` inside `dir` (canonical): a relative path of plain names, no "..", no empty or "."
// part, no control character; its folder must exist inside `dir` with no symlink leading out,
// and the file, if it exists, must not be a symlink. Returns the absolute target; throws
// Error(usage) with the reason.
std::string confined_path(const fs::path& dir, const std::string& rel) {
  if (rel.empty()) throw_usage("path: empty");
  if (rel.size() > 1024) throw_usage("path: longer than 1024 bytes");
  if (rel.front() == '/')
    throw_usage("path " + rel + ": absolute paths are refused (give a name inside the save folder)");
  for (const char c : rel)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f || c == '\\')
      throw_usage("path: control characters and backslashes are refused");
  std::stringstream ss(rel);
  std::string part;
  while (std::getline(ss, part, '/'))
    if (part.empty() || part == "." || part == "..")
      throw_usage("path " + rel + ": '..', '.' and empty names are refused (the file must be inside the save folder)");
  if (rel.back() == '/') throw_usage("path " + rel + ": names a folder");
  const fs::path target = dir / rel;
  std::error_code ec;
  const fs::path parent = fs::canonical(target.parent_path(), ec);
  if (ec) throw_usage("path " + rel + ": its folder does not exist in the save folder");
  const std::string d = dir.string(), p = parent.string();
  if (p != d && p.compare(0, d.size() + 1, d + "/") != 0)
    throw_usage("path " + rel + ": leads out of the save folder (through a symlink)");
  struct stat st {};
  if (::lstat(target.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
    throw_usage("path " + rel + ": exists and is not a regular file (a symlink or a folder)");
  return (parent / target.filename()).string();
}

struct SaveJob {
  std::mutex mu;
  std::string state = "idle", error, path, command;
  double psnr_db = NAN;
  std::atomic<double> fraction{0};
  std::atomic<bool> cancel{false};
  std::thread thread;
  ~SaveJob() {
    cancel = true;
    if (thread.joinable()) thread.join();
  }
};

// --- the server --------------------------------------------------------------------------

std::atomic<httplib::Server*> g_server{nullptr};
extern "C" void on_stop_signal(int) {
  if (httplib::Server* s = g_server.load()) s->stop();  // closes the listening socket
}

std::string random_token() {
  // std::random_device reads the kernel's generator (/dev/urandom or getrandom) on Linux.
  std::random_device rd;
  static const char hex[] = "0123456789abcdef";
  std::string t;
  for (int i = 0; i < 32; ++i) t += hex[rd() & 15];
  return t;
}

struct Inputs {
  Frame frame;
  Image truth;  // empty: none
  bool display_referred = false;
  std::string color_path, depth_path, layers_path, scene_name;
};

class ViewServer {
 public:
  ViewServer(ViewArgs& a, Inputs in, ViewState start, std::vector<std::string> input_flags, fs::path save_dir)
      : a_(a),
        in_(std::move(in)),
        start_(std::move(start)),
        input_flags_(std::move(input_flags)),
        save_dir_(std::move(save_dir)),
        token_(random_token()) {}

  // Throws the error `dofkit render` would give for these settings (Error(usage)).
  void check_state(const ViewState& s) const { (void)settings_for(s, nullptr); }

  void run() {
    httplib::Server svr;
    svr.set_payload_max_length(kMaxBody);
    svr.set_read_timeout(10, 0);
    svr.set_keep_alive_timeout(1);  // so that Ctrl-C does not wait on idle browser connections
    svr.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
      return guard(req, res) ? httplib::Server::HandlerResponse::Unhandled : httplib::Server::HandlerResponse::Handled;
    });
    svr.Get("/", [this](const httplib::Request&, httplib::Response& res) {
      res.set_header("Set-Cookie", "dofkit_view=" + token_ + "; Path=/; HttpOnly; SameSite=Strict");
      res.set_header("Cache-Control", "no-store");
      res.set_content(view_page(), "text/html; charset=utf-8");
    });
    svr.Get("/api/info", [this](const httplib::Request&, httplib::Response& res) { info(res); });
    svr.Post("/api/preview", [this](const httplib::Request& req, httplib::Response& res) { preview(req, res); });
    svr.Get("/api/image", [this](const httplib::Request& req, httplib::Response& res) { image(req, res); });
    svr.Get("/api/depth", [this](const httplib::Request& req, httplib::Response& res) { depth(req, res); });
    svr.Post("/api/command", [this](const httplib::Request& req, httplib::Response& res) {
      handle(res, [&] {
        const ViewState s = from_json(parse_body(req), start_);
        check_state(s);
        res.set_content(json{{"command", command_text(s, "OUTPUT.exr")}}.dump(), "application/json");
      });
    });
    svr.Post("/api/save", [this](const httplib::Request& req, httplib::Response& res) { save(req, res); });
    svr.Get("/api/save", [this](const httplib::Request&, httplib::Response& res) { save_status(res); });
    svr.Post("/api/save/cancel", [this](const httplib::Request&, httplib::Response& res) {
      save_.cancel = true;
      res.set_content("{}", "application/json");
    });
    svr.Get("/api/stats", [this](const httplib::Request&, httplib::Response& res) {
      res.set_content(worker_.stats().dump(), "application/json");
    });

    // The listening socket: SO_REUSEADDR only (cpp-httplib's default adds SO_REUSEPORT, which
    // would let another process of this user bind the same port and take connections), and a
    // backlog of 256 instead of the library's 5, so that a burst of requests (the page while a
    // slider moves, 200 at once in the tests) is queued, not refused: listen() again on a
    // listening socket only updates its backlog.
    int listen_fd = -1;
    svr.set_socket_options([&listen_fd](int fd) {
      const int yes = 1;
      setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
      listen_fd = fd;
    });
    if (a_.port == 0) {
      port_ = svr.bind_to_any_port("127.0.0.1");
    } else {
      port_ = svr.bind_to_port("127.0.0.1", a_.port) ? a_.port : -1;
    }
    if (port_ > 0 && listen_fd >= 0) ::listen(listen_fd, 256);
    if (port_ <= 0)
      throw_bad_input("--port " + std::to_string(a_.port) + ": cannot listen on 127.0.0.1 (in use or not allowed)");
    const std::string url = "http://127.0.0.1:" + std::to_string(port_) + "/?token=" + token_;
    std::cout << url << std::endl;
    std::cerr << "dofkit view: serving "
              << (!in_.scene_name.empty()  ? "scene " + in_.scene_name
                  : in_.color_path.empty() ? in_.layers_path
                                           : in_.color_path)
              << " (" << in_.frame.width() << "x" << in_.frame.height() << ") on 127.0.0.1:" << port_
              << "; saves go to " << save_dir_.string() << "; Ctrl-C stops\n";
    if (!a_.no_browser) open_browser(url);
    g_server = &svr;
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    struct sigaction old_int {
    }, old_term{};
    sigaction(SIGINT, &sa, &old_int);
    sigaction(SIGTERM, &sa, &old_term);
    svr.listen_after_bind();
    g_server = nullptr;
    sigaction(SIGINT, &old_int, nullptr);
    sigaction(SIGTERM, &old_term, nullptr);
    save_.cancel = true;
    std::cerr << "dofkit view: stopped\n";
  }

 private:
  // Host, token and body size, before a handler runs or any body byte is read.
  bool guard(const httplib::Request& req, httplib::Response& res) {
    const std::string host = req.get_header_value("Host"), port = std::to_string(port_);
    if (host != "127.0.0.1:" + port && host != "localhost:" + port) {
      fail(res, 403, "Host '" + host + "' refused: open the page as http://127.0.0.1:" + port + "/");
      return false;
    }
    std::string given = req.get_param_value("token");
    if (given.empty()) {
      const std::string cookies = req.get_header_value("Cookie");
      const std::string key = "dofkit_view=";
      for (std::size_t at = cookies.find(key); at != std::string::npos; at = cookies.find(key, at + 1))
        if (at == 0 || cookies[at - 1] == ' ' || cookies[at - 1] == ';') {
          const std::size_t begin = at + key.size(), end = cookies.find(';', begin);
          given = cookies.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
          break;
        }
    }
    if (given.size() != token_.size() || !constant_time_equal(given, token_)) {
      fail(res, 401, "missing or wrong token: open the URL dofkit view printed");
      return false;
    }
    if (req.has_header("Content-Length")) {
      const std::string len = req.get_header_value("Content-Length");
      if (len.size() > 12 || std::strtoull(len.c_str(), nullptr, 10) > kMaxBody) {
        res.set_header("Connection", "close");
        fail(res, 413, "request body larger than " + std::to_string(kMaxBody) + " bytes refused");
        return false;
      }
    }
    return true;
  }
  static bool constant_time_equal(const std::string& a, const std::string& b) {
    unsigned char d = 0;
    for (std::size_t i = 0; i < a.size(); ++i) d |= static_cast<unsigned char>(a[i] ^ b[i]);
    return d == 0;
  }
  static void fail(httplib::Response& res, int status, const std::string& message) {
    res.status = status;
    res.set_content(json{{"error", one_line(message)}}.dump(), "application/json");
  }
  template <class F>
  static void handle(httplib::Response& res, F&& fn) {
    try {
      fn();
    } catch (const Error& e) {
      fail(res, e.kind() == ErrorKind::internal ? 500 : 400, e.what());
    } catch (const json::exception& e) {
      fail(res, 400, std::string("bad JSON: ") + e.what());
    } catch (const std::bad_alloc&) {
      fail(res, 500, "out of memory");
    } catch (const std::exception& e) {
      fail(res, 500, std::string("internal error: ") + e.what());
    }
  }
  static json parse_body(const httplib::Request& req) { return json::parse(req.body); }

  void open_browser(const std::string& url) {
    // xdg-open / open, detached; a failure only means the user opens the URL themselves.
#ifdef __APPLE__
    const char* opener = "open";
#else
    const char* opener = "xdg-open";
#endif
    const pid_t pid = fork();
    if (pid == 0) {
      setsid();
      std::freopen("/dev/null", "w", stdout);
      std::freopen("/dev/null", "w", stderr);
      execlp(opener, opener, url.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
  }

  RenderSettings settings_for(const ViewState& s, const Frame* preview) const {
    RenderSettings rs = settings_from_flags(state_flags(s), in_.frame.depth, in_.display_referred, a_.threads);
    rs.debug_view = s.debug_view;
    if (preview) {
      // Radii in pixels refer to the full image: the preview renders the same picture smaller.
      if (rs.camera.reference_width_px <= 0) rs.camera.reference_width_px = in_.frame.width();
    }
    return rs;
  }

  std::vector<std::string> command_args(const ViewState& s, const std::string& output) const {
    std::vector<std::string> args = input_flags_;
    const std::vector<std::string> f = state_flags(s);
    args.insert(args.end(), f.begin(), f.end());
    if (a_.threads) {
      args.push_back("--threads");
      args.push_back(std::to_string(a_.threads));
    }
    args.push_back("--output");
    args.push_back(output);
    return args;
  }
  std::string command_text(const ViewState& s, const std::string& output) const {
    std::string t = "dofkit render";
    for (const std::string& arg : command_args(s, output)) t += " " + shell_quote(arg);
    return t;
  }

  void info(httplib::Response& res) {
    json methods_j = json::array();
    for (const MethodInfo& m : methods()) {
      json views = json::array();
      for (const DebugViewInfo& v : m.debug_views) views.push_back(v.name);
      methods_j.push_back({{"name", m.name}, {"debug_views", views}, {"aperture", m.aperture}});
    }
    json j{{"width", in_.frame.width()},
           {"height", in_.frame.height()},
           {"ground_truth", !in_.truth.empty()},
           {"scene", in_.scene_name},
           {"color", in_.color_path.empty() ? in_.layers_path : in_.color_path},
           {"save_dir", save_dir_.string()},
           {"state", to_json(start_)},
           {"methods", methods_j}};
    res.set_content(j.dump(), "application/json");
  }

  int preview_height(int w) const {
    return std::max(1, static_cast<int>(std::lround(static_cast<double>(w) * in_.frame.height() / in_.frame.width())));
  }
  int parse_width(const json& j) const {
    const double w = num(j, "width", in_.frame.width());
    if (!(w >= 8 && w <= kMaxPreviewWidth) || w != std::floor(w))
      throw_usage("width: must be an integer from 8 to " + std::to_string(kMaxPreviewWidth));
    return std::min(static_cast<int>(w), in_.frame.width());
  }

  // The inputs at a preview width. The last kScaledKept widths are kept: a change asks for
  // half the displayed width, then the displayed width, so two alternate.
  static constexpr std::size_t kScaledKept = 3;
  struct Scaled {
    int width = 0;
    std::shared_ptr<const Frame> frame;
    std::shared_ptr<const Image> truth;
  };
  Scaled scaled(int w) {
    const std::lock_guard<std::mutex> lock(scaled_mu_);
    for (std::size_t i = 0; i < scaled_.size(); ++i)
      if (scaled_[i].width == w) {
        std::rotate(scaled_.begin(), scaled_.begin() + static_cast<std::ptrdiff_t>(i),
                    scaled_.begin() + static_cast<std::ptrdiff_t>(i) + 1);
        return scaled_.front();
      }
    Scaled s;
    s.width = w;
    const int h = preview_height(w);
    s.frame = w == in_.frame.width() ? std::make_shared<const Frame>(in_.frame)
                                     : std::make_shared<const Frame>(downscale(in_.frame, w, h));
    if (!in_.truth.empty())
      s.truth = std::make_shared<const Image>(w == in_.frame.width() ? in_.truth : box_down(in_.truth, w, h));
    scaled_.insert(scaled_.begin(), std::move(s));
    if (scaled_.size() > kScaledKept) scaled_.pop_back();
    return scaled_.front();
  }

  void preview(const httplib::Request& req, httplib::Response& res) {
    handle(res, [&] {
      const json j = parse_body(req);
      const ViewState s = from_json(j.contains("settings") ? j["settings"] : json::object(), start_);
      const int w = parse_width(j);
      PreviewRequest pr;
      pr.seq = worker_.next_seq();
      pr.settings = settings_for(s, &in_.frame);
      const Scaled sc = scaled(w);
      pr.frame = sc.frame;
      pr.truth = sc.truth;
      pr.coc_map = j.value("coc_map", false);
      std::optional<PreviewResult> r = worker_.run(std::move(pr));
      if (!r) {
        fail(res, 409, "superseded by a newer preview request");
        return;
      }
      res.status = r->status;
      for (const auto& h : r->headers) res.set_header(h.first.c_str(), h.second);
      res.set_content(r->body, r->content_type.c_str());
    });
  }

  void image(const httplib::Request& req, httplib::Response& res) {
    handle(res, [&] {
      const std::string which = req.get_param_value("which");
      json j;
      if (req.has_param("width")) j["width"] = std::strtod(req.get_param_value("width").c_str(), nullptr);
      const int w = parse_width(j);
      const Scaled sc = scaled(w);
      std::string body;
      if (which == "input") {
        append_rgba8(sc.frame->color, body);
      } else if (which == "depth") {
        append_depth_view(sc.frame->depth, body);
      } else if (which == "truth") {
        if (!sc.truth) throw_usage("which=truth: this input has no ground truth (open a scene folder)");
        append_rgba8(*sc.truth, body);
      } else {
        throw_usage("which: must be input, depth or truth");
      }
      res.set_header("X-Width", std::to_string(sc.frame->color.width()));
      res.set_header("X-Height", std::to_string(sc.frame->color.height()));
      res.set_content(body, "application/octet-stream");
    });
  }

  void depth(const httplib::Request& req, httplib::Response& res) {
    handle(res, [&] {
      auto coord = [&](const char* k) {
        const std::string v = req.get_param_value(k);
        char* end = nullptr;
        const long n = std::strtol(v.c_str(), &end, 10);
        if (v.empty() || *end || n < 0 || n >= (k[0] == 'x' ? in_.frame.width() : in_.frame.height()))
          throw_usage(std::string(k) + "=" + v + ": outside the image");
        return static_cast<int>(n);
      };
      const int x = coord("x"), y = coord("y");
      const float z = in_.frame.depth.at(x, y);
      json j{{"x", x}, {"y", y}, {"depth_m", std::isfinite(z) ? json(z) : json("inf")}};
      try {
        j["focus_m"] = focus_from_depth(in_.frame.depth, x, y);
      } catch (const Error& e) {
        j["focus_error"] = e.what();
      }
      res.set_content(j.dump(), "application/json");
    });
  }

  void save(const httplib::Request& req, httplib::Response& res) {
    handle(res, [&] {
      const json j = parse_body(req);
      if (!j.is_object() || !j.contains("path") || !j["path"].is_string())
        throw_usage("save: expected {\"path\": \"name.exr\", \"settings\": {...}}");
      const std::string target = confined_path(save_dir_, j["path"].get<std::string>());
      const ViewState s = from_json(j.contains("settings") ? j["settings"] : json::object(), start_);
      check_state(s);
      std::vector<std::string> args = command_args(s, target);
      const std::lock_guard<std::mutex> lock(save_.mu);
      if (save_.state == "running") {
        fail(res, 409, "a save is running; wait for it or cancel it");
        return;
      }
      if (save_.thread.joinable()) save_.thread.join();
      save_.state = "running";
      save_.error.clear();
      save_.path = target;
      save_.command = command_text(s, target);
      save_.psnr_db = NAN;
      save_.fraction = 0;
      save_.cancel = false;
      save_.thread = std::thread([this, args, target] {
        std::string state = "done", error;
        double psnr_db = NAN;
        try {
          run_render_command(args, [this](double f) {
            save_.fraction = f;
            return !save_.cancel.load();
          });
          if (!in_.truth.empty() && io::is_exr_path(target)) psnr_db = metrics::psnr(in_.truth, io::read_color(target));
        } catch (const Cancelled&) {
          state = "cancelled";
        } catch (const Error& e) {
          state = "error";
          error = e.what();
        } catch (const std::exception& e) {
          state = "error";
          error = std::string("internal error: ") + e.what();
        }
        const std::lock_guard<std::mutex> l(save_.mu);
        save_.state = state;
        save_.error = error;
        save_.psnr_db = psnr_db;
        if (state == "done") save_.fraction = 1;
      });
      res.status = 202;
      res.set_content(json{{"path", target}, {"command", save_.command}}.dump(), "application/json");
    });
  }

  void save_status(httplib::Response& res) {
    const std::lock_guard<std::mutex> lock(save_.mu);
    json j{{"state", save_.state},
           {"fraction", save_.fraction.load()},
           {"path", save_.path},
           {"command", save_.command},
           {"error", save_.error}};
    if (std::isfinite(save_.psnr_db)) j["psnr_db"] = save_.psnr_db;
    res.set_content(j.dump(), "application/json");
  }

  ViewArgs& a_;
  const Inputs in_;
  const ViewState start_;
  const std::vector<std::string> input_flags_;
  const fs::path save_dir_;
  const std::string token_;
  int port_ = 0;
  std::mutex scaled_mu_;
  std::vector<Scaled> scaled_;  // most recently used first
  SaveJob save_;
  PreviewWorker worker_;
};

void run_view(ViewArgs& a) {
  a.budget.apply();
  Inputs in;
  std::vector<std::string> input_flags;
  json scene;
  if (!a.scene_dir.empty()) {
    if (!a.color.empty() || !a.depth.empty()) throw_usage("view: give a scene folder or --color/--depth, not both");
    const fs::path dir(a.scene_dir);
    std::ifstream pj(dir / "params.json");
    if (!pj) throw_bad_input(a.scene_dir + ": not a scene folder (no params.json; make one with dofkit scene)");
    try {
      scene = json::parse(pj);
    } catch (const json::exception& e) {
      throw_bad_input((dir / "params.json").string() + ": not valid JSON (" + e.what() + ")");
    }
    a.color = (dir / "color.exr").string();
    a.depth = (dir / "depth.exr").string();
    in.scene_name = scene.value("scene", dir.filename().string());
  }
  if (!a.layers.empty() && !a.scene_dir.empty())
    throw_usage("view: give a scene folder or --layers, not both (a scene's layers: --layers DIR/layers.exr)");
  if (a.color.empty() && a.layers.empty())
    throw_usage("view: give a scene folder (made by dofkit scene), --color IMG [--depth DEPTH] or --layers FILE");
  if (a.camera.model_given()) a.camera.check();
  a.aperture.check();
  a.highlights.check();
  const io::DepthOptions depth_opt = a.depth_flags.build();
  check_paths({{"--color", a.color},
               {"--depth", a.depth},
               {"--layers", a.layers},
               {"--aperture-image", a.aperture.image_path()}},
              {});
  in.color_path = a.color.empty() ? std::string() : fs::absolute(a.color).string();
  in.depth_path = a.depth.empty() ? std::string() : fs::absolute(a.depth).string();
  in.layers_path = a.layers.empty() ? std::string() : fs::absolute(a.layers).string();
  const std::string& layers_path = in.layers_path;
  if (layers_path.empty()) {
    in.frame = while_doing("reading " + a.color, [&] { return io::load_frame(a.color, a.depth, depth_opt); });
  } else {
    // As `dofkit render --layers` reads them (at most its default 8 layers): the layers give the
    // colour and depth unless --color / --depth override them.
    in.frame = while_doing("reading " + a.layers,
                           [&] { return read_layered_frame(a.color, a.depth, a.layers, depth_opt, {}, 8, nullptr); });
  }
  in.display_referred = !a.color.empty() && io::is_display_referred(a.color);
  if (!scene.is_null()) {
    const fs::path gt = fs::path(a.scene_dir) / "ground_truth.exr";
    if (fs::exists(gt)) {
      in.truth = io::read_color(gt.string());
      if (!in.truth.same_size(in.frame.color)) throw_bad_input(gt.string() + ": not the size of color.exr");
    }
  }
  if (!layers_path.empty()) input_flags = {"--layers", layers_path};
  if (!in.color_path.empty()) input_flags.insert(input_flags.end(), {"--color", in.color_path});
  if (!in.depth_path.empty()) input_flags.insert(input_flags.end(), {"--depth", in.depth_path});
  input_flags.insert(input_flags.end(), a.depth_flag_args.begin(), a.depth_flag_args.end());

  // The start: the flags given, else the scene's camera, else a 50 mm f/2.8 focused on the
  // centre pixel.
  ViewState st;
  st.method = a.method;
  st.debug_view = a.debug_view;
  st.sets = a.sets;
  (void)parse_sets(a.sets);
  CameraModel cam;
  if (a.camera.model_given()) {
    cam = a.camera.build(&in.frame.depth);
  } else if (!scene.is_null()) {
    cam.model = BlurAtInfinity{scene.value("focus_m", 5.0), scene.value("blur_at_infinity_px", 8.0)};
  } else {
    ThinLens t;
    t.focus_distance_m = focus_from_depth(in.frame.depth, in.frame.width() / 2, in.frame.height() / 2);
    cam.model = t;
  }
  if (const auto* t = std::get_if<ThinLens>(&cam.model)) {
    st.f_number_model = true;
    st.f_number = t->f_number;
    st.focal_length_mm = t->focal_length_mm;
    st.sensor_width_mm = t->sensor_width_mm;
    st.focus_m = t->focus_distance_m;
    st.blur_at_infinity_px = thin_lens_k_px(*t, in.frame.width());
  } else if (const auto* b = std::get_if<BlurAtInfinity>(&cam.model)) {
    st.f_number_model = false;
    st.blur_at_infinity_px = b->blur_at_infinity_px;
    st.focus_m = b->focus_distance_m;
  } else {
    throw_usage(
        "view: the page drives a thin lens; start it with --f-number or --blur-at-infinity (not --planes, "
        "--starcraft or --near-far)");
  }
  if (a.camera.focus_at()) st.focus_at = a.camera.focus_at();
  st.max_coc_px = std::isfinite(cam.max_coc_px) ? cam.max_coc_px : 0;
  st.reference_width_px = cam.reference_width_px;
  if (!a.aperture.image_path().empty()) throw_usage("--aperture-image: not supported by view yet");
  const ApertureShape shape = a.aperture.build();
  st.blades = shape.blades;
  st.rotation_deg = shape.rotation_deg;
  st.curvature = shape.curvature;
  st.anamorphic = shape.anamorphic;
  st.cat_eye = shape.cat_eye;
  if (!a.highlights.text().empty()) st.highlight_boost = a.highlights.build(in.display_referred).boost;
  if (!a.highlights.text().empty() && a.highlights.text().find("--highlight-boost") == std::string::npos)
    throw_usage("view: of the highlight flags only --highlight-boost is supported yet");

  const fs::path input_dir = fs::absolute(a.color.empty() ? a.layers : a.color).parent_path();
  fs::path save_dir = a.save_dir.empty() ? input_dir : fs::path(a.save_dir);
  std::error_code ec;
  save_dir = fs::canonical(save_dir, ec);
  if (ec || !fs::is_directory(save_dir))
    throw_bad_input("--save-dir " + (a.save_dir.empty() ? input_dir.string() : a.save_dir) +
                    ": not an existing folder");

  ViewServer server(a, std::move(in), st, input_flags, save_dir);
  // Every setting is checked once before the page opens (the same messages as render).
  server.check_state(st);
  server.run();
}

const char* kViewFooter = R"(
Opens a local page (http://127.0.0.1:PORT/?token=..., printed as the first line of stdout) over
one image + depth, a layered or deep EXR (--layers), or a scene folder made by `dofkit scene` (then the ground truth is shown for
A/B with its PSNR). Click the image to focus there (as --focus-at), shift-click to read the depth;
sliders set the lens, aperture and highlight recovery; Save renders at full size into --save-dir
and shows the equivalent `dofkit render` command (its output is the saved file, bit for bit).
The server listens on 127.0.0.1 only and needs the URL's token. Ctrl-C stops it.

Examples:
  dofkit scene portrait --out scenes/portrait --size 640x360 && dofkit view scenes/portrait
  dofkit view --color photo.png --depth depth.exr --f-number 2 --focus-at 320,200 --no-browser
See docs/cli.md#view.)";

}  // namespace

void add_view_command(CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  auto* cmd = app.add_subcommand("view", "open a local web page with click-to-focus, a live preview and Save");
  cmd->footer(kViewFooter);
  const std::string in = "Input", srv = "Server";
  cmd->add_option("scene", a->scene_dir, "a scene folder made by `dofkit scene` (instead of --color/--depth)")
      ->group(in);
  cmd->add_option("--color", a->color, "colour image, as for render")->group(in);
  cmd->add_option("--depth", a->depth, "depth map, as for render (default: the Z channel of --color)")->group(in);
  cmd->add_option("--layers", a->layers,
                  "multi-layer or deep EXR, as for render (the colour and depth unless --color / --depth are given)")
      ->group(in);
  a->budget.add(cmd);
  a->depth_flags.add(cmd);
  a->camera.add(cmd, "Starting camera (the page changes it; --f-number or --blur-at-infinity)");
  a->aperture.add(cmd, false, "Starting aperture");
  a->highlights.add(cmd, "Starting highlight recovery");
  cmd->add_option("--method", a->method, "starting method (default lens; see `dofkit methods`)")->group("Method");
  cmd->add_option("--set", a->sets, "KEY=VALUE method parameter, kept while the page keeps the starting method")
      ->group("Method");
  cmd->add_option("--debug-view", a->debug_view, "starting debug view shown as an overlay")->group("Method");
  add_threads(cmd, a->threads, "worker threads for previews and saves, 0 = all hardware threads (default)")
      ->group("Method");
  cmd->add_option("--save-dir", a->save_dir,
                  "the folder Save writes into (default: the input's folder); the page's paths are relative to it")
      ->group(srv);
  add_number(cmd, "--port", a->port, "TCP port on 127.0.0.1 (default 0: a free one)", "view --port")->group(srv);
  cmd->add_flag("--no-browser", a->no_browser, "do not open the default browser (print the URL only)")->group(srv);
  cmd->callback([a, cmd] {
    // The depth-convention flags as given, for the `dofkit render` command line.
    for (const CLI::Option* o : cmd->get_options()) {
      if (o->get_group() != "Depth conventions" || o->count() == 0 || o->get_lnames().empty()) continue;
      for (const std::string& v : o->results()) {
        a->depth_flag_args.push_back("--" + o->get_lnames().front());
        a->depth_flag_args.push_back(v);
      }
    }
    run_view(*a);
  });
}

}  // namespace dofkit::cli
