// `dofkit bench`: end-to-end timing of every method on a synthetic frame with a realistic
// CoC distribution, against the cost of copying the frame once (the memory floor).
//
// Each (method, size) runs in a child process (this executable re-invoked with the hidden
// `bench --child` flags) so that its peak resident memory is its own, not the largest of
// all methods run before it.
#include <sys/resource.h>
#include <sys/wait.h>
#include <spawn.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "cli_common.hpp"
#include "commands.hpp"
#include "core/parallel.hpp"
#include "core/pass_profile.hpp"
#include "core/simd_target.hpp"
#include "gpu/gpu.hpp"
#include "io/image_io.hpp"
#include "quality_run.hpp"
#include "scene/bench_frame.hpp"
#include "scene/raytracer.hpp"
#include "ssao_common.hpp"
#include "light_common.hpp"
#include "dofkit/light.hpp"
#include "dofkit/ao.hpp"
#include "dofkit/render.hpp"

extern char** environ;

namespace dofkit::cli {

namespace {

struct Size {
  int w = 0, h = 0;
};

RenderSettings bench_settings(const std::string& method_spec, int w, int threads, Backend backend) {
  // Same syntax as `dofkit quality --methods`: name or name:key=value,key=value.
  const std::vector<MethodSpec> specs = parse_method_list(method_spec);
  if (specs.size() != 1 || specs[0].name == "input") throw_usage("--methods " + method_spec + ": expected one method");
  RenderSettings s;
  s.method = specs[0].name;
  s.params = specs[0].params;
  s.aperture = row_aperture(ApertureShape{}, specs[0]);
  s.camera = scene::bench_camera(w);
  s.threads = threads;
  s.backend = backend;
  return s;
}

// The GPU rows (--backend vulkan): GPU time per frame from the backend's timestamp queries —
// the method's passes, without the uploads and the download (reported beside them) — and the
// GPU time of one frame copy on the device (RGBA16F and RGBA32F images, vkCmdCopyImage).
void run_gpu_child(const std::string& method, Size size, int iterations, bool passes) {
  const gpu::DeviceInfo dev = gpu::selected_device();
  nlohmann::json j;
  j["method"] = method;
  j["width"] = size.w;
  j["height"] = size.h;
  j["backend"] = "vulkan";
  j["device"] = dev.name;
  j["device_type"] = dev.type;
  j["driver"] = dev.driver;
  auto put = [&](std::vector<double> v, const char* median, const char* min) {
    std::sort(v.begin(), v.end());
    j[median] = v[v.size() / 2];
    if (min) j[min] = v.front();
  };
  if (method == "copy-rgba16f" || method == "copy-rgba32f") {
    put(gpu::time_frame_copy(size.w, size.h, method == "copy-rgba16f", iterations), "median_ms", "min_ms");
  } else {
    const Frame frame = scene::bench_frame(size.w, size.h);
    Renderer renderer(bench_settings(method, size.w, 0, Backend::vulkan));
    const gpu::MethodRenderer* g = detail::RendererAccess::gpu(renderer);
    std::vector<double> ms, wall, up, down;
    std::vector<std::pair<std::string, std::vector<double>>> pass_ms;
    for (int i = 0; i < iterations + 1; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      renderer.render(frame);
      const auto t1 = std::chrono::steady_clock::now();
      if (i == 0) continue;  // warm-up
      const gpu::FrameTimes& t = g->last_times();
      ms.push_back(t.passes_ms);
      up.push_back(t.upload_ms);
      down.push_back(t.download_ms);
      wall.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      for (const gpu::FrameTimes::Pass& p : t.passes) {
        auto it = std::find_if(pass_ms.begin(), pass_ms.end(), [&](const auto& q) { return q.first == p.name; });
        if (it == pass_ms.end()) it = pass_ms.insert(pass_ms.end(), {p.name, {}});
        it->second.push_back(p.ms);
      }
    }
    put(ms, "median_ms", "min_ms");
    put(up, "upload_ms", nullptr);
    put(down, "download_ms", nullptr);
    // The whole render() call on the host: CoC map and colour check on the CPU, uploads,
    // passes, download, waits.
    put(wall, "call_ms", nullptr);
    if (passes) {
      nlohmann::json list = nlohmann::json::array();
      for (auto& [path, v] : pass_ms) {
        std::sort(v.begin(), v.end());
        list.push_back({{"pass", path}, {"median_ms", v[v.size() / 2]}, {"min_ms", v.front()}});
      }
      j["passes"] = list;
    }
  }
  j["mpix_per_s"] = size.w * double(size.h) / 1e6 / (j["median_ms"].get<double>() / 1000.0);
  std::cout << j.dump() << std::endl;
}

// CPU time of this process so far (user + system, all threads), ms.
double cpu_ms() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return (ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) * 1e3 + (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) / 1e3;
}

double peak_rss_mb() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss / 1024.0;  // KiB on Linux
}

// A deferred-lighting benchmark set-up: the scene `lights`' G-buffer at w×h and the lights of
// `spec` = points32 | small | full | none, optionally ":impl=brute".
struct LightBench {
  GBufferImages g;
  std::vector<Light> lights;
  LightSettings settings;
};
LightBench light_bench_setup(const std::string& spec, int w, int h, int threads) {
  std::string name = spec, impl = "tiled";
  if (const auto colon = spec.find(':'); colon != std::string::npos) {
    name = spec.substr(0, colon);
    const std::string kv = spec.substr(colon + 1);
    if (kv != "impl=brute" && kv != "impl=tiled")
      throw_usage("--methods " + spec + ": the light set-ups take only impl=tiled or impl=brute");
    impl = kv.substr(5);
  }
  if (name != "points32" && name != "small" && name != "full" && name != "none")
    throw_usage("--methods " + spec + ": unknown light set-up (points32, small, full, none)");
  const scene::Scene sc = scene::build_scene("lights");
  scene::SceneOptions so;
  so.width = w;
  so.height = h;
  const scene::LensCamera cam = scene::camera_for(sc, so);
  scene::GBuffer gb = scene::render_gbuffer(sc, cam);
  LightBench b;
  b.g.depth = std::move(gb.z);
  b.g.normals = std::move(gb.normal);
  b.g.albedo = std::move(gb.albedo);
  b.g.specular = std::move(gb.specular);
  b.g.gloss = std::move(gb.gloss);
  b.g.emissive = std::move(gb.emissive);
  b.g.has_specular = b.g.has_gloss = b.g.has_emissive = true;
  b.settings.hfov_deg = cam.hfov_deg;
  b.settings.threads = threads;
  b.settings.impl = impl;
  if (name == "points32") {
    // 32 lights of radius 1 m, 0.2 m above the visible surface at an 8×4 grid of pixels.
    const double f = cam.f_px();
    for (int k = 0; k < 32; ++k) {
      const int x = static_cast<int>((k % 8 + 0.5) * w / 8), y = static_cast<int>((k / 8 + 0.5) * h / 4);
      const double z = b.g.depth.at(x, y);
      if (!std::isfinite(z)) continue;
      Light l;
      l.name = "p" + std::to_string(k);
      l.radius_m = 1.0;
      l.intensity = 0.5;
      l.color = {0.5 + 0.5 * (k % 3 == 0), 0.5 + 0.5 * (k % 3 == 1), 0.5 + 0.5 * (k % 3 == 2)};
      l.position_m = {(x + 0.5 - 0.5 * w) / f * z, -(y + 0.5 - 0.5 * h) / f * z, -z};
      for (int c = 0; c < 3; ++c) l.position_m[c] += 0.2 * b.g.normals.at(x, y, c);
      b.lights.push_back(l);
    }
  } else if (name == "small") {
    b.lights.push_back(sc.lights[3]);  // "small": radius 0.24 m beside the small ball
  } else if (name == "full") {
    Light l;
    l.name = "full";
    l.position_m = {0, 0, 0.1};
    l.radius_m = 1000;
    b.lights.push_back(l);
  }
  return b;
}

// Runs one measurement in this process and prints one JSON object.
void run_child(const std::string& method, Size size, int threads, int iterations, const std::string& simd, bool passes,
               const std::string& effect) {
  const bool ao = effect == "ao";
  nlohmann::json extra = nlohmann::json::object();
  if (!simd.empty() && !core::pin_simd_target(simd)) throw_usage("--simd " + simd + ": not a target this machine runs");
  const Frame frame = scene::bench_frame(size.w, size.h);
  std::vector<double> ms, cpu;
  // Per pass path (core/pass_profile.hpp, in first-seen order): its ms in each timed run.
  std::vector<std::pair<std::string, std::vector<double>>> pass_ms;
  core::set_pass_profiling(passes);
  // One untimed warm-up, then `iterations` timed runs of `body` (wall and CPU ms each).
  auto time_runs = [&](const auto& body) {
    using clock = std::chrono::steady_clock;
    for (int i = 0; i < iterations + 1; ++i) {
      const double c0 = cpu_ms();
      const auto t0 = clock::now();
      body();
      const auto t1 = clock::now();
      const double c1 = cpu_ms();
      const std::vector<core::PassTime> took = core::take_pass_profile();
      if (i > 0) {
        ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        cpu.push_back(c1 - c0);
        for (const core::PassTime& t : took) {
          auto it = std::find_if(pass_ms.begin(), pass_ms.end(), [&](const auto& p) { return p.first == t.path; });
          if (it == pass_ms.end()) it = pass_ms.insert(pass_ms.end(), {t.path, {}});
          it->second.push_back(t.ms);
        }
      }
    }
  };
  if (method == "copy") {
    // The memory floor: read the RGBA float frame once and write it once.
    Image out(size.w, size.h, 4);
    time_runs(
        [&] { std::memcpy(out.data().data(), frame.color.data().data(), frame.color.data().size() * sizeof(float)); });
  } else if (ao) {
    // AO: the built-in scene ao_corner's depth and normals at this size (not timed), its own
    // radius; one AoRenderer, as a game loop would use it.
    const scene::Scene sc = scene::build_scene("ao_corner");
    scene::SceneOptions so;
    so.width = size.w;
    so.height = size.h;
    const scene::LensCamera cam = scene::camera_for(sc, so);
    const scene::GBuffer g = scene::render_gbuffer(sc, cam);
    const std::vector<AoSpec> spec = parse_ao_method_list(method);
    if (spec.size() != 1) throw_usage("--methods " + method + ": expected one AO method");
    AoSettings s;
    s.method = spec[0].name;
    s.params = spec[0].params;
    s.hfov_deg = cam.hfov_deg;
    s.radius_m = sc.ao_radius_m;
    s.threads = threads;
    AoRenderer renderer(s);
    time_runs([&] { renderer.render(g.z, &g.normal); });
  } else if (effect == "light") {
    // Deferred lighting of the built-in scene `lights`' G-buffer at this size (not timed).
    const LightBench lb = light_bench_setup(method, size.w, size.h, threads);
    LightResult last;
    time_runs([&] { last = deferred_lighting(lb.g.ref(), lb.lights, lb.settings); });
    long long shaded = 0;
    for (long long p : last.stats.pixels_shaded) shaded += p;
    extra["lights"] = lb.lights.size();
    extra["coverage"] = lb.lights.empty() ? 0.0 : static_cast<double>(shaded) / lb.lights.size() / size.w / size.h;
  } else {
    // A Renderer, as a game loop would use it: buffers are kept between frames.
    Renderer renderer(bench_settings(method, size.w, threads, Backend::cpu));
    time_runs([&] { renderer.render(frame); });
  }
  std::sort(ms.begin(), ms.end());
  std::sort(cpu.begin(), cpu.end());
  nlohmann::json j;
  j["method"] = method;
  j["width"] = size.w;
  j["height"] = size.h;
  j["threads"] = threads;
  j["median_ms"] = ms[ms.size() / 2];
  j["min_ms"] = ms.front();
  // CPU time per frame, all threads together (getrusage resolution: ~1 ms, so only
  // meaningful for frames of several ms). Less sensitive to other load than the wall time:
  // wall ≈ cpu / threads when the threads scale and the cores are free.
  j["cpu_ms"] = cpu[cpu.size() / 2];
  j["mpix_per_s"] = size.w * double(size.h) / 1e6 / (ms[ms.size() / 2] / 1000.0);
  j["peak_rss_mb"] = peak_rss_mb();
  j["simd"] = core::simd_target();
  j["backend"] = "cpu";
  for (const auto& [k, v] : extra.items()) j[k] = v;
  if (passes) {
    // A pass that ran in only some frames counts 0 ms in the others.
    nlohmann::json list = nlohmann::json::array();
    for (auto& [path, v] : pass_ms) {
      v.resize(ms.size(), 0.0);
      std::sort(v.begin(), v.end());
      list.push_back({{"pass", path}, {"median_ms", v[v.size() / 2]}, {"min_ms", v.front()}});
    }
    j["passes"] = list;
  }
  std::cout << j.dump() << std::endl;
}

nlohmann::json spawn_child(const std::string& method, Size size, int threads, int iterations, const std::string& simd,
                           bool passes, const std::string& backend = "cpu", const std::string& effect = "dof") {
  const std::string self = "/proc/self/exe";
  std::vector<std::string> args = {"dofkit",       "bench",
                                   "--child",      method,
                                   "--size",       std::to_string(size.w) + "x" + std::to_string(size.h),
                                   "--threads",    std::to_string(threads),
                                   "--iterations", std::to_string(iterations)};
  if (!simd.empty()) args.insert(args.end(), {"--simd", simd});
  if (passes) args.push_back("--passes");
  if (backend != "cpu") args.insert(args.end(), {"--backend", backend});
  if (effect != "dof") args.insert(args.end(), {"--effect", effect});
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  int fds[2], errs[2];
  if (pipe(fds) != 0) throw_internal("bench: pipe failed");
  if (pipe(errs) != 0) {
    close(fds[0]);
    close(fds[1]);
    throw_internal("bench: pipe failed");
  }
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
  posix_spawn_file_actions_adddup2(&fa, errs[1], 2);  // the child's error line, for ours
  posix_spawn_file_actions_addclose(&fa, fds[0]);
  posix_spawn_file_actions_addclose(&fa, errs[0]);
  pid_t pid;
  char exe[4096];
  const ssize_t n = readlink(self.c_str(), exe, sizeof(exe) - 1);
  if (n <= 0) throw_internal("bench: cannot find own executable");
  exe[n] = 0;
  if (posix_spawn(&pid, exe, &fa, nullptr, argv.data(), environ) != 0) throw_internal("bench: spawn failed");
  posix_spawn_file_actions_destroy(&fa);
  close(fds[1]);
  close(errs[1]);
  std::string out, err;
  char buf[4096];
  ssize_t k;
  while ((k = read(fds[0], buf, sizeof buf)) > 0) out.append(buf, k);
  close(fds[0]);
  while ((k = read(errs[0], buf, sizeof buf)) > 0) err.append(buf, k);
  close(errs[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    // The child's own one-line error, with its kind (a bad parameter is the user's, exit 2).
    std::string line = err.substr(0, err.find('\n'));
    for (const char* prefix : {"dofkit: error: ", "dofkit: internal error: ", "dofkit: "})
      if (line.rfind(prefix, 0) == 0) {
        line = line.substr(std::strlen(prefix));
        break;
      }
    const std::string where = "bench: method " + method + " at " + std::to_string(size.w) + "x" +
                              std::to_string(size.h) + ": " + (line.empty() ? "failed" : line);
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 1;
    if (code == 2) throw_usage(where);
    if (code == 3) throw_bad_input(where);
    throw_internal(where + (WIFSIGNALED(status) ? " (killed by signal " + std::to_string(WTERMSIG(status)) + ")" : ""));
  }
  return nlohmann::json::parse(out);
}

void run_gpu_bench(const std::vector<std::string>& names, const std::vector<Size>& sizes, int iterations, bool passes,
                   bool json) {
  const gpu::DeviceInfo dev = gpu::selected_device();  // a one-line error when there is none
  if (!json) std::cerr << fmt::format("device: {} ({}, {})\n", dev.name, dev.type, dev.driver);
  nlohmann::json rows = nlohmann::json::array();
  for (const Size& size : sizes) {
    nlohmann::json copy16 = spawn_child("copy-rgba16f", size, 0, std::max(iterations, 15), "", false, "vulkan");
    nlohmann::json copy32 = spawn_child("copy-rgba32f", size, 0, std::max(iterations, 15), "", false, "vulkan");
    const double base = copy16["median_ms"].get<double>();
    copy16["ratio_to_copy"] = 1.0;
    copy32["ratio_to_copy"] = copy32["median_ms"].get<double>() / base;
    rows.push_back(copy16);
    rows.push_back(copy32);
    for (const auto& m : names) {
      nlohmann::json r = spawn_child(m, size, 0, iterations, "", passes, "vulkan");
      r["ratio_to_copy"] = r["median_ms"].get<double>() / base;  // × the RGBA16F copy
      if (!json) std::cerr << fmt::format("{}x{}: {} {:.3f} GPU ms\n", size.w, size.h, m, r["median_ms"].get<double>());
      rows.push_back(r);
    }
  }
  if (json) {
    std::cout << rows.dump(2) << "\n";
    return;
  }
  std::cout << "| method | size | device | GPU median ms | GPU min ms | × RGBA16F copy | upload ms | download ms | "
               "call ms |\n|---|---|---|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& r : rows) {
    auto opt = [&](const char* k) {
      return r.contains(k) ? fmt::format("{:.3f}", r[k].get<double>()) : std::string("—");
    };
    std::cout << fmt::format("| {} | {}x{} | {} | {:.4f} | {:.4f} | {:.2f} | {} | {} | {} |\n",
                             r["method"].get<std::string>(), r["width"].get<int>(), r["height"].get<int>(),
                             r["device"].get<std::string>(), r["median_ms"].get<double>(), r["min_ms"].get<double>(),
                             r["ratio_to_copy"].get<double>(), opt("upload_ms"), opt("download_ms"), opt("call_ms"));
  }
  if (!passes) return;
  for (const auto& r : rows) {
    if (!r.contains("passes")) continue;
    std::cout << fmt::format(
        "\n{} {}x{} on {}: {:.4f} GPU ms per frame\n\n| pass | median ms | min ms |\n|---|---:|---:|\n",
        r["method"].get<std::string>(), r["width"].get<int>(), r["height"].get<int>(), r["device"].get<std::string>(),
        r["median_ms"].get<double>());
    for (const auto& p : r["passes"])
      std::cout << fmt::format("| {} | {:.4f} | {:.4f} |\n", p["pass"].get<std::string>(), p["median_ms"].get<double>(),
                               p["min_ms"].get<double>());
  }
}

}  // namespace

void add_bench_command(CLI::App& app) {
  struct Opts {
    std::vector<std::string> sizes;
    std::string methods;
    int threads = 0;
    int iterations = 7;
    bool json = false;
    std::string child;
    std::string write_frame;
    std::string simd;
    bool passes = false;
    std::string effect = "dof";
    std::string backend = "cpu";
  };
  auto opts = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("bench",
                                 "time every method on a synthetic frame (focus 4 m, K = 1.5 % of the width, "
                                 "CoC clamp 3 % of the width) against one frame copy\n"
                                 "example: dofkit bench --size 1920x1080 --methods mcguire,sterna --threads 2");
  cmd->add_option("--size", opts->sizes, "frame size WxH (repeatable; default 1920x1080 and 3840x2160)");
  cmd->add_option("--methods", opts->methods,
                  "comma-separated methods, optionally with parameters as name:key=value,key=value (default: all)");
  add_threads(cmd, opts->threads, "worker threads (default: all hardware threads)");
  add_number(cmd, "--iterations", opts->iterations, "timed runs per method after one warm-up (default 7)",
             "bench --iterations");
  cmd->add_flag("--json", opts->json, "print a JSON list instead of a table");
  cmd->add_option("--write-frame", opts->write_frame,
                  "write the synthetic frame of the first --size (default 1920x1080) as DIR/color.exr and "
                  "DIR/depth.exr (float) and print the render flags of its camera, instead of timing");
  cmd->add_option(
      "--simd", opts->simd,
      "run the kernels of this SIMD target instead of the widest one the machine has, to see "
      "what a machine without the wider ones gets (e.g. AVX2, SSE4; a name it does not run prints the list)");
  cmd->add_flag("--passes", opts->passes,
                "also time each pass of each method (median ms per frame; nested passes are included in their "
                "parents) and print the breakdown after the table (JSON: a 'passes' list per row)");
  cmd->add_option("--effect", opts->effect,
                  "dof (depth of field, default); ao: time the AO methods (--methods sc2,gtao by default, with "
                  "parameters as name:key=value) on the built-in scene ao_corner's depth and normals at --size; "
                  "light: time deferred lighting of the scene lights' G-buffer (--methods points32,small,full,none by "
                  "default; :impl=brute for the oracle)")
      ->check(CLI::IsMember({"dof", "ao", "light"}));
  cmd->add_option("--backend", opts->backend,
                  "cpu (default) or vulkan: time the methods' compute shaders on the GPU by timestamp queries "
                  "(median and min GPU ms per frame of the passes; rows name the device) against the GPU time "
                  "of one RGBA16F and one RGBA32F frame copy on the device, measured in the same run");
  cmd->add_option("--child", opts->child, "internal: run one measurement")->group("");
  cmd->callback([opts] {
    std::vector<Size> sizes;
    for (const auto& s : opts->sizes) {
      Size z;
      parse_size(s, "--size", z.w, z.h);
      sizes.push_back(z);
    }
    if (sizes.empty()) sizes = {{1920, 1080}, {3840, 2160}};
    const int threads = opts->threads > 0 ? opts->threads : core::hardware_threads();
    const std::vector<std::string> targets = core::simd_targets();
    std::string target_list;
    for (const std::string& t : targets) target_list += (target_list.empty() ? "" : ", ") + t;
    if (!opts->simd.empty() && std::find(targets.begin(), targets.end(), opts->simd) == targets.end())
      throw_usage("--simd " + opts->simd + ": not a SIMD target this machine runs (it runs " + target_list + ")");
    const Backend backend = parse_backend(opts->backend);
    if (!opts->child.empty() && backend == Backend::vulkan) {
      run_gpu_child(opts->child, sizes.front(), opts->iterations, opts->passes);
      return;
    }
    if (!opts->child.empty()) {
      run_child(opts->child, sizes.front(), threads, opts->iterations, opts->simd, opts->passes, opts->effect);
      return;
    }
    if (!opts->write_frame.empty()) {
      const Size z = opts->sizes.empty() ? Size{1920, 1080} : sizes.front();
      const Frame frame = scene::bench_frame(z.w, z.h);
      std::error_code ec;
      std::filesystem::create_directories(opts->write_frame, ec);
      if (ec) throw_bad_input(opts->write_frame + ": cannot create the folder: " + ec.message());
      const std::string dir = opts->write_frame + "/";
      io::write_image(dir + "color.exr", frame.color);
      io::WriteOptions depth;
      depth.channel_name = "Z";
      io::write_image(dir + "depth.exr", frame.depth, depth);
      const CameraModel cam = scene::bench_camera(z.w);
      const auto& lens = std::get<BlurAtInfinity>(cam.model);
      std::cout << fmt::format("--focus {:g} --blur-at-infinity {:g} --max-coc {:g}\n", lens.focus_distance_m,
                               lens.blur_at_infinity_px, cam.max_coc_px);
      return;
    }
    std::vector<std::string> names;
    const bool ao = opts->effect == "ao", light = opts->effect == "light";
    if (light) {
      std::stringstream in(opts->methods.empty() ? "points32,small,full,none" : opts->methods);
      std::string m;
      while (std::getline(in, m, ',')) {
        (void)light_bench_setup(m, 16, 16, 1);  // checks the name (exit 2)
        names.push_back(m);
      }
    } else if (ao) {
      for (const AoSpec& spec : parse_ao_method_list(opts->methods.empty() ? "sc2,gtao" : opts->methods))
        names.push_back(spec.label);
    } else if (opts->methods.empty()) {
      for (const auto& m : methods())
        if (m.name != "scatter") names.push_back(m.name);
    } else {
      for (const MethodSpec& spec : parse_method_list(opts->methods)) {
        if (spec.name == "input") throw_usage("--methods: 'input' is not a method to time");
        names.push_back(spec.label);
      }
    }
    // Every method and its parameters are checked here, on a tiny frame, before the first
    // child is spawned: a bad value is the user's error (exit 2), said once.
    for (const std::string& m : names) {
      if (ao || light) break;  // the AO specs were checked by parse_ao_method_list, the light set-ups above
      const RenderSettings probe_settings = bench_settings(m, 16, 1, Backend::cpu);
      Frame probe;
      probe.color = Image(16, 16, 4, 0.5f);
      probe.depth = Image(16, 16, 1, 2.0f);
      (void)render(probe, probe_settings);
    }
    if (backend == Backend::vulkan) {
      if (ao || light) throw_usage("--effect " + opts->effect + ": runs on --backend cpu only");
      if (opts->methods.empty()) names = gpu::supported_methods();
      if (!opts->simd.empty()) throw_usage("--simd: applies to --backend cpu only");
      return run_gpu_bench(names, sizes, opts->iterations, opts->passes, opts->json);
    }
    nlohmann::json rows = nlohmann::json::array();
    if (!opts->json)
      std::cerr << fmt::format("SIMD target: {} (this machine runs {})\n",
                               opts->simd.empty() ? targets.front() : opts->simd, target_list);
    for (const Size& size : sizes) {
      nlohmann::json copy = spawn_child("copy", size, threads, std::max(opts->iterations, 15), opts->simd, false);
      copy["ratio_to_copy"] = 1.0;
      rows.push_back(copy);
      if (!opts->json)
        std::cerr << fmt::format("{}x{}: copy {:.2f} ms\n", size.w, size.h, copy["median_ms"].get<double>());
      for (const auto& m : names) {
        nlohmann::json r =
            spawn_child(m, size, threads, opts->iterations, opts->simd, opts->passes, "cpu", opts->effect);
        r["ratio_to_copy"] = r["median_ms"].get<double>() / copy["median_ms"].get<double>();
        if (!opts->json)
          std::cerr << fmt::format("{}x{}: {} {:.2f} ms\n", size.w, size.h, m, r["median_ms"].get<double>());
        rows.push_back(r);
      }
    }
    if (opts->json) {
      std::cout << rows.dump(2) << "\n";
      return;
    }
    std::cout << fmt::format(
        "| method | size | threads | median ms | min ms | CPU ms | Mpix/s | peak RSS MB | × copy |\n");
    std::cout << "|---|---|---|---:|---:|---:|---:|---:|---:|\n";
    for (const auto& r : rows)
      std::cout << fmt::format("| {} | {}x{} | {} | {:.2f} | {:.2f} | {:.1f} | {:.1f} | {:.0f} | {:.1f} |\n",
                               r["method"].get<std::string>(), r["width"].get<int>(), r["height"].get<int>(),
                               r["threads"].get<int>(), r["median_ms"].get<double>(), r["min_ms"].get<double>(),
                               r["cpu_ms"].get<double>(), r["mpix_per_s"].get<double>(), r["peak_rss_mb"].get<double>(),
                               r["ratio_to_copy"].get<double>());
    if (light) {
      // Per set-up: its lights, the mean fraction of the pixels each light was evaluated at,
      // and the time per light over the set-up without local lights (none) when it ran.
      std::cout << "\n| set-up | size | lights | coverage per light % | median ms | ms per light over none |\n"
                   "|---|---|---:|---:|---:|---:|\n";
      for (const auto& r : rows) {
        if (!r.contains("lights")) continue;
        double none = std::nan("");
        for (const auto& q : rows)
          if (q.contains("lights") && q["method"] == "none" && q["width"] == r["width"] && q["height"] == r["height"])
            none = q["median_ms"].get<double>();
        const int n = r["lights"].get<int>();
        const double per = n > 0 && !std::isnan(none) ? (r["median_ms"].get<double>() - none) / n : std::nan("");
        std::cout << fmt::format("| {} | {}x{} | {} | {:.2f} | {:.2f} | {} |\n", r["method"].get<std::string>(),
                                 r["width"].get<int>(), r["height"].get<int>(), n, 100 * r["coverage"].get<double>(),
                                 r["median_ms"].get<double>(), std::isnan(per) ? "–" : fmt::format("{:.3f}", per));
      }
    }
    if (!opts->passes) return;
    // Per method and size: each pass's median ms per frame and its share of the frame's median.
    for (const auto& r : rows) {
      if (!r.contains("passes")) continue;
      const double frame = r["median_ms"].get<double>();
      std::cout << fmt::format(
          "\n{} {}x{}, {} thread(s): {:.2f} ms per frame\n\n| pass | median ms | min ms | % of frame |\n"
          "|---|---:|---:|---:|\n",
          r["method"].get<std::string>(), r["width"].get<int>(), r["height"].get<int>(), r["threads"].get<int>(),
          frame);
      for (const auto& p : r["passes"])
        std::cout << fmt::format("| {} | {:.2f} | {:.2f} | {:.0f} |\n", p["pass"].get<std::string>(),
                                 p["median_ms"].get<double>(), p["min_ms"].get<double>(),
                                 frame > 0 ? 100.0 * p["median_ms"].get<double>() / frame : 0.0);
    }
  });
}

}  // namespace dofkit::cli
