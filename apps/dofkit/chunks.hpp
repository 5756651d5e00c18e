// `dofkit render --frames` on a render farm: which part of the frame list this task renders
// (--chunk-index / --chunk-count, or the array index a scheduler puts in the environment with
// --chunk-from-env), --skip-existing, and a graceful stop on SIGTERM.
//
// The mapping (docs/cli.md): the frame list of --frames (M frames, in order) is cut into N
// contiguous chunks; chunk I (counted from 0, like Slurm's --array=0-(N-1), Kubernetes'
// JOB_COMPLETION_INDEX and AWS Batch's AWS_BATCH_JOB_ARRAY_INDEX) holds the list positions
// floor(I*M/N) .. floor((I+1)*M/N)-1. Chunk sizes differ by at most one frame, every frame is
// in exactly one chunk, and 1 <= N <= M so that no chunk is empty.
#pragma once
#include <CLI/CLI.hpp>

#include <cstddef>
#include <cstdlib>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "cli_common.hpp"

namespace dofkit::cli {

/// --chunk-index, --chunk-count, --chunk-from-env as given ("" = flag absent), and
/// --skip-existing.
struct FarmFlags {
  std::string index, count;
  bool from_env = false;
  bool skip_existing = false;
  void add(CLI::App* cmd);
  bool chunked() const { return !index.empty() || !count.empty() || from_env; }
};

/// The environment as --chunk-from-env reads it (std::getenv, or a table in the tests).
using EnvLookup = std::function<const char*(const char*)>;

/// This task's chunk: index in [0, count).
struct Chunk {
  long index = 0, count = 1;
};

/// Resolves the chunk of a --frames list of `frame_count` frames (`frames_flag`: the --frames
/// text, "" when absent); std::nullopt when no chunk flag is given. An explicit --chunk-index or
/// --chunk-count wins over the environment. The variables, in this order (the first one set
/// gives the index): SLURM_ARRAY_TASK_ID (count: SLURM_ARRAY_TASK_COUNT), JOB_COMPLETION_INDEX,
/// AWS_BATCH_JOB_ARRAY_INDEX (count: --chunk-count). Throws Error(usage), one line naming the
/// flag or variable, for a missing, malformed or out-of-range value.
std::optional<Chunk> resolve_chunk(
    const FarmFlags& flags, const std::string& frames_flag, std::size_t frame_count,
    const EnvLookup& env = [](const char* name) { return std::getenv(name); });

/// List positions [begin, end) of chunk `index` of `count` over `frame_count` frames
/// (requires 1 <= count <= frame_count, 0 <= index < count).
struct ChunkRange {
  std::size_t begin = 0, end = 0;
};
ChunkRange chunk_range(std::size_t frame_count, long index, long count);

/// --skip-existing: true when every non-empty output path exists as a regular file. Outputs are
/// written to a temporary file and renamed into place, so an existing output is a complete one.
bool outputs_exist(const std::vector<NamedPath>& outputs);

/// While one is alive, SIGTERM (what Slurm's scancel, Kubernetes and AWS Batch send to stop a
/// task) only sets a flag, so that a --frames run finishes the frame it is on and stops before
/// the next one (stop_if_requested); a second SIGTERM ends the process at once. The previous
/// handler is restored on destruction.
class GracefulStop {
 public:
  GracefulStop();
  ~GracefulStop();
  GracefulStop(const GracefulStop&) = delete;
  GracefulStop& operator=(const GracefulStop&) = delete;
  static bool requested();
  /// If SIGTERM came: prints `message` on stderr and ends the process by SIGTERM (its default
  /// action), so the scheduler sees a task terminated by the signal it sent.
  static void stop_if_requested(const std::string& message);
};

}  // namespace dofkit::cli
