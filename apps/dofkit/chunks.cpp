// Frame chunks for farm tasks, --skip-existing and the SIGTERM stop (see chunks.hpp).
#include "chunks.hpp"

#include <algorithm>
#include <cctype>
#include <csignal>
#include <filesystem>
#include <iostream>

#include "dofkit/error.hpp"

namespace dofkit::cli {

void FarmFlags::add(CLI::App* cmd) {
  const std::string g = "Farm (chunks of --frames)";
  cmd->add_option("--chunk-index", index,
                  "I: render only chunk I (counted from 0) of the --chunk-count N contiguous chunks of the --frames "
                  "list; chunk I holds list positions floor(I*M/N) .. floor((I+1)*M/N)-1 of the M frames")
      ->group(g);
  cmd->add_option("--chunk-count", count, "N: number of chunks the --frames list is cut into, 1..M (M frames)")
      ->group(g);
  cmd->add_flag("--chunk-from-env", from_env,
                "take the chunk index (and count) the scheduler sets when the flags are absent: "
                "SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT (submit --array=0-(N-1)), Kubernetes "
                "JOB_COMPLETION_INDEX or AWS_BATCH_JOB_ARRAY_INDEX (these two with --chunk-count N)")
      ->group(g);
  cmd->add_flag("--skip-existing", skip_existing,
                "leave out every frame whose outputs all exist (outputs are renamed into place when complete, so an "
                "existing file is a whole frame): rerun a killed task with it to resume")
      ->group(g);
}

namespace {

// A whole decimal number, optionally signed, no spaces; |value| <= 10^9. `what` names the flag
// or variable in the message ("--chunk-index 1x" / "SLURM_ARRAY_TASK_ID=1x (--chunk-from-env)").
long parse_count(const std::string& text, const std::string& what) {
  std::size_t i = (!text.empty() && (text[0] == '-' || text[0] == '+')) ? 1 : 0;
  const bool digits =
      i < text.size() && std::all_of(text.begin() + static_cast<std::ptrdiff_t>(i), text.end(),
                                     [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
  if (!digits) throw_usage(what + ": not a whole number");
  long v = 0;
  for (; i < text.size(); ++i) {
    v = v * 10 + (text[i] - '0');
    if (v > 1000000000) throw_usage(what + ": out of range");
  }
  return text[0] == '-' ? -v : v;
}

}  // namespace

std::optional<Chunk> resolve_chunk(const FarmFlags& flags, const std::string& frames_flag, std::size_t frame_count,
                                   const EnvLookup& env) {
  if (!flags.chunked()) return std::nullopt;
  const std::string first = !flags.index.empty()   ? "--chunk-index"
                            : !flags.count.empty() ? "--chunk-count"
                                                   : "--chunk-from-env";
  if (frames_flag.empty()) throw_usage(first + ": needs --frames FIRST-LAST (chunks are parts of the frame list)");

  // Where the index and the count come from, for the messages.
  std::string index_text = flags.index, index_what = "--chunk-index " + flags.index;
  std::string count_text = flags.count, count_what = "--chunk-count " + flags.count;
  std::string index_source = "--chunk-index";
  if (flags.index.empty()) {
    if (!flags.from_env)
      throw_usage(flags.count.empty() ? std::string("--chunk-index: required")
                                      : "--chunk-count " + flags.count +
                                            ": needs --chunk-index I (or --chunk-from-env inside an array job)");
    const char* kIndexVars[] = {"SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX", "AWS_BATCH_JOB_ARRAY_INDEX"};
    for (const char* name : kIndexVars) {
      if (const char* value = env(name)) {
        index_text = value;
        index_source = name;
        index_what = std::string(name) + "=" + value + " (--chunk-from-env)";
        break;
      }
    }
    if (index_text.empty() && index_source == "--chunk-index")
      throw_usage(
          "--chunk-from-env: none of SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX, AWS_BATCH_JOB_ARRAY_INDEX is set "
          "(not inside an array job? give --chunk-index I)");
  }
  if (flags.count.empty()) {
    if (index_source == "SLURM_ARRAY_TASK_ID" && env("SLURM_ARRAY_TASK_COUNT")) {
      count_text = env("SLURM_ARRAY_TASK_COUNT");
      count_what = "SLURM_ARRAY_TASK_COUNT=" + count_text + " (--chunk-from-env)";
    } else if (index_source == "SLURM_ARRAY_TASK_ID") {
      throw_usage("SLURM_ARRAY_TASK_COUNT (--chunk-from-env): not set; give --chunk-count N");
    } else if (index_source == "--chunk-index") {
      throw_usage("--chunk-index " + flags.index + ": needs --chunk-count N");
    } else {
      throw_usage(index_source + " (--chunk-from-env): gives only the index; give --chunk-count N (the number of " +
                  (index_source == "JOB_COMPLETION_INDEX" ? "completions of the Indexed Job)"
                                                          : "child jobs of the array job)"));
    }
  }

  const long count = parse_count(count_text, count_what);
  if (count < 1) throw_usage(count_what + ": must be at least 1");
  if (static_cast<std::size_t>(count) > frame_count)
    throw_usage(count_what + ": more chunks than the " + std::to_string(frame_count) + " frames of --frames " +
                frames_flag);
  const long index = parse_count(index_text, index_what);
  if (index < 0 || index >= count)
    throw_usage(index_what + ": must be 0.." + std::to_string(count - 1) + " (chunks count from 0; " + count_what +
                ")");
  return Chunk{index, count};
}

ChunkRange chunk_range(std::size_t frame_count, long index, long count) {
  // 64-bit products: frame_count <= 10^6 (--frames' limit) and count <= frame_count.
  const auto m = static_cast<unsigned long long>(frame_count);
  const auto i = static_cast<unsigned long long>(index), n = static_cast<unsigned long long>(count);
  return {static_cast<std::size_t>(i * m / n), static_cast<std::size_t>((i + 1) * m / n)};
}

bool outputs_exist(const std::vector<NamedPath>& outputs) {
  bool any = false;
  for (const NamedPath& out : outputs) {
    if (out.path.empty()) continue;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(out.path, ec)) return false;
    any = true;
  }
  return any;
}

namespace {

volatile std::sig_atomic_t g_stop_requested = 0;

extern "C" void on_sigterm(int) {
  if (g_stop_requested) {
    std::signal(SIGTERM, SIG_DFL);
    std::raise(SIGTERM);
    return;
  }
  g_stop_requested = 1;
}

void (*g_previous_handler)(int) = SIG_DFL;

}  // namespace

GracefulStop::GracefulStop() {
  g_stop_requested = 0;
  g_previous_handler = std::signal(SIGTERM, on_sigterm);
  if (g_previous_handler == SIG_ERR) g_previous_handler = SIG_DFL;
}

GracefulStop::~GracefulStop() { std::signal(SIGTERM, g_previous_handler); }

bool GracefulStop::requested() { return g_stop_requested != 0; }

void GracefulStop::stop_if_requested(const std::string& message) {
  if (!requested()) return;
  std::cerr << "dofkit: " << message << std::endl;
  std::signal(SIGTERM, SIG_DFL);
  std::raise(SIGTERM);
}

}  // namespace dofkit::cli
