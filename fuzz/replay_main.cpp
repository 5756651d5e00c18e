// Runs a fuzz harness without libFuzzer: every file named on the command line (folders are
// walked, in name order) goes once through LLVMFuzzerTestOneInput. The main build links each
// harness with this file and CTest replays the committed corpus with it (FuzzCorpus.<target>):
// a crash, sanitizer report or harness-detected bug (abort) fails the test. Also handy to rerun
// one reproducer under a debugger: build/replay_<target> crash-file.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
extern "C" __attribute__((weak)) int LLVMFuzzerInitialize(int* argc, char*** argv);

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  // Read every input first: a harness's initialiser may change the working directory.
  std::vector<fs::path> paths;
  for (int i = 1; i < argc; ++i) {
    const fs::path p = fs::absolute(argv[i]);
    if (fs::is_directory(p)) {
      std::vector<fs::path> in_dir;
      for (const auto& e : fs::recursive_directory_iterator(p))
        if (e.is_regular_file()) in_dir.push_back(e.path());
      std::sort(in_dir.begin(), in_dir.end());
      paths.insert(paths.end(), in_dir.begin(), in_dir.end());
    } else {
      paths.push_back(p);
    }
  }
  std::vector<std::string> inputs;
  for (const auto& p : paths) {
    std::ifstream f(p, std::ios::binary);
    if (!f) {
      std::fprintf(stderr, "replay: cannot read %s\n", p.c_str());
      return 2;
    }
    inputs.emplace_back(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  if (inputs.empty()) {
    std::fprintf(stderr, "replay: no input files (usage: %s FILE|FOLDER...)\n", argv[0]);
    return 2;
  }
  if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    std::fprintf(stderr, "replay: %s\n", paths[i].filename().c_str());
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(inputs[i].data()), inputs[i].size());
  }
  std::fprintf(stderr, "replay: %zu inputs, no bug\n", inputs.size());
  return 0;
}
