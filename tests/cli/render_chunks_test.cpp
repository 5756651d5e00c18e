// `dofkit render --frames` split over farm tasks: the chunk mapping (chunks.hpp), the chunk
// flags and environment variables, --skip-existing, and the graceful stop on SIGTERM. A chunk's
// frames must be bit-identical to the same frames of one process rendering the whole range.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <thread>

#include "chunks.hpp"
#include "commands.hpp"
#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "render_cli_util.hpp"

extern char** environ;

using namespace dofkit;
using namespace dofkit::test;
namespace fs = std::filesystem;

namespace {

// --- the mapping and the flag/variable resolution, without rendering --------------------

using Env = std::map<std::string, std::string>;
cli::EnvLookup lookup(const Env& env) {
  return [&env](const char* name) -> const char* {
    const auto it = env.find(name);
    return it == env.end() ? nullptr : it->second.c_str();
  };
}

cli::FarmFlags flags(const std::string& index, const std::string& count, bool from_env = false) {
  cli::FarmFlags f;
  f.index = index;
  f.count = count;
  f.from_env = from_env;
  return f;
}

// The usage error (exit 2) resolve_chunk throws, or "" if none.
std::string resolve_error(const cli::FarmFlags& f, std::size_t frames, const Env& env = {},
                          const std::string& frames_flag = "1-12") {
  try {
    cli::resolve_chunk(f, frames_flag, frames, lookup(env));
  } catch (const Error& e) {
    EXPECT_EQ(e.exit_code(), 2) << e.what();
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST(ChunkMapping, EveryCountCutsTheListIntoContiguousNonEmptyChunksOfBalancedSize) {
  for (std::size_t m = 1; m <= 40; ++m)
    for (long n = 1; n <= static_cast<long>(m); ++n) {
      std::size_t next = 0, smallest = m, largest = 0;
      for (long i = 0; i < n; ++i) {
        const cli::ChunkRange r = cli::chunk_range(m, i, n);
        ASSERT_EQ(r.begin, next) << m << " frames, chunk " << i << " of " << n;
        ASSERT_LT(r.begin, r.end) << m << " frames, chunk " << i << " of " << n << " is empty";
        smallest = std::min(smallest, r.end - r.begin);
        largest = std::max(largest, r.end - r.begin);
        next = r.end;
      }
      EXPECT_EQ(next, m) << m << " frames, " << n << " chunks";
      EXPECT_LE(largest - smallest, 1u) << m << " frames, " << n << " chunks";
    }
  // The largest list --frames allows, in the widest split.
  EXPECT_EQ(cli::chunk_range(1000000, 999999, 1000000).begin, 999999u);
  EXPECT_EQ(cli::chunk_range(1000000, 999999, 1000000).end, 1000000u);
  EXPECT_EQ(cli::chunk_range(10, 1, 3).begin, 3u);  // 10 frames in 3: 3, 3, 4
  EXPECT_EQ(cli::chunk_range(10, 2, 3).begin, 6u);
}

TEST(ChunkFlags, ExplicitIndexAndCount) {
  EXPECT_FALSE(cli::resolve_chunk(flags("", ""), "1-12", 12, lookup({})).has_value());
  const auto c = cli::resolve_chunk(flags("3", "4"), "1-12", 12, lookup({}));
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(c->index, 3);
  EXPECT_EQ(c->count, 4);
  // The flags win over the environment.
  const Env slurm = {{"SLURM_ARRAY_TASK_ID", "1"}, {"SLURM_ARRAY_TASK_COUNT", "2"}};
  EXPECT_EQ(cli::resolve_chunk(flags("3", "4", true), "1-12", 12, lookup(slurm))->index, 3);
  EXPECT_EQ(cli::resolve_chunk(flags("", "6", true), "1-12", 12, lookup(slurm))->count, 6);
}

TEST(ChunkFlags, BadIndexOrCountIsAUsageErrorNamingTheFlag) {
  struct Case {
    std::string index, count, expect;
  };
  for (const Case& c :
       std::vector<Case>{{"-1", "4", "--chunk-index -1: must be 0..3 (chunks count from 0"},
                         {"4", "4", "--chunk-index 4: must be 0..3"},
                         {"0", "0", "--chunk-count 0: must be at least 1"},
                         {"0", "-2", "--chunk-count -2: must be at least 1"},
                         {"0", "13", "--chunk-count 13: more chunks than the 12 frames of --frames 1-12"},
                         {"x", "4", "--chunk-index x: not a whole number"},
                         {"1.5", "4", "--chunk-index 1.5: not a whole number"},
                         {" 1", "4", "--chunk-index  1: not a whole number"},
                         {"1", "4k", "--chunk-count 4k: not a whole number"},
                         {"1", "99999999999", "--chunk-count 99999999999: out of range"},
                         {"1", "", "--chunk-index 1: needs --chunk-count N"},
                         {"", "4", "--chunk-count 4: needs --chunk-index I"}}) {
    const std::string e = resolve_error(flags(c.index, c.count), 12);
    EXPECT_TRUE(contains(e, c.expect)) << "got: " << e << "\nwant: " << c.expect;
    EXPECT_FALSE(contains(e, "\n")) << e;
  }
  EXPECT_TRUE(contains(resolve_error(flags("0", "2"), 0, {}, ""), "--chunk-index: needs --frames"));
  EXPECT_TRUE(contains(resolve_error(flags("", "", true), 0, {}, ""), "--chunk-from-env: needs --frames"));
}

TEST(ChunkFlags, FromEnvironment) {
  auto chunk = [](const Env& env, const std::string& count = "") {
    const auto c = cli::resolve_chunk(flags("", count, true), "1-12", 12, lookup(env));
    EXPECT_TRUE(c.has_value());
    return c ? std::make_pair(c->index, c->count) : std::make_pair(-1L, -1L);
  };
  EXPECT_EQ(chunk({{"SLURM_ARRAY_TASK_ID", "5"}, {"SLURM_ARRAY_TASK_COUNT", "6"}}), std::make_pair(5L, 6L));
  EXPECT_EQ(chunk({{"JOB_COMPLETION_INDEX", "0"}}, "4"), std::make_pair(0L, 4L));
  EXPECT_EQ(chunk({{"AWS_BATCH_JOB_ARRAY_INDEX", "2"}}, "3"), std::make_pair(2L, 3L));
  // Slurm's variables come first when several schedulers' are set.
  EXPECT_EQ(chunk({{"SLURM_ARRAY_TASK_ID", "1"}, {"SLURM_ARRAY_TASK_COUNT", "2"}, {"JOB_COMPLETION_INDEX", "0"}}),
            std::make_pair(1L, 2L));
}

TEST(ChunkFlags, MissingOrMalformedVariableIsAUsageErrorNamingIt) {
  struct Case {
    Env env;
    std::string count, expect;
  };
  for (const Case& c : std::vector<Case>{
           {{}, "", "--chunk-from-env: none of SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX, AWS_BATCH_JOB_ARRAY_INDEX"},
           {{{"SLURM_ARRAY_TASK_ID", "2"}}, "", "SLURM_ARRAY_TASK_COUNT (--chunk-from-env): not set"},
           {{{"SLURM_ARRAY_TASK_ID", "two"}, {"SLURM_ARRAY_TASK_COUNT", "4"}},
            "",
            "SLURM_ARRAY_TASK_ID=two (--chunk-from-env): not a whole number"},
           {{{"SLURM_ARRAY_TASK_ID", ""}, {"SLURM_ARRAY_TASK_COUNT", "4"}},
            "",
            "SLURM_ARRAY_TASK_ID= (--chunk-from-env): not a whole number"},
           {{{"SLURM_ARRAY_TASK_ID", "1"}, {"SLURM_ARRAY_TASK_COUNT", "x"}},
            "",
            "SLURM_ARRAY_TASK_COUNT=x (--chunk-from-env): not a whole number"},
           // --array=1-4: ids 1..4 with a count of 4; the last one is out of range.
           {{{"SLURM_ARRAY_TASK_ID", "4"}, {"SLURM_ARRAY_TASK_COUNT", "4"}},
            "",
            "SLURM_ARRAY_TASK_ID=4 (--chunk-from-env): must be 0..3 (chunks count from 0; "
            "SLURM_ARRAY_TASK_COUNT=4 (--chunk-from-env))"},
           {{{"SLURM_ARRAY_TASK_ID", "0"}, {"SLURM_ARRAY_TASK_COUNT", "20"}},
            "",
            "SLURM_ARRAY_TASK_COUNT=20 (--chunk-from-env): more chunks than the 12 frames"},
           {{{"JOB_COMPLETION_INDEX", "1"}}, "", "JOB_COMPLETION_INDEX (--chunk-from-env): gives only the index"},
           {{{"JOB_COMPLETION_INDEX", "-1"}}, "4", "JOB_COMPLETION_INDEX=-1 (--chunk-from-env): must be 0..3"},
           {{{"AWS_BATCH_JOB_ARRAY_INDEX", "1"}}, "", "AWS_BATCH_JOB_ARRAY_INDEX (--chunk-from-env): gives only"},
           {{{"AWS_BATCH_JOB_ARRAY_INDEX", "9"}},
            "4",
            "AWS_BATCH_JOB_ARRAY_INDEX=9 (--chunk-from-env): must be 0..3"}}) {
    const std::string e = resolve_error(flags("", c.count, true), 12, c.env);
    EXPECT_TRUE(contains(e, c.expect)) << "got: " << e << "\nwant: " << c.expect;
    EXPECT_FALSE(contains(e, "\n")) << e;
  }
}

// --- through `dofkit render` -----------------------------------------------------------

namespace {

using Result = CliResult;
// `dofkit render ARGS` in this process, like main.cpp (errors → exit codes).
Result render(const std::vector<std::string>& args) { return run_render(args); }

// Sets environment variables for one scope and removes them after.
class ScopedEnv {
 public:
  explicit ScopedEnv(const Env& env) : env_(env) {
    for (const auto& kv : env_) ::setenv(kv.first.c_str(), kv.second.c_str(), 1);
  }
  ~ScopedEnv() {
    for (const auto& kv : env_) ::unsetenv(kv.first.c_str());
  }

 private:
  Env env_;
};

std::set<std::string> files_in(const fs::path& dir) {
  std::set<std::string> s;
  for (const auto& e : fs::directory_iterator(dir)) s.insert(e.path().filename().string());
  return s;
}

std::string frame_name(int frame) {
  char b[32];
  std::snprintf(b, sizeof b, "o.%04d.exr", frame);
  return b;
}

// Frames 1..kFrames of a small rack focus: one colour plate copied per frame and its depth
// scaled by 0.6 + 0.05 k, so that a fixed --focus falls on another depth in every frame.
constexpr int kW = 96, kH = 54, kFrames = 24;
class RenderChunks : public ::testing::Test {
 protected:
  void SetUp() override {
    const Image color = test_rgba(kW, kH, true, true);
    Image depth(kW, kH, 1, 10.0f);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) depth.at(x, y) = 1.0f + 0.25f * static_cast<float>((x / 8 + y / 6) % 9);
    fs::create_directories(dir_.path() / "in");
    for (int k = 1; k <= kFrames; ++k) {
      char n[16];
      std::snprintf(n, sizeof n, "%04d", k);
      io::write_image(dir_ / ("in/c." + std::string(n) + ".exr"), color);
      Image z = depth;
      for (float& v : z.data()) v *= 0.6f + 0.05f * static_cast<float>(k);
      io::WriteOptions zo;
      zo.channel_name = "Z";
      io::write_image(dir_ / ("in/z." + std::string(n) + ".exr"), z, zo);
    }
  }

  // `dofkit render` of --frames `frames` into folder `out` (created), plus `extra` flags; the
  // exact `reference` method with a blur at infinity of `blur_px`.
  std::vector<std::string> call(const std::string& frames, const std::string& out, std::vector<std::string> extra = {},
                                const std::string& blur_px = "6") const {
    fs::create_directories(dir_.path() / out);
    std::vector<std::string> a = {"--color",
                                  dir_ / "in/c.####.exr",
                                  "--depth",
                                  dir_ / "in/z.####.exr",
                                  "--frames",
                                  frames,
                                  "--focus",
                                  "2",
                                  "--blur-at-infinity",
                                  blur_px,
                                  "--method",
                                  "reference",
                                  "--output",
                                  dir_ / (out + "/o.####.exr")};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }
  std::string bytes(const std::string& out, int frame) const {
    return read_bytes(dir_ / (out + "/" + frame_name(frame)));
  }

  ScratchDir dir_;
};

}  // namespace

// Every chunk of --frames 1-12 --chunk-count 4 writes exactly its three frames; together they
// are the range with no frame twice, and each is bit-identical to one process rendering the
// whole range (with another thread count).
TEST_F(RenderChunks, EveryChunkWritesExactlyItsFramesAndTheSamePictures) {
  ASSERT_EQ(render(call("1-12", "whole", {"--threads", "2"})).code, 0);
  std::set<std::string> all;
  std::size_t total = 0;
  for (int i = 0; i < 4; ++i) {
    const std::string out = "chunk" + std::to_string(i);
    const Result r =
        render(call("1-12", out, {"--chunk-index", std::to_string(i), "--chunk-count", "4", "--threads", "1"}));
    ASSERT_EQ(r.code, 0) << r.message;
    const std::set<std::string> got = files_in(dir_.path() / out);
    std::set<std::string> want;
    for (int f = 3 * i + 1; f <= 3 * i + 3; ++f) want.insert(frame_name(f));
    EXPECT_EQ(got, want) << "chunk " << i;
    total += got.size();
    all.insert(got.begin(), got.end());
    for (int f = 3 * i + 1; f <= 3 * i + 3; ++f) EXPECT_EQ(bytes(out, f), bytes("whole", f)) << "frame " << f;
  }
  EXPECT_EQ(all, files_in(dir_.path() / "whole"));  // the union is the range
  EXPECT_EQ(total, all.size());                     // and no frame is in two chunks
  // The frames differ, so a chunk that rendered another frame's picture would have been seen.
  EXPECT_NE(bytes("whole", 1), bytes("whole", 12));
}

// Chunks are cut from the frame list, not from the range of numbers: --frames 1-23x2 is 12
// frames (1, 3, … 23); chunk 1 of 4 is 7, 9, 11. An uneven split (10 in 3) gives 3, 3, 4.
TEST_F(RenderChunks, ChunksOfASteppedListAndAnUnevenSplit) {
  ASSERT_EQ(render(call("1-23x2", "step", {"--chunk-index", "1", "--chunk-count", "4"})).code, 0);
  EXPECT_EQ(files_in(dir_.path() / "step"), (std::set<std::string>{frame_name(7), frame_name(9), frame_name(11)}));
  ASSERT_EQ(render(call("1-10", "uneven", {"--chunk-index", "2", "--chunk-count", "3"})).code, 0);
  EXPECT_EQ(files_in(dir_.path() / "uneven"),
            (std::set<std::string>{frame_name(7), frame_name(8), frame_name(9), frame_name(10)}));
}

TEST_F(RenderChunks, BadChunkIsAUsageErrorWithNoOutput) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--chunk-index", "-1", "--chunk-count", "4"}, "--chunk-index -1"},
      {{"--chunk-index", "4", "--chunk-count", "4"}, "--chunk-index 4"},
      {{"--chunk-index", "0", "--chunk-count", "0"}, "--chunk-count 0"},
      {{"--chunk-index", "0", "--chunk-count", "13"}, "--chunk-count 13"},
      {{"--chunk-index", "0"}, "--chunk-index 0: needs --chunk-count"},
      {{"--chunk-from-env"}, "--chunk-from-env: none of"}};
  for (const auto& c : cases) {
    const Result r = render(call("1-12", "bad", c.first));
    EXPECT_EQ(r.code, 2) << r.message;
    EXPECT_TRUE(contains(r.message, c.second)) << "got: " << r.message << "\nwant: " << c.second;
    EXPECT_FALSE(contains(r.message, "\n")) << r.message;
    EXPECT_TRUE(files_in(dir_.path() / "bad").empty()) << c.second;
  }
  // Without --frames there is no list to cut.
  const Result r =
      render({"--color", dir_ / "in/c.0001.exr", "--depth", dir_ / "in/z.0001.exr", "--focus", "2",
              "--blur-at-infinity", "6", "--output", dir_ / "bad/one.exr", "--chunk-index", "0", "--chunk-count", "1"});
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.message, "--chunk-index: needs --frames")) << r.message;
  EXPECT_TRUE(files_in(dir_.path() / "bad").empty());
}

TEST_F(RenderChunks, ChunkFromTheSchedulersEnvironment) {
  ASSERT_EQ(render(call("1-12", "whole")).code, 0);
  const std::vector<std::pair<Env, std::vector<std::string>>> cases = {
      {{{"SLURM_ARRAY_TASK_ID", "2"}, {"SLURM_ARRAY_TASK_COUNT", "4"}}, {}},
      {{{"JOB_COMPLETION_INDEX", "2"}}, {"--chunk-count", "4"}},
      {{{"AWS_BATCH_JOB_ARRAY_INDEX", "2"}}, {"--chunk-count", "4"}}};
  int n = 0;
  for (const auto& c : cases) {
    const ScopedEnv env(c.first);
    const std::string out = "env" + std::to_string(n++);
    auto extra = c.second;
    extra.push_back("--chunk-from-env");
    const Result r = render(call("1-12", out, extra));
    ASSERT_EQ(r.code, 0) << r.message;
    EXPECT_EQ(files_in(dir_.path() / out), (std::set<std::string>{frame_name(7), frame_name(8), frame_name(9)}));
    for (int f = 7; f <= 9; ++f) EXPECT_EQ(bytes(out, f), bytes("whole", f)) << out << " frame " << f;
  }
  const ScopedEnv env({{"SLURM_ARRAY_TASK_ID", "1"}, {"SLURM_ARRAY_TASK_COUNT", "many"}});
  const Result r = render(call("1-12", "badenv", {"--chunk-from-env"}));
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.message, "SLURM_ARRAY_TASK_COUNT=many")) << r.message;
  EXPECT_TRUE(files_in(dir_.path() / "badenv").empty());
}

// --skip-existing leaves a frame alone when all its outputs exist (even a file that is not a
// picture: existence is the test, as outputs are renamed into place when complete) and renders
// a frame that lacks one of them.
TEST_F(RenderChunks, SkipExistingRendersOnlyTheMissingFrames) {
  ASSERT_EQ(render(call("1-4", "whole", {"--output-coc", dir_ / "whole/coc.####.exr"})).code, 0);
  fs::create_directories(dir_.path() / "resume");
  write_bytes(dir_ / ("resume/" + frame_name(2)), "kept");
  write_bytes(dir_ / "resume/coc.0002.exr", "kept");
  write_bytes(dir_ / ("resume/" + frame_name(3)), "stale");  // its CoC map is missing: rendered again
  const Result r = render(call("1-4", "resume", {"--output-coc", dir_ / "resume/coc.####.exr", "--skip-existing"}));
  ASSERT_EQ(r.code, 0) << r.message;
  EXPECT_EQ(bytes("resume", 2), "kept");
  for (int f : {1, 3, 4}) EXPECT_EQ(bytes("resume", f), bytes("whole", f)) << "frame " << f;
  EXPECT_EQ(files_in(dir_.path() / "resume").size(), 8u);  // no temporary file left
  // Everything there: nothing is written.
  const auto before = fs::last_write_time(dir_ / ("resume/" + frame_name(1)));
  ASSERT_EQ(render(call("1-4", "resume", {"--output-coc", dir_ / "resume/coc.####.exr", "--skip-existing"})).code, 0);
  EXPECT_EQ(fs::last_write_time(dir_ / ("resume/" + frame_name(1))), before);
  EXPECT_EQ(bytes("resume", 2), "kept");
}

// SIGTERM (scancel) during a --frames run of the built binary: the frame being rendered is
// finished, the run stops before the next one and ends by SIGTERM; no temporary file remains and
// every frame written equals the uninterrupted run's. A rerun with --skip-existing completes it.
TEST_F(RenderChunks, SigtermStopsBetweenFramesAndSkipExistingResumes) {
  // A large blur (up to the 24 px cap of a 96 px wide frame) makes every frame take a while,
  // so that the signal comes while frames remain.
  ASSERT_EQ(render(call("1-24", "whole", {}, "60")).code, 0);
  std::vector<std::string> args = call("1-24", "stopped", {"--threads", "1"}, "60");
  args.insert(args.begin(), {std::string(DOFKIT_BINARY_DIR) + "/dofkit", "render"});
  std::vector<char*> argv;
  for (auto& s : args) argv.push_back(s.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  const std::string log = dir_ / "stopped.log";
  posix_spawn_file_actions_addopen(&fa, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&fa);
  // Wait (bounded) for the first frame, then send SIGTERM.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(dir_ / ("stopped/" + frame_name(1))) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  const std::set<std::string> written = files_in(dir_.path() / "stopped");
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM)
      << "the run ended with status " << status << " after " << written.size() << " frames: " << read_bytes(log);
  EXPECT_TRUE(contains(read_bytes(log), "stopped by SIGTERM after")) << read_bytes(log);
  EXPECT_GE(written.size(), 1u);
  EXPECT_LT(written.size(), static_cast<std::size_t>(kFrames));
  for (int f = 1; f <= kFrames; ++f)
    if (written.count(frame_name(f))) EXPECT_EQ(bytes("stopped", f), bytes("whole", f)) << "frame " << f;
  for (const std::string& name : written) EXPECT_TRUE(name.rfind("o.", 0) == 0) << "left behind: " << name;

  const Result r = render(call("1-24", "stopped", {"--skip-existing"}, "60"));
  ASSERT_EQ(r.code, 0) << r.message;
  for (int f = 1; f <= kFrames; ++f) EXPECT_EQ(bytes("stopped", f), bytes("whole", f)) << "frame " << f;
}
