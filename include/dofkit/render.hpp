// dofkit — rendering depth of field.
#pragma once
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "dofkit/aperture.hpp"
#include "dofkit/coc.hpp"
#include "dofkit/error.hpp"
#include "dofkit/frame.hpp"
#include "dofkit/image.hpp"

namespace dofkit {

/// Where a method's passes run: the CPU (default), or Vulkan compute shaders on a GPU
/// (methods mcguire, sterna, starcraft; see docs/gpu.md).
enum class Backend { cpu, vulkan };

/// Progress of one render: called with the fraction of the frame done (0..1, non-decreasing
/// within a frame; 1 once the frame is complete). Return false to cancel: the render then stops
/// at the next band and throws Cancelled. Called from the render's worker threads, one call at
/// a time (serialised by the library); it must not throw and should return quickly. The
/// output does not depend on whether a callback is set. Methods report per band of their main
/// passes (`lens` and `reference` do; the others report only the frame's end, and a cancel
/// then takes effect when their passes finish).
using ProgressCallback = std::function<bool(double fraction_done)>;

/// Thrown by render() / Renderer::render() when the ProgressCallback returned false (an
/// Error of kind internal, message "render cancelled"; no result is produced).
class Cancelled : public Error {
 public:
  Cancelled() : Error(ErrorKind::internal, "render cancelled") {}
};

/// Everything a render needs besides the frame.
struct RenderSettings {
  /// Technique: "lens" (the default: the reference's picture, fast), "reference" (exact
  /// single-layer scatter, the oracle), "mcguire", "sterna", "starcraft", "layered", … — see
  /// methods().
  std::string method = "lens";
  /// The camera: CoC model, reference width, clamp.
  CameraModel camera;
  /// The lens aperture (bokeh shape), for the methods that honour it (MethodInfo::aperture;
  /// the others draw their own kernel). Default: the circle.
  ApertureShape aperture;
  /// Highlight recovery for display-referred colour (default: off). Applied by render() to the
  /// colour every method gets, so it works with any method.
  HighlightRecovery highlights;
  /// Method parameters as key → value text (the CLI's `--set k=v`). Unknown keys and
  /// out-of-range values throw Error(usage) naming the key.
  std::map<std::string, std::string> params;
  /// Worker threads; 0 = all hardware threads, at most kMaxThreads. Output is identical for
  /// every count.
  int threads = 0;
  /// Name of an intermediate buffer to return in RenderResult::debug ("" = none).
  /// See MethodInfo::debug_views; every method has `highlights` (the boost mask m²·w, 1 plane)
  /// and every method that honours an aperture has `aperture` (its kernels, far | near).
  std::string debug_view;
  /// The most work the disc scatter of `reference` and `scatter` may take, in pixel visits
  /// (a source's disc covers about (2r + 1)² receivers): a frame whose CoC map implies more is
  /// refused with Error(usage) before it is scattered (the CLI's --max-work). 0 = the
  /// default, kDefaultMaxWork. The gather methods cost a bounded number of samples per pixel
  /// and have no such limit.
  double max_work = 0;
  /// cpu, or vulkan (GPU compute shaders; a build or machine without Vulkan throws
  /// Error(internal) naming the reason when a Renderer is made).
  Backend backend = Backend::cpu;
  /// Progress and cancellation (see ProgressCallback); empty = none.
  ProgressCallback progress;
};

/// --threads' maximum.
inline constexpr int kMaxThreads = 1024;
/// The default RenderSettings::max_work: about half a minute of the reference method on two
/// cores (it visits ~7e9 pixels a second there).
inline constexpr double kDefaultMaxWork = 2e11;

/// The result of a render.
struct RenderResult {
  Image image;  ///< RGBA premultiplied, linear, same size as the input colour
  Image coc;    ///< signed CoC radius in pixels used for the render (1 plane)
  Image debug;  ///< the requested debug view (empty if none was requested)
};

namespace detail {
struct RendererAccess;  // the GPU backend's timings (src/gpu/gpu.hpp)
}

/// Renders depth of field. Throws dofkit::Error on bad input or settings.
/// (One-shot convenience; for sequences use Renderer, which keeps its buffers.)
RenderResult render(const Frame& frame, const RenderSettings& settings);

/// Renders a sequence of frames with the same settings, keeping every intermediate buffer
/// (and the result) between frames of the same size, so steady-state rendering does no
/// per-frame allocation. Not thread-safe: one Renderer per thread of the caller.
class Renderer {
 public:
  explicit Renderer(RenderSettings settings);
  ~Renderer();
  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;
  /// Renders one frame; the returned reference stays valid until the next call.
  const RenderResult& render(const Frame& frame);
  /// Replaces the camera for the frames that follow (a focus pulled from frame to frame);
  /// the buffers are kept. Throws like the constructor if the camera is inconsistent (and
  /// then keeps the previous one).
  void set_camera(const CameraModel& camera);
  const RenderSettings& settings() const;
  /// Replaces the progress callback for the frames that follow (empty = none).
  void set_progress(ProgressCallback progress);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  friend struct detail::RendererAccess;
};

/// Transparency (StarCraft II, docs/methods/starcraft.md): renders `frame` as usual, then
/// re-applies depth of field over the region where `mask` (1 plane, 0..1, same size) is
/// non-zero using `mask_depth` (1 plane, z) as the depth there — e.g. the depth of a key
/// transparency that did not write depth — and blends the second result in by the mask.
RenderResult render_masked(const Frame& frame, const Image& mask, const Image& mask_depth,
                           const RenderSettings& settings);

/// An upper estimate of the memory render() allocates for a frame of `width` × `height`
/// pixels with `layers` extra layers (bytes): the result and the CoC map, a sanitised copy
/// of the colour, the method's scratch buffers (measured per method; docs/robustness.md).
std::uint64_t render_memory_bytes(const RenderSettings& settings, int width, int height, int layers = 0);

/// Computes the signed, clamped CoC map (pixels) of a depth map for a camera.
Image compute_coc(const Image& depth, const CameraModel& camera, int threads = 0);

/// The kind of value a method parameter takes.
enum class ParamType {
  integer,  ///< a whole number in [min, max]
  real,     ///< a number in [min, max] (or one of `choices`, words accepted instead: "auto")
  choice,   ///< one of `choices`
  boolean,  ///< on/off (also true/false, 1/0, yes/no)
};

/// One method parameter, declared once: render() validates and reads `--set` values by this,
/// and `dofkit methods` (--json), the CLI help and the docs check are made from it.
struct ParamInfo {
  std::string name;           ///< key for RenderSettings::params
  std::string default_value;  ///< as text ("4 (demo), 2 (book, g3d)" when it depends on another key)
  std::string help;           ///< meaning, one line (type, range, unit and default are the fields)
  ParamType type = ParamType::real;
  std::string unit;                  ///< "px", "deg", "m", … ("" = dimensionless)
  double min = 0, max = 0;           ///< integer / real: the accepted closed range
  std::vector<std::string> choices;  ///< choice: the values; real: words accepted instead of a number
  /// A default that depends on another parameter: that parameter's name and, per value of it
  /// (in the order `default_value` lists them), the default as text. Empty: one default.
  std::string default_depends_on;
  std::vector<std::pair<std::string, std::string>> default_cases;
};

/// "int", "float", "choice" or "bool".
const char* param_type_name(ParamType type);
/// A parameter's type, range / choices and unit in a few words, e.g. "int 3..16",
/// "float 0..4096 px", "float 0.01..50 or auto", "one of mean, max", "on/off".
std::string param_kind(const ParamInfo& p);

/// Description of a debug view.
struct DebugViewInfo {
  std::string name;
  std::string help;
};

/// Description of a technique.
struct MethodInfo {
  std::string name;
  std::string summary;
  std::vector<ParamInfo> params;
  std::vector<DebugViewInfo> debug_views;
  /// Which RenderSettings::aperture fields the method honours, in words ("" = none: it draws
  /// its own kernel whatever the aperture says).
  std::string aperture;
};

/// All available techniques, sorted by name.
std::vector<MethodInfo> methods();

/// Focus distance (scene units) read from a depth map around pixel (x, y): the median of
/// the finite depths in a (2·radius+1)² window, so a pixel on an edge still gives a
/// sensible value. Throws Error(usage) if (x, y) is outside the image or the window holds
/// no finite depth.
double focus_from_depth(const Image& depth, int x, int y, int radius = 3);

}  // namespace dofkit
