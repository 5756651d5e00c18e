// Safe output (issue 9): a write that fails or is killed half-way never damages the previous
// file of that name. Complements tests/io (which covers a failing encoder and a missing
// folder) with failures from outside the encoder: the file-size limit (what a full disk looks
// like to the writer), SIGKILL in the middle of writing, a failure in the second file of an
// OutputSet, and a target that is a folder.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "dofkit/error.hpp"
#include "io/atomic_write.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"

using namespace dofkit;
namespace fs = std::filesystem;

namespace {

// Scratch folders: the IO tests' helper (removed with its contents at the end of a test).
using Dir = dofkit::test::ScratchDir;

void put(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }
std::string get(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

Image noise(int w, int h) {
  Image img(w, h, 4, 1.0f);
  unsigned s = 12345;
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < img.plane_size(); ++i) {
      s = s * 1664525u + 1013904223u;
      img.plane(c)[i] = static_cast<float>(s >> 8) / 16777216.0f;  // incompressible
    }
  return img;
}

// Runs this test binary again as a fresh process (fork + exec: forking the multi-threaded
// test process itself could deadlock in the OpenEXR/TBB thread pools) running only
// SafeOutputChild.Run with DOFKIT_ROBUST_CHILD=<job>:<folder>; returns its wait status.
int run_child(const std::string& job, const std::string& folder) {
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setenv("DOFKIT_ROBUST_CHILD", (job + ":" + folder).c_str(), 1);
    const char* argv[] = {"test_robustness", "--gtest_filter=SafeOutputChild.Run", nullptr};
    ::execv("/proc/self/exe", const_cast<char* const*>(argv));
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return status;
}

}  // namespace

// The child side of run_child(); skipped in a normal run.
TEST(SafeOutputChild, Run) {
  const char* env = std::getenv("DOFKIT_ROBUST_CHILD");
  if (!env) GTEST_SKIP() << "only runs as a child of the SafeOutput tests";
  const std::string arg = env, job = arg.substr(0, arg.find(':')), dir = arg.substr(arg.find(':') + 1);
  if (job == "fsize") {
    ::signal(SIGXFSZ, SIG_IGN);  // get EFBIG from write(2) instead of being killed
    rlimit lim{4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &lim);
    try {
      io::write_image(dir + "/out.exr", noise(128, 128));  // ~256 KB
      ::_exit(10);                                         // unexpectedly succeeded
    } catch (const Error& e) {
      std::fprintf(stderr, "child: %s\n", e.what());
      ::_exit(e.kind() == ErrorKind::bad_input ? 20 : 21);
    } catch (...) {
      ::_exit(22);
    }
  }
  if (job == "term" || job == "int" || job == "hup") {
    // A terminating signal in the middle of writing, with the CLI's handlers installed.
    io::install_signal_cleanup();
    const int sig = job == "term" ? SIGTERM : job == "int" ? SIGINT : SIGHUP;
    io::write_atomically(dir + "/out.png", [&](const std::string& temp) {
      io::encode_image(temp, dir + "/out.png", noise(64, 64));
      ::raise(sig);
    });
    ::_exit(31);  // the signal did not end the process
  }
  if (job == "kill") {
    io::write_atomically(dir + "/out.png", [&](const std::string& temp) {
      io::encode_image(temp, dir + "/out.png", noise(64, 64));
      std::ofstream(temp, std::ios::binary | std::ios::app) << "partial";
      ::raise(SIGKILL);
    });
  }
  ::_exit(30);
}

// The writer runs out of room (RLIMIT_FSIZE: writes past 4 KiB fail with EFBIG, as on a full
// disk): write_image reports a bad-input error, the old file is intact and no temporary stays.
TEST(SafeOutput, FileSizeLimitDuringWriteKeepsPreviousFile) {
  Dir dir;
  put(dir / "out.exr", "previous result");
  const int status = run_child("fsize", dir.path().string());
  ASSERT_TRUE(WIFEXITED(status)) << "child died with signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 20) << "10: write succeeded, 21: wrong error kind, 22: not a dofkit::Error";
  EXPECT_EQ(get(dir / "out.exr"), "previous result");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.exr"});
}

// The process is killed (SIGKILL: no destructor, no cleanup) in the middle of writing the
// temporary file: the target keeps its previous content. The orphaned temporary is hidden
// (leading dot) and never has the target's name.
TEST(SafeOutput, KilledMidWriteKeepsPreviousFile) {
  Dir dir;
  put(dir / "out.png", "previous result");
  const int status = run_child("kill", dir.path().string());
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(WTERMSIG(status), SIGKILL);
  EXPECT_EQ(get(dir / "out.png"), "previous result");
  for (const auto& name : dir.entries())
    if (name != "out.png") EXPECT_EQ(name[0], '.') << "orphaned temporary is not hidden: " << name;
}

// Several outputs of one run: the second fails, so neither target is touched.
TEST(SafeOutput, OutputSetCommitsNothingWhenOneWriteFails) {
  Dir dir;
  put(dir / "a.exr", "old a");
  put(dir / "b.png", "old b");
  {
    io::OutputSet set;
    set.add(dir / "a.exr", [&](const std::string& t) { io::encode_image(t, dir / "a.exr", noise(8, 8)); });
    Image five(4, 4, 5, 0.5f);  // not encodable as PNG
    EXPECT_THROW(set.add(dir / "b.png", [&](const std::string& t) { io::encode_image(t, dir / "b.png", five); }),
                 Error);
  }
  EXPECT_EQ(get(dir / "a.exr"), "old a");
  EXPECT_EQ(get(dir / "b.png"), "old b");
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"a.exr", "b.png"}));
}

// An exception thrown by the caller's writer (any failure, not only the encoder's) leaves the
// target untouched and removes the temporary.
TEST(SafeOutput, WriterExceptionLeavesNoTrace) {
  Dir dir;
  put(dir / "out.exr", "previous result");
  EXPECT_THROW(io::write_atomically(dir / "out.exr",
                                    [&](const std::string& temp) {
                                      put(temp, "half of a file");
                                      throw_internal("injected failure");
                                    }),
               Error);
  EXPECT_EQ(get(dir / "out.exr"), "previous result");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.exr"});
}

// A folder where the file should go is refused, and the folder is left as it was.
TEST(SafeOutput, TargetThatIsAFolderIsRefused) {
  Dir dir;
  fs::create_directories(dir / "out.exr");
  put(dir / "out.exr/inside", "x");
  try {
    io::write_image(dir / "out.exr", noise(4, 4));
    FAIL() << "wrote over a folder";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::bad_input) << e.what();
    EXPECT_NE(std::string(e.what()).find("folder"), std::string::npos) << e.what();
  }
  EXPECT_EQ(get(dir / "out.exr/inside"), "x");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.exr"});
}

// SIGTERM, SIGINT or SIGHUP while a file is written (issue 37, finding 8: the temporary file,
// up to 133 MB, stayed next to the target): the handler removes it and the process dies of
// the same signal, so a shell reports 128 + signal; the target keeps its content.
TEST(SafeOutput, TerminatingSignalsRemoveTheTemporary) {
  for (const auto& [job, sig] : {std::pair<const char*, int>{"term", SIGTERM}, {"int", SIGINT}, {"hup", SIGHUP}}) {
    SCOPED_TRACE(job);
    Dir dir;
    put(dir / "out.png", "previous result");
    const int status = run_child(job, dir.path().string());
    ASSERT_TRUE(WIFSIGNALED(status)) << "exit " << WEXITSTATUS(status);
    EXPECT_EQ(WTERMSIG(status), sig);
    EXPECT_EQ(get(dir / "out.png"), "previous result");
    EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.png"}) << "a temporary file was left behind";
  }
}

// A temporary orphaned by SIGKILL (nothing can remove it then) is removed by the next write
// of this user to the same folder, because the process its name records no longer exists.
// Another process's live temporary and a file that only looks like one are left alone.
TEST(SafeOutput, NextWriteRemovesTemporariesOfDeadProcesses) {
  Dir dir;
  put(dir / "out.png", "previous result");
  const int status = run_child("kill", dir.path().string());
  ASSERT_TRUE(WIFSIGNALED(status));
  std::vector<std::string> orphans;
  for (const auto& name : dir.entries())
    if (name.find(".dofkit-tmp-") != std::string::npos) orphans.push_back(name);
  ASSERT_EQ(orphans.size(), 1u) << "the killed write should leave its temporary";
  // A live process's temporary (this test's parent shell: pid 1 always exists) and a user file.
  put(dir / ".x.dofkit-tmp-1-abcdefghijklmnop.png", "live");
  put(dir / "notes.dofkit-tmp-1-x.txt", "not hidden: not ours");
  io::write_image(dir / "other.exr", noise(4, 4));
  const std::vector<std::string> left = dir.entries();
  EXPECT_EQ(std::count(left.begin(), left.end(), orphans[0]), 0) << "the orphan is still there";
  EXPECT_EQ(std::count(left.begin(), left.end(), ".x.dofkit-tmp-1-abcdefghijklmnop.png"), 1);
  EXPECT_EQ(std::count(left.begin(), left.end(), "notes.dofkit-tmp-1-x.txt"), 1);
  EXPECT_EQ(get(dir / "out.png"), "previous result");
}

// The temporary's name: hidden, recognisable, short (a 255-byte target name still has one),
// and different every time.
TEST(SafeOutput, TemporaryNamesAreShortAndUnpredictable) {
  Dir dir;
  const std::string target = dir / (std::string(251, 'n') + ".exr");
  std::vector<std::string> seen;
  for (int i = 0; i < 3; ++i) {
    io::AtomicFile f(target);
    const std::string name = fs::path(f.temp_path()).filename().string();
    EXPECT_EQ(name[0], '.');
    EXPECT_NE(name.find(".dofkit-tmp-" + std::to_string(::getpid()) + "-"), std::string::npos) << name;
    EXPECT_LE(name.size(), 88u) << name;
    EXPECT_EQ(fs::path(name).extension(), ".exr");
    EXPECT_EQ(std::count(seen.begin(), seen.end(), name), 0) << name;
    seen.push_back(name);
  }
  EXPECT_TRUE(dir.entries().empty()) << "an uncommitted AtomicFile leaves nothing";
}
