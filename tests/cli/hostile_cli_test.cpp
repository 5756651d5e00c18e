// Issue 37: the hostile user's findings, each as a test of the built `dofkit` (exit code, one
// line on stderr, nothing written), numbered as in the issue. The readers' share of them
// (bombs, damaged files) is in tests/data/bad (the bad-input corpus) and tests/io.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dofkit/ranges.hpp"
#include "dofkit/render.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "io/layers_io.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAsan = true;
#else
constexpr bool kAsan = false;
#endif

struct Proc {
  int code = -1;    // exit status; 128 + signal if it died of one
  std::string err;  // stderr
  std::string out;  // stdout
};

std::string q(const std::string& s) {
  std::string r = "'";
  for (char c : s) r += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return r + "'";
}

// Runs `dofkit ARGS` through the shell, in `dir`, killed after 60 s (a hang is a failure, not
// a stuck suite).
Proc cli(const std::string& args, const ScratchDir& dir, const std::string& prefix = "") {
  const std::string err = dir / ".stderr", out = dir / ".stdout";
  const std::string cmd = "cd " + q(dir.path().string()) + " && " + prefix + " timeout -s KILL 60 " +
                          std::string(DOFKIT_BINARY_DIR) + "/dofkit " + args + " 2>" + q(err) + " >" + q(out);
  const int status = std::system(cmd.c_str());
  Proc r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.err = read_bytes(err);
  r.out = read_bytes(out);
  std::filesystem::remove(err);
  std::filesystem::remove(out);
  return r;
}

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// The contract of a refusal: exit `code`, one line "dofkit: error: …" (or CLI11's "dofkit: …")
// on stderr holding every part.
void expect_refused(const Proc& r, int code, std::initializer_list<std::string> parts) {
  EXPECT_EQ(r.code, code) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "not one line: " << r.err;
  EXPECT_EQ(r.err.rfind("dofkit: ", 0), 0u) << r.err;
  for (const std::string& p : parts) EXPECT_TRUE(has(r.err, p)) << "missing '" << p << "' in: " << r.err;
}

class HostileCli : public ::testing::Test {
 protected:
  void SetUp() override {
    Image c = test_rgba(64, 48, true);
    Image z(64, 48, 1, 4.0f);
    for (int x = 0; x < 20; ++x) z.at(x, 10) = 1.0f;
    io::write_image(dir_ / "c.exr", c);
    io::WriteOptions zo;
    zo.channel_name = "Z";
    io::write_image(dir_ / "z.exr", z, zo);
  }
  // render with c.exr / z.exr, the given camera and extra flags, output o.exr.
  Proc run(const std::string& flags) { return cli("render --color c.exr --depth z.exr " + flags, dir_); }
  std::vector<std::string> entries() const {
    std::vector<std::string> v;
    for (const auto& e : dir_.entries())
      if (e[0] != '.' || e.find("dofkit-tmp") != std::string::npos) v.push_back(e);
    return v;
  }
  void expect_only(std::vector<std::string> names) {
    names.insert(names.end(), {"c.exr", "z.exr"});
    std::sort(names.begin(), names.end());
    EXPECT_EQ(entries(), names);
  }
  ScratchDir dir_;
};

}  // namespace

// --- 1. numbers that crashed -------------------------------------------------------------

TEST_F(HostileCli, Finding1_SubnormalAndOverflowingCameraNumbersAreUsageErrors) {
  const char* cases[][2] = {
      {"--focus 4 --f-number 1e-320", "--f-number 1e-320: must be 0.1 to 10000"},
      {"--focus 4 --f-number 2.8 --sensor-width 1e-320", "--sensor-width 1e-320: must be"},
      {"--focus 4 --blur-at-infinity 8 --reference-width 1e-320", "--reference-width 1e-320: must be 1 to"},
      {"--focus 4 --blur-at-infinity 1e300 --reference-width 1e-300 --max-coc 10", "--blur-at-infinity 1e300"},
      {"--focus 4 --blur-at-infinity 8 --reference-width 1e-300 --max-coc 10", "--reference-width 1e-300"},
      {"--focus 4 --f-number 2.8 --focal-length 1e6", "--focal-length 1e6: must be 0.1 to 100000 mm"},
      {"--focus nan --blur-at-infinity 8", "--focus nan"},
      {"--focus 4 --blur-at-infinity inf", "--blur-at-infinity inf"},
      {"--focus 4 --blur-at-infinity 0x10", "not a number"},
      {"--starcraft 4,1,5,2 --max-radius -1", "--max-radius -1: must be 0 to"},
      {"--starcraft 4,1,5,1e-320", "--starcraft 4,1,5,1e-320: value 4 (1e-320)"},
      {"--planes 0.5,2,4,1e31 --near-radius 8 --far-radius 8", "--planes"},
      {"--focus 4 --blur-at-infinity 8 --max-coc 1e-320", "--max-coc 1e-320"},
      {"--focus-at 1e10,3 --blur-at-infinity 8", "--focus-at"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c[0]);
    for (const char* method : {"reference", "scatter", "mcguire"})
      expect_refused(run(std::string(c[0]) + " --method " + method + " --output o.exr"), 2, {c[1]});
  }
  expect_only({});
}

TEST_F(HostileCli, Finding1_ThreadCountsAreCappedAndQuiet) {
  for (const char* threads : {"12000000", "4000000", "1025", "-1"})
    expect_refused(run(std::string("--focus 4 --blur-at-infinity 8 --threads ") + threads + " --output o.exr"), 2,
                   {"--threads", "0 to 1024"});
  expect_refused(cli("scene occluder --out s --threads 100000", dir_), 2, {"--threads 100000"});
  // More threads than the machine has: the same picture, and nothing but dofkit's own line on
  // stderr (oneTBB printed a multi-line warning).
  const Proc one = run("--focus 4 --blur-at-infinity 8 --threads 1 --output one.exr");
  ASSERT_EQ(one.code, 0) << one.err;
  const Proc many = run("--focus 4 --blur-at-infinity 8 --threads 64 --output many.exr");
  ASSERT_EQ(many.code, 0) << many.err;
  EXPECT_EQ(std::count(many.err.begin(), many.err.end(), '\n'), 1) << many.err;
  EXPECT_TRUE(has(many.err, "dofkit: wrote")) << many.err;
  EXPECT_EQ(read_bytes(dir_ / "one.exr"), read_bytes(dir_ / "many.exr"));
}

// --- 2. / 4. sizes before pixels, memory ------------------------------------------------------

// A colour file whose header is sound but whose pixels cannot be decoded, with a depth map of
// another size: the sizes are compared from the headers, so the error is the mismatch — the
// decoder never runs (a 649-byte JPEG declaring 16000x16000 took 7 GB and 24 s to get there).
TEST_F(HostileCli, Finding2_SizesAreComparedBeforeAnyPixelIsDecoded) {
  Image big(320, 200, 4, 0.0f);
  io::write_image(dir_ / "big.png", big);
  std::string bytes = read_bytes(dir_ / "big.png");
  const std::size_t idat = bytes.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  for (std::size_t i = idat + 10; i < idat + 30; ++i) bytes[i] = static_cast<char>(0x5a);  // scrambled deflate
  write_bytes(dir_ / "big.png", bytes);
  const Proc r = cli("render --color big.png --depth z.exr --focus 4 --blur-at-infinity 8 --output o.exr", dir_);
  expect_refused(r, 3, {"z.exr", "depth is 64x48 but colour big.png is 320x200"});
  // The same with --layers and --mask: every header first.
  Frame f;
  f.layer_color = {Image(32, 24, 4, 0.5f)};
  f.layer_depth = {Image(32, 24, 1, 3.0f)};
  io::write_layers_exr(dir_ / "l.exr", f);
  expect_refused(
      cli("render --color c.exr --layers l.exr --method layered --focus 4 --blur-at-infinity 8 --output o.exr", dir_),
      3, {"l.exr: layers is 32x24 but colour c.exr is 64x48"});
  io::write_image(dir_ / "m.png", Image(10, 10, 1, 0.5f));
  expect_refused(run("--mask m.png --mask-depth z.exr --focus 4 --blur-at-infinity 8 --output o.exr"), 3,
                 {"m.png: mask is 10x10"});
  expect_only({"big.png", "l.exr", "m.png"});
}

TEST_F(HostileCli, Finding4_MemoryBudgetRefusesBeforeWork) {
  // scene --size 8192x8192 --layers 64 reached 10 GB, then exit 1; 16384x16384 was killed.
  for (const char* size : {"8192x8192 --layers 64", "16384x16384"}) {
    const Proc r = cli(std::string("scene occluder --out s --size ") + size + " --max-memory 2048", dir_);
    expect_refused(r, 3, {"needs about", "MiB of memory, more than the limit of 2048 MiB (--max-memory"});
  }
  EXPECT_FALSE(std::filesystem::exists(dir_ / "s")) << "the --out folder was made";
  // By default too (3/4 of any machine's memory is less than 16384² px with 64 layers).
  expect_refused(cli("scene occluder --out s --size 16384x16384 --layers 64", dir_), 3, {"by default 3/4"});
  // A render whose inputs are fine but too large for the budget.
  expect_refused(run("--focus 4 --blur-at-infinity 8 --max-memory 16 --output o.exr"), 3,
                 {"rendering 64x48 with method reference needs about", "more than the limit of 16 MiB"});
  // --max-pixels applies to the scene size.
  expect_refused(cli("scene occluder --out s --size 100x100 --max-pixels 5000", dir_), 2, {"--max-pixels"});
  expect_only({});
}

// An allocation that fails anyway (the machine has less than the budget says: here a
// 500 MB address-space limit) is exit 3 naming what was being done, never "internal".
TEST_F(HostileCli, Finding4_FailedAllocationIsBadInputNotInternal) {
  if (kAsan) GTEST_SKIP() << "an address-space limit and AddressSanitizer's shadow memory do not mix";
  io::write_image(dir_ / "big.exr", Image(4096, 2048, 4, 0.25f));
  io::WriteOptions zo;
  zo.channel_name = "Z";
  io::write_image(dir_ / "bigz.exr", Image(4096, 2048, 1, 3.0f), zo);
  const Proc r =
      cli("render --color big.exr --depth bigz.exr --focus 4 --blur-at-infinity 8 --max-memory 100000 --output o.exr",
          dir_, "ulimit -v 500000 &&");
  expect_refused(r, 3, {"out of memory while"});
  EXPECT_FALSE(has(r.err, "internal")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "o.exr"));
}

// --- 3. devices and special files ----------------------------------------------------------

TEST_F(HostileCli, Finding3_DevicesFifosAndFoldersAreRefusedAtOnce) {
  ASSERT_EQ(::mkfifo((dir_ / "fifo.exr").c_str(), 0600), 0);
  std::filesystem::create_directory(dir_ / "folder.exr");
  const char* cases[][2] = {
      {"--color /dev/zero --depth z.exr", "/dev/zero: colour path is a character device, not a regular file"},
      {"--color /dev/urandom --depth z.exr", "/dev/urandom: colour path is a character device"},
      {"--color c.exr --depth /dev/full", "/dev/full: depth path is a character device"},
      {"--color fifo.exr --depth z.exr", "fifo.exr: colour path is a named pipe (fifo), not a regular file"},
      {"--color c.exr --depth fifo.exr", "fifo.exr: depth path is a named pipe"},
      {"--layers /dev/zero --method layered", "/dev/zero: layered input path is a character device"},
      {"--layers fifo.exr --method layered", "fifo.exr: layered input path is a named pipe"},
      {"--color folder.exr --depth z.exr", "folder.exr: colour path is a folder"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c[0]);
    expect_refused(cli(std::string("render ") + c[0] + " --focus 4 --blur-at-infinity 8 --output o.exr", dir_), 3,
                   {c[1]});
  }
  expect_refused(cli("compare /dev/zero c.exr", dir_), 3, {"character device"});
  expect_only({"fifo.exr", "folder.exr"});
}

// --- 5. sequences --------------------------------------------------------------------------

TEST_F(HostileCli, Finding5_FrameRangesAreCappedAndCheckedFirst) {
  expect_refused(run("--focus 4 --blur-at-infinity 8 --frames 0-999999 --output o.####.exr"), 2,
                 {"--frames 0-999999", "1000000 frames, more than the limit of 100000"});
  // 100,000 frames whose first input is missing: stopped at frame 0, at once.
  expect_refused(cli("render --color c.#####.exr --focus 4 --blur-at-infinity 8 --frames 0-99999 --output "
                     "o.#####.exr",
                     dir_),
                 3, {"c.00000.exr", "does not exist (frame 0 of --frames 0-99999)"});
  expect_refused(run("--focus 4 --blur-at-infinity 8 --frames '' --output o.####.exr"), 2, {"--frames: empty"});
  expect_only({});
}

// --- 7. messages ---------------------------------------------------------------------------

TEST_F(HostileCli, Finding7_MessagesAreOneLineAndNameTheRightThing) {
  // A path with a newline: one line, the newline escaped.
  io::write_image(dir_ / "new\nline.exr", test_rgba(8, 8));
  Proc r = cli("render --color " + q("new\nline.exr") + " --depth z.exr --focus 4 --blur-at-infinity 8 --output o.exr",
               dir_);
  expect_refused(r, 3, {"new\\nline.exr"});
  // A damaged palette PNG (it went to OpenImageIO, where libpng printed its own line first).
  io::write_image(dir_ / "z4.exr", Image(4, 4, 1, 2.0f));
  r = cli("render --color " + q(std::string(DOFKIT_SOURCE_DIR) + "/tests/data/bad/palette_bad_idat.png") +
              " --depth z4.exr --focus 4 --blur-at-infinity 8 --output o.exr",
          dir_);
  expect_refused(r, 3, {"palette_bad_idat.png: cannot read colour"});
  EXPECT_FALSE(has(r.err, "libpng")) << r.err;
  // A symlink loop, an over-long name, a pipe.
  ASSERT_EQ(::symlink("loop.exr", (dir_ / "loop.exr").c_str()), 0);
  r = cli("render --color loop.exr --depth z.exr --focus 4 --blur-at-infinity 8 --output o.exr", dir_);
  expect_refused(r, 3, {"loop.exr: cannot open colour file: too many levels of symbolic links"});
  r = cli(
      "render --color " + std::string(300, 'x') + ".exr --depth z.exr --focus 4 --blur-at-infinity 8 --output o.exr",
      dir_);
  expect_refused(r, 3, {"cannot open colour file: the path or a name in it is too long"});
  r = cli("render --color /dev/stdin --depth z.exr --focus 4 --blur-at-infinity 8 --output o.exr", dir_, "echo x |");
  expect_refused(r, 3, {"named pipe"});
  // bench with a bad method parameter: exit 2, one line (was 4 lines and exit 1).
  r = cli("bench --size 64x36 --methods mcguire:variant=xx --iterations 1", dir_);
  expect_refused(r, 2, {"variant=xx"});
  // demo --out FILE: refused before its banner.
  write_bytes(dir_ / "file", "x");
  r = cli("demo --out file", dir_);
  expect_refused(r, 3, {"--out file: exists and is not a folder"});
  expect_only({"file", "loop.exr", "new\nline.exr", "z4.exr"});
}

TEST_F(HostileCli, Finding7_UnreadableFileIsPermissionDenied) {
  if (::geteuid() == 0) GTEST_SKIP() << "root reads every file";
  io::write_image(dir_ / "secret.exr", test_rgba(8, 8));
  ::chmod((dir_ / "secret.exr").c_str(), 0);
  expect_refused(cli("render --color secret.exr --depth z.exr --focus 4 --blur-at-infinity 8 --output o.exr", dir_), 3,
                 {"secret.exr: cannot open colour file: permission denied"});
}

// --- 8. signals and temporary files -------------------------------------------------------

// SIGTERM / SIGINT / SIGHUP while the output is written: the temporary file goes, the process
// ends by the signal (a shell reports 128 + signal), the previous output stays or is
// completely replaced. The signal is sent once a temporary file exists (polled), so it lands
// while the outputs are written on any machine. (safe_output_test.cpp raises it inside a
// write, deterministically.)
TEST_F(HostileCli, Finding8_SignalsRemoveTheTemporaryFile) {
  io::write_image(dir_ / "big.exr", Image(2048, 2048, 4, 0.25f));
  io::WriteOptions zo;
  zo.channel_name = "Z";
  io::write_image(dir_ / "bigz.exr", Image(2048, 2048, 1, 3.0f), zo);
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) {
    SCOPED_TRACE(sig);
    write_bytes(dir_ / "o.exr", "previous result");
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::chdir(dir_.path().c_str());
      ::execl((std::string(DOFKIT_BINARY_DIR) + "/dofkit").c_str(), "dofkit", "render", "--color", "big.exr", "--depth",
              "bigz.exr", "--focus", "4", "--blur-at-infinity", "2", "--method", "mcguire", "--compression", "none",
              "--output", "o.exr", "--output-coc", "coc.exr", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    // Wait for a temporary to appear, then signal.
    bool seen = false;
    for (int i = 0; i < 60000 && !seen; ++i) {
      for (const auto& e : dir_.entries()) seen = seen || e.find(".dofkit-tmp-") != std::string::npos;
      if (!seen) ::usleep(500);
    }
    ::kill(pid, sig);
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (!seen) {
      ADD_FAILURE() << "no temporary file was seen before the process ended";
      continue;
    }
    if (WIFEXITED(status)) {
      EXPECT_EQ(WEXITSTATUS(status), 0);  // it finished in the moment between
    } else {
      EXPECT_EQ(WTERMSIG(status), sig);
    }
    // The target is untouched or completely replaced.
    if (read_bytes(dir_ / "o.exr") != "previous result") {
      const Image out = io::read_color(dir_ / "o.exr");
      EXPECT_EQ(out.width(), 2048);
    }
    for (const auto& e : dir_.entries()) EXPECT_EQ(e.find(".dofkit-tmp-"), std::string::npos) << e;
    std::filesystem::remove(dir_ / "coc.exr");
  }
}

// --- 9. frame patterns -----------------------------------------------------------------------

TEST_F(HostileCli, Finding9_FramePatternsFollowPrintf) {
  for (const char* f : {"c.1.exr", "c.2.exr"}) std::filesystem::copy_file(dir_ / "c.exr", dir_ / f);
  // %d: the number as it is; %05d: five digits; %% a literal %.
  Proc r = run("--focus 4 --blur-at-infinity 8 --frames 1-2 --output o.%d.%05d.exr");
  EXPECT_EQ(r.code, 2) << r.err;  // two patterns in one path
  r =
      cli("render --color c.%d.exr --depth z.exr --focus 4 --blur-at-infinity 8 --frames 1-2 --output "
          "o%%.%05d.exr",
          dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir_ / "o%.00001.exr"));
  EXPECT_TRUE(std::filesystem::exists(dir_ / "o%.00002.exr"));
  // "%%d" is the characters %d, not a pattern: the output then has none.
  expect_refused(cli("render --color c.%d.exr --depth z.exr --focus 4 --blur-at-infinity 8 --frames 1-2 --output "
                     "o.%%d.exr",
                     dir_),
                 2, {"--output o.%%d.exr: needs a frame pattern"});
  for (const char* bad : {"o.%099d.exr", "o.%5d.exr", "o.%x.exr", "o.%0d.exr", "o.%.exr"})
    expect_refused(cli(std::string("render --color c.%d.exr --depth z.exr --focus 4 --blur-at-infinity 8 --frames "
                                   "1-2 --output ") +
                           bad,
                       dir_),
                   2, {"--output"});
  // A padding that makes a name longer than the system allows.
  expect_refused(cli("render --color c.%d.exr --depth z.exr --focus 4 --blur-at-infinity 8 --frames 1-2 --output " +
                         std::string(245, 'n') + ".%016d.exr",
                     dir_),
                 2, {"longer than 255 bytes"});
}

// --- 10. cost --------------------------------------------------------------------------------

TEST_F(HostileCli, Finding10_ScatterWorkIsBounded) {
  // Every radius at the cap of a quarter of the width: Σ (2r+1)² pixel visits. With the limit
  // lowered below this frame's work the reference and the scatter refuse and say which flags
  // to lower; the gather methods have no such cost.
  for (const char* method : {"reference", "scatter"})
    expect_refused(
        run(std::string("--focus 1 --blur-at-infinity 1e6 --method ") + method + " --max-work 1e6 --output o.exr"), 2,
        {std::string(method) + ": this frame's discs need", "--max-work", "--max-coc", "sterna"});
  const Proc ok = run("--focus 1 --blur-at-infinity 1e6 --method sterna --max-work 1e6 --output o.exr");
  EXPECT_EQ(ok.code, 0) << ok.err;
  const Proc def = run("--focus 1 --blur-at-infinity 1e6 --method reference --output r.exr");
  EXPECT_EQ(def.code, 0) << def.err;
}

TEST(ScatterWork, MatchesTheDocumentedFormulaAndTheDefaultLimit) {
  Frame f;
  f.color = Image(256, 128, 4, 0.5f);
  f.depth = Image(256, 128, 1, 1.0f);
  RenderSettings s;
  s.camera.model = BlurAtInfinity{4.0, 1.0};  // r = 1 · (4/1 − 1) = 3 px everywhere
  s.max_work = 256 * 128 * 7 * 7;             // (2·⌈3.5⌉ − 1)² = 49 per source: exactly the work
  EXPECT_NO_THROW(render(f, s));
  s.max_work = 256 * 128 * 49 - 1;
  EXPECT_THROW(render(f, s), Error);
  s.method = "scatter";
  EXPECT_THROW(render(f, s), Error);
  s.method = "mcguire";
  EXPECT_NO_THROW(render(f, s));
  EXPECT_EQ(kDefaultMaxWork, 2e11);
}

// --- 11. output files ---------------------------------------------------------------------

TEST_F(HostileCli, Finding11_ScenePlantedSymlinkIsNotFollowed) {
  write_bytes(dir_ / "victim.txt", "do not touch");
  std::filesystem::create_directory(dir_ / "s");
  ASSERT_EQ(::symlink((dir_ / "victim.txt").c_str(), (dir_ / "s/.params.json.tmp").c_str()), 0);
  const Proc r = cli("scene occluder --out s --size 32x18 --samples 1 --layers 0", dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(read_bytes(dir_ / "victim.txt"), "do not touch");
  EXPECT_TRUE(std::filesystem::is_regular_file(dir_ / "s/params.json"));
}

TEST_F(HostileCli, Finding11_OutputsAreHandledCarefully) {
  const std::string camera = "--focus 4 --blur-at-infinity 8 --output ";
  // An existing output's mode is kept.
  write_bytes(dir_ / "kept.exr", "old");
  ::chmod((dir_ / "kept.exr").c_str(), 0640);
  ASSERT_EQ(run(camera + "kept.exr").code, 0);
  struct stat st {};
  ASSERT_EQ(::stat((dir_ / "kept.exr").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
  // A read-only output is refused (even for root), and kept.
  write_bytes(dir_ / "ro.exr", "old");
  ::chmod((dir_ / "ro.exr").c_str(), 0444);
  expect_refused(run(camera + "ro.exr"), 3,
                 {"ro.exr: cannot write: the existing file is not writable by you (mode "
                  "0444); refusing to replace it"});
  EXPECT_EQ(read_bytes(dir_ / "ro.exr"), "old");
  // Another user's private file (0600): refused, kept (needs root to make it).
  if (::geteuid() == 0) {
    write_bytes(dir_ / "theirs.exr", "old");
    ::chmod((dir_ / "theirs.exr").c_str(), 0600);
    ASSERT_EQ(::chown((dir_ / "theirs.exr").c_str(), 65534, 65534), 0);
    expect_refused(run(camera + "theirs.exr"), 3, {"theirs.exr: cannot write", "0600"});
    EXPECT_EQ(read_bytes(dir_ / "theirs.exr"), "old");
    // One the caller may write (group / others) keeps its owner.
    ::chmod((dir_ / "theirs.exr").c_str(), 0666);
    ASSERT_EQ(run(camera + "theirs.exr").code, 0);
    ASSERT_EQ(::stat((dir_ / "theirs.exr").c_str(), &st), 0);
    EXPECT_EQ(st.st_uid, 65534u);
    EXPECT_EQ(st.st_mode & 07777, 0666u);
  }
  // A fifo named *.exr is refused, not replaced.
  ASSERT_EQ(::mkfifo((dir_ / "pipe.exr").c_str(), 0600), 0);
  expect_refused(run(camera + "pipe.exr"), 3, {"pipe.exr: cannot write: it is a named pipe (fifo)"});
  ASSERT_EQ(::lstat((dir_ / "pipe.exr").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  // Output names up to the system's 255 bytes work (the temporary name is short).
  const std::string long_name = std::string(251, 'n') + ".exr";
  ASSERT_EQ(long_name.size(), 255u);
  const Proc r = run(camera + long_name);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir_ / long_name));
  for (const auto& e : dir_.entries()) EXPECT_EQ(e.find(".dofkit-tmp-"), std::string::npos) << e;
}

// --- 12. small ones ----------------------------------------------------------------------------

TEST_F(HostileCli, Finding12_SmallOnes) {
  expect_refused(cli("quality --layers 17 --out q", dir_), 2, {"--layers 17"});
  EXPECT_FALSE(std::filesystem::exists(dir_ / "q")) << "quality made its --out folder";
  expect_refused(run("--focus 4 --blur-at-infinity 8 --png-level -1 --output o.png"), 2,
                 {"--png-level -1: must be 0 to 9"});
  expect_refused(run("--focus 4 --blur-at-infinity 8 --bits 0 --output o.png"), 2, {"--bits 0: must be 8 to 32"});
  expect_refused(run("--focus 4 --blur-at-infinity 8 --frames '' --output o.exr"), 2, {"--frames"});
  expect_only({});
}

// --- the ranges table ---------------------------------------------------------------------

// docs/cli.md holds the table of numeric ranges the code checks, between two markers: it
// must be exactly what the table generates (regenerate it by pasting numeric_ranges_markdown()).
TEST(NumericRanges, DocsTableMatchesTheCode) {
  const std::string doc = read_bytes(std::string(DOFKIT_SOURCE_DIR) + "/docs/cli.md");
  const std::string begin = "<!-- ranges:begin -->\n", end = "<!-- ranges:end -->";
  const auto a = doc.find(begin), b = doc.find(end);
  ASSERT_NE(a, std::string::npos);
  ASSERT_NE(b, std::string::npos);
  EXPECT_EQ(doc.substr(a + begin.size(), b - a - begin.size()), numeric_ranges_markdown())
      << "docs/cli.md's table differs from src/core/ranges.cpp; the table to paste:\n"
      << numeric_ranges_markdown();
}

TEST(NumericRanges, HelpShowsEachRenderFlagsRange) {
  ScratchDir dir;
  const Proc r = cli("render --help", dir);
  ASSERT_EQ(r.code, 0);
  for (const char* flag : {"--f-number", "--focal-length", "--threads", "--max-memory", "--max-work", "--png-level"})
    EXPECT_TRUE(has(r.out, range_text(numeric_range(flag)))) << flag;
}
