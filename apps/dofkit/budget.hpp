// The memory budget (--max-memory): every command estimates the peak memory of the work it
// was asked for — from the inputs' headers, before any pixel is decoded or made — and refuses
// work above the budget with exit 3 and the estimate, instead of meeting the out-of-memory
// killer (or a failed allocation) minutes later. docs/robustness.md has the estimates.
#pragma once
#include <cstdint>
#include <string>

#include "dofkit/render.hpp"

namespace dofkit::cli {

/// 3/4 of the machine's memory (physical RAM, or the cgroup's limit where that is lower).
std::uint64_t default_memory_budget_bytes();
/// Sets the budget (0 = the default). Throws Error(usage) outside the --max-memory range.
void set_memory_budget_mib(long long mib);
std::uint64_t memory_budget_bytes();

/// Throws Error(bad_input) "<what> needs about N MiB of memory, more than the limit of M MiB
/// (--max-memory); <hint>" if `estimate_bytes` is above the budget.
void check_memory(std::uint64_t estimate_bytes, const std::string& what, const std::string& hint);

/// The inputs of one frame, as their headers declare them.
struct FrameShape {
  int width = 0, height = 0;
  int layers = 0;                       ///< fragments per pixel the layers reader keeps (0 = none)
  std::uint64_t deep_sample_bytes = 0;  ///< a deep input's sample data (header_check.hpp)
  int layer_file_channels = 0;          ///< a layered EXR's channels (all are read)
  bool mask = false;                    ///< --mask and --mask-depth
  int passthrough_channels = 0;         ///< an EXR colour's channels kept for the EXR output
};

/// Peak bytes of one `dofkit render` frame: the process, the decoded inputs (and a
/// decoder's buffers while one is read), render()'s memory (render_memory_bytes) and the
/// encoders' buffers. `sequence`: --frames reads the next frame while this one renders.
std::uint64_t render_frame_bytes(const RenderSettings& settings, const FrameShape& shape, bool sequence);

/// Peak bytes of `dofkit scene` / one scene of `dofkit quality`: the pinhole frame with its
/// layers, the ground truth and the ray tracer's buffers, the written files' buffers.
std::uint64_t scene_bytes(int width, int height, int layers);

/// "1234 MiB" (rounded up).
std::string mib_text(std::uint64_t bytes);

}  // namespace dofkit::cli
