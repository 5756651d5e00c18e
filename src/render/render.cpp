// render(): validates settings and input, computes the CoC map and runs the chosen method.
#include "dofkit/render.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <optional>
#include <sstream>

#include "core/clones.hpp"
#include "core/coc_range.hpp"
#include "core/parallel.hpp"
#include "core/pass_profile.hpp"
#include "gpu/gpu.hpp"
#include "methods/method.hpp"
#include "render/sanitize.hpp"

namespace dofkit {

namespace detail {

const MethodDef* find_method(const std::string& name) {
  for (const MethodDef* m : all_methods())
    if (m->name == name) return m;
  return nullptr;
}

namespace {
std::string known_names(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}
[[noreturn]] void bad_param(const std::string& method, const std::string& key, const std::string& value,
                            const std::string& why) {
  throw_usage("--set " + key + "=" + value + ": " + why + " (method " + method + ")");
}
}  // namespace

double Params::get_double(const std::string& key, double def, double lo, double hi) const {
  auto it = values_.find(key);
  if (it == values_.end()) return def;
  const std::string& v = it->second;
  double d;
  try {
    std::size_t used = 0;
    d = std::stod(v, &used);
    if (used != v.size()) throw std::invalid_argument(v);
  } catch (const std::exception&) {
    bad_param(method_, key, v, "not a number");
  }
  if (!(d >= lo && d <= hi)) {
    std::ostringstream s;
    s << "must be in [" << lo << ", " << hi << "]";
    bad_param(method_, key, v, s.str());
  }
  return d;
}

int Params::get_int(const std::string& key, int def, int lo, int hi) const {
  const double d = get_double(key, def, lo, hi);
  if (d != std::floor(d)) bad_param(method_, key, values_.at(key), "must be an integer");
  return static_cast<int>(d);
}

bool Params::get_bool(const std::string& key, bool def) const {
  auto it = values_.find(key);
  if (it == values_.end()) return def;
  const std::string& v = it->second;
  if (v == "on" || v == "true" || v == "1" || v == "yes") return true;
  if (v == "off" || v == "false" || v == "0" || v == "no") return false;
  bad_param(method_, key, v, "must be on or off");
}

std::string Params::get_choice(const std::string& key, const std::string& def,
                               const std::vector<std::string>& choices) const {
  auto it = values_.find(key);
  if (it == values_.end()) return def;
  if (std::find(choices.begin(), choices.end(), it->second) == choices.end())
    bad_param(method_, key, it->second, "must be one of " + known_names(choices));
  return it->second;
}

}  // namespace detail

namespace {
// Depth values that are NaN, zero or negative. The count is a branch-free sum so it
// vectorises (the scan runs on every frame); the position of the first one is looked up
// only when there is one, for the message.
DOFKIT_CLONES
std::size_t count_not_positive(const float* z, std::size_t n) {
  std::size_t bad = 0;
  for (std::size_t i = 0; i < n; ++i) bad += !(z[i] > 0);
  return bad;
}
std::size_t first_not_positive(const float* z) {
  std::size_t i = 0;
  while (z[i] > 0) ++i;  // callers know that one exists
  return i;
}
// The message for a depth plane with `bad` NaN, zero or negative values: "<what> has N NaN, zero
// or negative value(s), first at pixel (x, y) = v" (the visible depth and every layer's follow
// the same rule: a missing fragment is z = +inf, never NaN or <= 0).
[[noreturn]] void throw_bad_depth(const Image& depth, std::size_t bad, const std::string& what) {
  const float* z = depth.plane(0);
  const std::size_t first = first_not_positive(z);
  throw_bad_input(what + " has " + std::to_string(bad) + " NaN, zero or negative value(s), first at pixel (" +
                  std::to_string(first % depth.width()) + ", " + std::to_string(first / depth.width()) +
                  ") = " + std::to_string(z[first]));
}
void check_depth_values(const Image& depth, const std::string& what) {
  const std::size_t bad = count_not_positive(depth.plane(0), depth.plane_size());
  if (bad) throw_bad_depth(depth, bad, what);
}

// validate_frame; render() passes visible_depth = false and checks the visible depth's values in
// the same pass that turns them into CoC (fill_coc).
void validate_frame(const Frame& frame, const std::string& src, bool visible_depth) {
  if (frame.color.empty() || frame.color.width() <= 0 || frame.color.height() <= 0)
    throw_bad_input(src + ": colour image is empty");
  if (frame.color.channels() != 4)
    throw_bad_input(src + ": colour must have 4 planes (RGBA), has " + std::to_string(frame.color.channels()));
  if (frame.depth.channels() != 1 || !frame.depth.same_size(frame.color))
    throw_bad_input(src + ": depth is " + std::to_string(frame.depth.width()) + "x" +
                    std::to_string(frame.depth.height()) + " but colour is " + std::to_string(frame.color.width()) +
                    "x" + std::to_string(frame.color.height()));
  if (visible_depth) check_depth_values(frame.depth, src + ": depth");
  if (frame.layer_color.size() != frame.layer_depth.size()) throw_bad_input(src + ": layer colour/depth counts differ");
  for (std::size_t l = 0; l < frame.layer_color.size(); ++l) {
    if (frame.layer_color[l].channels() != 4 || !frame.layer_color[l].same_size(frame.color) ||
        frame.layer_depth[l].channels() != 1 || !frame.layer_depth[l].same_size(frame.color))
      throw_bad_input(src + ": layer " + std::to_string(l) + " does not match the colour image size");
    check_depth_values(frame.layer_depth[l], src + ": layer " + std::to_string(l) + " depth");
  }
}
}  // namespace

void validate_frame(const Frame& frame, const char* what) { validate_frame(frame, what ? what : "frame", true); }

namespace {
// Signed, clamped CoC of every pixel (image pixels). Returns how many depth values
// validate_frame rejects (NaN, zero or negative), counted row by row while the row is in
// cache: render() checks the visible depth in this parallel pass instead of a serial scan
// before it. With `range`, also the largest near and far radius of the map, taken from each
// CoC row while it is in cache (MethodContext::coc_range): methods that size their kernels
// by it then need not read the map again. A maximum does not depend on the order in which
// the blocks are merged, so it is the same for any thread count.
std::size_t fill_coc(const Image& depth, const CocFunction& f, Image& coc, core::CocRange* range = nullptr) {
  coc.resize(depth.width(), depth.height(), 1);
  std::atomic<std::size_t> bad{0};
  std::mutex merge;
  core::CocRange all;
  const int w = depth.width();
  core::parallel_for(
      depth.height(),
      [&](int y0, int y1) {
        std::size_t n = 0;
        core::CocRange part;
        for (int y = y0; y < y1; ++y) {
          f.evaluate(depth.row(0, y), coc.row(0, y), w);
          n += count_not_positive(depth.row(0, y), static_cast<std::size_t>(w));
          if (range) core::coc_row_range(coc.row(0, y), nullptr, w, part.near_max, part.far_max);
        }
        bad.fetch_add(n, std::memory_order_relaxed);
        if (range) {
          const std::lock_guard<std::mutex> lock(merge);
          all.near_max = std::max(all.near_max, part.near_max);
          all.far_max = std::max(all.far_max, part.far_max);
        }
      },
      16);
  if (range) *range = all;
  return bad.load();
}
}  // namespace

Image compute_coc(const Image& depth, const CameraModel& camera, int threads) {
  validate(camera);
  Image coc;
  core::with_threads(threads, [&] { fill_coc(depth, CocFunction(camera, depth.width()), coc); });
  return coc;
}

std::vector<MethodInfo> methods() {
  std::vector<MethodInfo> out;
  for (const auto* m : detail::all_methods()) out.push_back({m->name, m->summary, m->params, m->debug_views});
  std::sort(out.begin(), out.end(), [](const MethodInfo& a, const MethodInfo& b) { return a.name < b.name; });
  return out;
}

namespace {

const detail::MethodDef& checked_method(const RenderSettings& settings) {
  const detail::MethodDef* method = detail::find_method(settings.method);
  if (!method) {
    std::vector<std::string> names;
    for (const auto* m : detail::all_methods()) names.push_back(m->name);
    throw_usage("--method " + settings.method + ": unknown method (known: " + detail::known_names(names) + ")");
  }
  for (const auto& kv : settings.params) {
    // Not a structured binding: clang 14 (the fuzz build) cannot capture those in a lambda.
    const std::string& key = kv.first;
    const std::string& value = kv.second;
    const bool known =
        std::any_of(method->params.begin(), method->params.end(), [&](const ParamInfo& p) { return p.name == key; });
    if (!known) {
      std::vector<std::string> names;
      for (const auto& p : method->params) names.push_back(p.name);
      throw_usage("--set " + key + "=" + value + ": unknown parameter for method " + method->name +
                  (names.empty() ? std::string(" (it has none)") : " (known: " + detail::known_names(names) + ")"));
    }
  }
  if (!settings.debug_view.empty()) {
    const bool known = std::any_of(method->debug_views.begin(), method->debug_views.end(),
                                   [&](const DebugViewInfo& v) { return v.name == settings.debug_view; });
    if (!known) {
      std::vector<std::string> names;
      for (const auto& v : method->debug_views) names.push_back(v.name);
      throw_usage("--debug-view " + settings.debug_view + ": method " + method->name + " has no such view (" +
                  (names.empty() ? std::string("it has none") : "known: " + detail::known_names(names)) + ")");
    }
  }
  if (settings.threads < 0) throw_usage("--threads: must be >= 0");
  validate(settings.camera);
  return *method;
}

}  // namespace

struct Renderer::Impl {
  RenderSettings settings;
  const detail::MethodDef* method = nullptr;
  detail::Workspace workspace;
  RenderResult result;
  Frame sanitized;                           // colour-sanitised copy of the input, used only when the input needs it
  std::unique_ptr<gpu::MethodRenderer> gpu;  // backend = vulkan: the method's shaders
};

Renderer::Renderer(RenderSettings settings) : impl_(std::make_unique<Impl>()) {
  impl_->method = &checked_method(settings);
  if (settings.backend == Backend::vulkan) impl_->gpu = gpu::make_renderer(settings);
  impl_->settings = std::move(settings);
}

const gpu::MethodRenderer* detail::RendererAccess::gpu(const Renderer& r) { return r.impl_->gpu.get(); }
Renderer::~Renderer() = default;
Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&&) noexcept = default;
const RenderSettings& Renderer::settings() const { return impl_->settings; }
void Renderer::set_camera(const CameraModel& camera) {
  validate(camera);
  impl_->settings.camera = camera;
}

const RenderResult& Renderer::render(const Frame& frame_in) {
  const RenderSettings& settings = impl_->settings;
  const detail::MethodDef& method = *impl_->method;
  {
    core::PassScope pass("frame check");
    validate_frame(frame_in, "frame", false);  // the depth values are checked by fill_coc
  }
  RenderResult& result = impl_->result;
  const detail::Params params(method.name, settings.params);
  std::optional<detail::DebugSink> sink;
  const int threads = settings.threads > 0 ? settings.threads : core::hardware_threads();
  core::with_threads(settings.threads, [&] {
    // Non-finite / out-of-range colour never reaches a method's result (rules in
    // render/sanitize.hpp). A method that reads every colour sample in one of its passes
    // anyway checks them there (checks_colour); otherwise, or when it found a bad sample,
    // the colour is checked here and sanitised into a copy where needed.
    std::atomic<bool> dirty{false};
    // The GPU passes get sanitised colour (the check is not made in their shaders).
    const bool deferred = method.checks_colour && frame_in.layer_color.empty() && !impl_->gpu;
    const Frame& frame = [&]() -> const Frame& {
      if (deferred) return frame_in;
      core::PassScope pass("colour check");
      return detail::sanitized_frame(frame_in, impl_->sanitized);
    }();
    const CocFunction coc_of(settings.camera, frame.width());
    core::CocRange range;
    {
      core::PassScope pass("coc map");
      if (const std::size_t bad = fill_coc(frame.depth, coc_of, result.coc, &range))
        throw_bad_depth(frame.depth, bad, "frame: depth");
    }
    result.image.resize(frame.width(), frame.height(), 4);
    sink.emplace(settings.debug_view);
    core::PassScope pass(method.name.c_str());
    if (impl_->gpu) {
      impl_->gpu->render(
          {frame, result.coc, settings.camera, coc_of, params, *sink, threads, impl_->workspace, nullptr, &range},
          result.image);
      return;
    }
    method.render({frame, result.coc, settings.camera, coc_of, params, *sink, threads, impl_->workspace,
                   deferred ? &dirty : nullptr, &range},
                  result.image);
    if (deferred && dirty.load()) {
      // Rare (hostile input): everything from the first try is discarded. The depth, and so
      // the CoC, are the caller's in both tries.
      core::PassScope again("colour check + render again");
      const Frame& clean = detail::sanitized_frame(frame_in, impl_->sanitized);
      sink.emplace(settings.debug_view);
      method.render(
          {clean, result.coc, settings.camera, coc_of, params, *sink, threads, impl_->workspace, nullptr, &range},
          result.image);
    }
  });
  result.debug = Image();
  if (!settings.debug_view.empty()) {
    if (!sink->found()) throw_internal("method " + method.name + " did not produce debug view " + settings.debug_view);
    result.debug = std::move(sink->result());
  }
  return result;
}

RenderResult render(const Frame& frame, const RenderSettings& settings) {
  Renderer renderer(settings);
  // The renderer is discarded: move its result out instead of copying it.
  return std::move(const_cast<RenderResult&>(renderer.render(frame)));
}

double focus_from_depth(const Image& depth, int x, int y, int radius) {
  if (x < 0 || y < 0 || x >= depth.width() || y >= depth.height())
    throw_usage("--focus-at " + std::to_string(x) + "," + std::to_string(y) + ": outside the " +
                std::to_string(depth.width()) + "x" + std::to_string(depth.height()) + " image");
  std::vector<float> v;
  for (int j = std::max(0, y - radius); j <= std::min(depth.height() - 1, y + radius); ++j)
    for (int i = std::max(0, x - radius); i <= std::min(depth.width() - 1, x + radius); ++i) {
      const float z = depth.at(i, j);
      if (std::isfinite(z) && z > 0) v.push_back(z);
    }
  if (v.empty())
    throw_usage("--focus-at " + std::to_string(x) + "," + std::to_string(y) + ": no finite depth around that pixel");
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace dofkit
