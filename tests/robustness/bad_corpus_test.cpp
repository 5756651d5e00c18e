// The hand-made bad-input corpus (tests/data/bad/, written by make_bad_corpus.py): every file
// must give exactly the error class its manifest line names, with a one-line message that
// names the file and contains the expected text — never a crash, and never an allocation of
// what a huge header declares (the size checks run on the header; ASan/LSan in
// scripts/sanitize would also report a multi-GB allocation attempt).
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <fstream>
#include <sstream>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/layers_io.hpp"

using namespace dofkit;
namespace fs = std::filesystem;

namespace {

const fs::path kBad = fs::path(DOFKIT_SOURCE_DIR) / "tests" / "data" / "bad";

struct Case {
  std::string file, op, depth, kind, substring, why;
  std::string todo;  // known, reported bug: the expectation is kept but does not fail yet
  int line = 0;
};

std::vector<Case> read_manifest() {
  std::ifstream in(kBad / "manifest.tsv");
  std::vector<Case> cases;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, '\t')) f.push_back(field);
    while (f.size() < 7) f.emplace_back();
    cases.push_back({f[0], f[1], f[2], f[3], f[4], f[5], f[6], n});
  }
  return cases;
}

const char* kind_name(ErrorKind k) {
  return k == ErrorKind::usage ? "usage" : k == ErrorKind::bad_input ? "bad_input" : "internal";
}

}  // namespace

TEST(BadCorpus, ManifestIsComplete) {
  const auto cases = read_manifest();
  ASSERT_GE(cases.size(), 20u);
  // Every file in the folder (except the generator and manifest) is exercised.
  for (const auto& e : fs::directory_iterator(kBad)) {
    const std::string name = e.path().filename().string();
    if (name == "manifest.tsv" || name == "make_bad_corpus.py") continue;
    const bool used =
        std::any_of(cases.begin(), cases.end(), [&](const Case& c) { return c.file == name || c.depth == name; });
    EXPECT_TRUE(used) << name << " is not in manifest.tsv";
  }
}

TEST(BadCorpus, EachFileGivesItsErrorClassAndMessage) {
  for (const Case& c : read_manifest()) {
    SCOPED_TRACE("manifest.tsv line " + std::to_string(c.line) + ": " + c.file + " " + c.op + " (" + c.why + ")");
    const std::string path = (kBad / c.file).string();
    const std::string depth = c.depth == "-" || c.depth.empty() ? "" : (kBad / c.depth).string();
    std::string message;
    ErrorKind kind{};
    bool threw = false;
    try {
      if (c.op == "color") {
        const Image img = io::read_color(path);
        EXPECT_EQ(img.channels(), 4);
      } else if (c.op == "depth") {
        io::read_depth(path, {});
      } else if (c.op == "frame") {
        io::load_frame(path, depth, {});
      } else if (c.op == "mask") {
        io::read_mask(path);
      } else if (c.op == "layers") {
        Frame frame;
        io::read_layers(path, frame, 8);
      } else {
        FAIL() << "unknown op " << c.op;
      }
    } catch (const Error& e) {
      threw = true;
      kind = e.kind();
      message = e.what();
    }
    // Collect every broken expectation of this line.
    std::vector<std::string> wrong;
    if (c.kind == "ok") {
      if (threw) wrong.push_back("unexpected error: " + message);
    } else if (!threw) {
      wrong.push_back("no error (expected " + c.kind + ")");
    } else {
      if (kind_name(kind) != c.kind)
        wrong.push_back(std::string("error kind ") + kind_name(kind) + ", expected " + c.kind);
      if (message.find(c.substring) == std::string::npos) wrong.push_back("message lacks '" + c.substring + "'");
      // The file at fault is named: the depth file for a frame with one, else the file read.
      const std::string& named = depth.empty() ? c.file : c.depth;
      if (message.find(named) == std::string::npos) wrong.push_back("message does not name " + named);
      if (message.find('\n') != std::string::npos) wrong.push_back("message spans lines");
    }
    if (!c.todo.empty()) {
      // A reported bug: print its state instead of failing the suite, and say so when it is fixed.
      std::cout << "[ TODO ] " << c.file << ": " << c.todo << " -- "
                << (wrong.empty() ? "now behaves as expected: remove the TODO column" : "still " + wrong[0]) << "\n";
      continue;
    }
    for (const auto& w : wrong) ADD_FAILURE() << w << "; message: " << message;
  }
}
