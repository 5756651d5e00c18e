// Every run-time dispatched plain C++ function goes through DOFKIT_CLONES (core/clones.hpp),
// never the raw target_clones attribute: clang 14, the fuzz build's compiler, silently turns
// a multiversioned function that has an earlier declaration into one AVX-512 body, which dies
// of SIGILL on machines without AVX-512 (clones.hpp explains). This scans the sources.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace {

namespace fs = std::filesystem;

TEST(Clones, NoRawTargetClonesAttributeOutsideTheMacro) {
  const fs::path src = fs::path(DOFKIT_SOURCE_DIR) / "src";
  ASSERT_TRUE(fs::is_directory(src)) << src;
  const std::string needle = std::string("target_clones") + "(";
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(src)) {
    const std::string ext = e.path().extension().string();
    if (!e.is_regular_file() || (ext != ".cpp" && ext != ".hpp" && ext != ".h")) continue;
    if (e.path().filename() == "clones.hpp") continue;  // the one definition
    ++files;
    std::ifstream in(e.path());
    std::string line;
    int n = 0;
    while (std::getline(in, line)) {
      ++n;
      const auto at = line.find(needle);
      const auto comment = line.find("//");
      if (at != std::string::npos && (comment == std::string::npos || comment > at))
        ADD_FAILURE() << e.path().string() << ":" << n << ": raw target_clones; use DOFKIT_CLONES: " << line;
    }
  }
  EXPECT_GT(files, 50);  // the scan saw the sources
}

}  // namespace
