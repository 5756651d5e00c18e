// Running the built `dofkit` from a test: its exit code, stderr and stdout (the CLI tests of
// the screen-space effects).
#pragma once
#include <OpenImageIO/imageio.h>

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dofkit/image.hpp"
#include "io/io_test_util.hpp"

namespace dofkit::test {

struct CliRun {
  int code;
  std::string err, out;
};

/// Runs `dofkit ARGS` with stderr and stdout captured in files of `dir` (removed afterwards).
inline CliRun dofkit_run(const ScratchDir& dir, const std::string& args) {
  const std::string err = dir / ".stderr", out = dir / ".stdout";
  const std::string cmd = std::string(DOFKIT_BINARY_DIR) + "/dofkit " + args + " 2>" + err + " >" + out;
  const int status = std::system(cmd.c_str());
  const auto slurp = [](const std::string& p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  };
  CliRun r{WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(err), slurp(out)};
  std::filesystem::remove(err);
  std::filesystem::remove(out);
  return r;
}

/// The R, G, B planes of an RGBA image (what read_color returns).
inline Image rgb_planes(const Image& im) {
  Image o(im.width(), im.height(), 3);
  std::copy(im.data().begin(), im.data().begin() + 3 * im.plane_size(), o.data().begin());
  return o;
}

/// The channel names of an image file (empty if it cannot be opened).
inline std::vector<std::string> channels_of(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) return {};
  return in->spec().channelnames;
}

}  // namespace dofkit::test
