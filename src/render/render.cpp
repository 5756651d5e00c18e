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
#include "render/highlights.hpp"
#include "render/sanitize.hpp"
#include "dofkit/ranges.hpp"

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
}  // namespace

void Progress::pass(double lo, double hi, long units) {
  if (!fn_) return;
  const std::lock_guard<std::mutex> lock(mu_);
  lo_ = lo;
  hi_ = hi;
  units_ = units > 0 ? units : 1;
  done_ = 0;
}

void Progress::advance(long units) {
  if (!fn_) return;
  const std::lock_guard<std::mutex> lock(mu_);
  done_ = std::min(units_, done_ + units);
  report(lo_ + (hi_ - lo_) * static_cast<double>(done_) / static_cast<double>(units_));
}

void Progress::finish() {
  if (!fn_) return;
  const std::lock_guard<std::mutex> lock(mu_);
  report(1.0);
}

void Progress::report(double f) {
  f = std::clamp(f, 0.0, 1.0);
  if (f <= last_ || cancelled_.load(std::memory_order_relaxed)) return;
  last_ = f;
  bool go = false;
  try {
    go = (*fn_)(f);
  } catch (...) {
    go = false;  // a callback that throws cancels (it must not throw across the worker threads)
  }
  if (!go) cancelled_.store(true, std::memory_order_relaxed);
}

std::vector<DebugViewInfo> common_debug_views(const MethodDef& m) {
  std::vector<DebugViewInfo> v{{"highlights",
                                "highlight recovery's boost mask m^2 * w (1 plane; the gain is 1 + boost * mask; 0 "
                                "where nothing was boosted or recovery is off)"}};
  if (!m.aperture.empty())
    v.push_back({"aperture",
                 "the aperture kernels the method used, normalised to a peak of 1: far field (left) and near field "
                 "(right) at the frame's largest far / near radius (at most 64 px), each a 3x3 grid of source "
                 "positions across the frame (cat's eye), RGB"});
  return v;
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
  for (const auto* m : detail::all_methods()) {
    MethodInfo info{m->name, m->summary, m->params, m->debug_views, m->aperture};
    for (const DebugViewInfo& v : detail::common_debug_views(*m)) info.debug_views.push_back(v);
    out.push_back(std::move(info));
  }
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
    const auto it =
        std::find_if(method->params.begin(), method->params.end(), [&](const ParamInfo& p) { return p.name == key; });
    if (it == method->params.end()) {
      std::vector<std::string> names;
      for (const auto& p : method->params) names.push_back(p.name);
      throw_usage("--set " + key + "=" + value + ": unknown parameter for method " + method->name +
                  (names.empty() ? std::string(" (it has none)") : " (known: " + detail::known_names(names) + ")"));
    }
    detail::check_param_value(method->name, *it, value);  // type and range, by the method's table
  }
  if (!settings.debug_view.empty()) {
    std::vector<DebugViewInfo> views = method->debug_views;
    for (const DebugViewInfo& v : detail::common_debug_views(*method)) views.push_back(v);
    const bool known =
        std::any_of(views.begin(), views.end(), [&](const DebugViewInfo& v) { return v.name == settings.debug_view; });
    if (!known) {
      std::vector<std::string> names;
      for (const auto& v : views) names.push_back(v.name);
      throw_usage("--debug-view " + settings.debug_view + ": method " + method->name + " has no such view (" +
                  (names.empty() ? std::string("it has none") : "known: " + detail::known_names(names)) + ")");
    }
  }
  check_number("--threads", settings.threads);
  if (settings.max_work != 0) check_number("--max-work", settings.max_work);
  validate(settings.camera);
  validate(settings.aperture);
  validate(settings.highlights);
  return *method;
}

}  // namespace

struct Renderer::Impl {
  RenderSettings settings;
  const detail::MethodDef* method = nullptr;
  detail::Workspace workspace;
  RenderResult result;
  Frame sanitized;  // colour-sanitised copy of the input, used only when the input needs it
  Frame boosted;    // the highlight-boosted copy, used only when highlight recovery is on
  Image boost_mask;
  // The aperture model for the current frame size (made again when the size changes).
  std::optional<core::ApertureModel> aperture;
  int aperture_w = -1, aperture_h = -1;
  std::unique_ptr<gpu::MethodRenderer> gpu;  // backend = vulkan: the method's shaders
};

namespace {

// The `aperture` debug view: far | near kernels, each a 3×3 grid of source positions.
Image aperture_view(const core::ApertureModel& model, const core::CocRange& range, int w, int h) {
  const float rho_far = std::clamp(static_cast<float>(range.far_max), 0.5f, 64.0f);
  const float rho_near = std::clamp(static_cast<float>(range.near_max), 0.5f, 64.0f);
  const int reach = std::max(model.reach(rho_far), model.reach(rho_near));
  const int cell = 2 * reach + 3, side = 3 * cell;
  Image out(2 * side + 4, side, 4, 0.0f);
  std::fill(out.plane(3), out.plane(3) + out.plane_size(), 1.0f);
  for (int panel = 0; panel < 2; ++panel) {
    const core::Field f = panel == 0 ? core::Field::far : core::Field::near;
    const float rho = panel == 0 ? rho_far : rho_near;
    for (int gy = 0; gy < 3; ++gy)
      for (int gx = 0; gx < 3; ++gx) {
        const float sx = (gx == 0 ? 0.5f : gx == 1 ? 0.5f * w : w - 0.5f);
        const float sy = (gy == 0 ? 0.5f : gy == 1 ? 0.5f * h : h - 0.5f);
        for (int c = 0; c < 3; ++c) {
          const core::ApertureModel::Kernel k = model.kernel(rho, f, sx, sy, std::min(c, model.channels() - 1));
          const float peak = *std::max_element(k.cov.begin(), k.cov.end());
          const int ox = panel * (side + 4) + gx * cell + cell / 2, oy = gy * cell + cell / 2;
          for (int dy = -k.reach; dy <= k.reach; ++dy)
            for (int dx = -k.reach; dx <= k.reach; ++dx)
              out.at(ox + dx, oy + dy, c) = peak > 0 ? k.at(dx, dy) / peak : 0.0f;
        }
      }
  }
  return out;
}

}  // namespace

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
void Renderer::set_progress(ProgressCallback progress) { impl_->settings.progress = std::move(progress); }
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
  const detail::Params params(method.name, method.params, settings.params);
  std::optional<detail::DebugSink> sink;
  const int threads = settings.threads > 0 ? settings.threads : core::hardware_threads();
  detail::Progress progress(&settings.progress);
  core::with_threads(settings.threads, [&] {
    // Non-finite / out-of-range colour never reaches a method's result (rules in
    // render/sanitize.hpp). A method that reads every colour sample in one of its passes
    // anyway checks them there (checks_colour); otherwise, or when it found a bad sample,
    // the colour is checked here and sanitised into a copy where needed.
    std::atomic<bool> dirty{false};
    const bool boost = settings.highlights.enabled();
    // The GPU passes get sanitised colour (the check is not made in their shaders).
    const bool deferred = method.checks_colour && frame_in.layer_color.empty() && !boost && !impl_->gpu;
    const Frame& frame = [&]() -> const Frame& {
      if (deferred) return frame_in;
      core::PassScope pass("colour check");
      const Frame& clean = detail::sanitized_frame(frame_in, impl_->sanitized);
      if (!boost) return clean;
      // Highlight recovery: the boosted copy of the (clean) colour and of every layer.
      Frame& b = impl_->boosted;
      const bool want_mask = settings.debug_view == "highlights";
      detail::boost_highlights(clean.color, settings.highlights, b.color, want_mask ? &impl_->boost_mask : nullptr);
      b.depth = clean.depth;
      b.layer_color.resize(clean.layer_color.size());
      for (std::size_t l = 0; l < clean.layer_color.size(); ++l)
        detail::boost_highlights(clean.layer_color[l], settings.highlights, b.layer_color[l]);
      b.layer_depth = clean.layer_depth;
      return b;
    }();
    if (!impl_->aperture || impl_->aperture_w != frame.width() || impl_->aperture_h != frame.height()) {
      impl_->aperture.emplace(settings.aperture, frame.width(), frame.height());
      impl_->aperture_w = frame.width();
      impl_->aperture_h = frame.height();
    }
    const core::ApertureModel* aperture = &*impl_->aperture;
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
    const double max_work = settings.max_work > 0 ? settings.max_work : kDefaultMaxWork;
    if (impl_->gpu)
      impl_->gpu->render({frame, result.coc, settings.camera, coc_of, params, *sink, threads, impl_->workspace, nullptr,
                          &range, max_work, aperture, &progress},
                         result.image);
    else
      method.render({frame, result.coc, settings.camera, coc_of, params, *sink, threads, impl_->workspace,
                     deferred ? &dirty : nullptr, &range, max_work, aperture, &progress},
                    result.image);
    if (progress.cancelled()) throw Cancelled();
    if (deferred && dirty.load()) {
      // Rare (hostile input): everything from the first try is discarded. The depth, and so
      // the CoC, are the caller's in both tries.
      core::PassScope again("colour check + render again");
      const Frame& clean = detail::sanitized_frame(frame_in, impl_->sanitized);
      sink.emplace(settings.debug_view);
      method.render({clean, result.coc, settings.camera, coc_of, params, *sink, threads, impl_->workspace, nullptr,
                     &range, max_work, aperture, &progress},
                    result.image);
      if (progress.cancelled()) throw Cancelled();
    }
    if (boost && settings.highlights.restore) {
      core::PassScope again("highlight restore");
      detail::restore_highlights(result.image, settings.highlights);
    }
    if (settings.debug_view == "highlights")
      sink->offer("highlights",
                  [&] { return boost ? impl_->boost_mask : Image(frame.width(), frame.height(), 1, 0.0f); });
    if (settings.debug_view == "aperture" && !sink->found())
      sink->offer("aperture", [&] { return aperture_view(*aperture, range, frame.width(), frame.height()); });
  });
  result.debug = Image();
  if (!settings.debug_view.empty()) {
    if (!sink->found()) throw_internal("method " + method.name + " did not produce debug view " + settings.debug_view);
    result.debug = std::move(sink->result());
  }
  progress.finish();
  return result;
}

RenderResult render(const Frame& frame, const RenderSettings& settings) {
  Renderer renderer(settings);
  // The renderer is discarded: move its result out instead of copying it.
  return std::move(const_cast<RenderResult&>(renderer.render(frame)));
}

std::uint64_t render_memory_bytes(const RenderSettings& settings, int width, int height, int layers) {
  // Scratch bytes per pixel of each method (and per pixel of each extra layer): peak RSS of
  // `dofkit render` on the 2048x1024 bench frame less the inputs, the result and the output's
  // buffers, times 1.5 plus 16 (docs/robustness.md has the measurements). A method not listed
  // gets 160.
  struct Cost {
    const char* method;
    double per_px, per_layer_px;
  };
  static const Cost kCosts[] = {{"reference", 48, 0}, {"scatter", 32, 0},   {"mcguire", 40, 0},
                                {"sterna", 48, 0},    {"starcraft", 32, 0}, {"layered", 112, 16}};
  Cost cost{"", 160, 32};
  for (const Cost& c : kCosts)
    if (settings.method == c.method) cost = c;
  const double px = static_cast<double>(std::max(width, 0)) * std::max(height, 0);
  // The result (RGBA) and the CoC map; a sanitised copy of the colour and of every layer's
  // colour (only made for a frame that needs it); a debug view.
  const double fixed = 16 + 4 + 16 + 16.0 * layers + (settings.debug_view.empty() ? 0 : 16);
  const double bytes = px * (fixed + cost.per_px + cost.per_layer_px * layers);
  return bytes > 1.8e19 ? ~std::uint64_t{0} : static_cast<std::uint64_t>(bytes);
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
