// What every fuzz target shares: a private temporary file for the input, the rule for what
// counts as a bug, and the setup that keeps a run cheap (one OpenImageIO thread, a 64x64 px
// pixel budget: every header declaring more must be refused by dofkit before it allocates).
#pragma once
#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "dofkit/error.hpp"
#include "dofkit/render.hpp"
#include "io/image_io.hpp"

namespace dofkit::fuzz {

constexpr long long kFuzzMaxPixels = 64 * 64;

[[noreturn]] inline void bug(const std::string& what) {
  std::fprintf(stderr, "FUZZ BUG: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

/// A path private to this process (the fuzzer may run several), with `ext`.
inline std::string temp_path(const std::string& ext) {
  static const std::string base = [] {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir && *dir ? dir : "/tmp") + "/dofkit-fuzz-" + std::to_string(::getpid());
  }();
  return base + ext;
}

inline bool write_file(const std::string& path, const std::uint8_t* data, std::size_t n) {
  std::FILE* fp = std::fopen(path.c_str(), "wb");
  if (!fp) return false;
  const bool ok = std::fwrite(data, 1, n, fp) == n;
  return std::fclose(fp) == 0 && ok;
}

inline void setup() {
  OIIO::attribute("threads", 1);
  OIIO::attribute("exr_threads", 1);
  io::set_pixel_budget(kFuzzMaxPixels);
}

/// Runs `fn`; a dofkit::Error of kind usage or bad_input is an acceptable end, anything else
/// (an internal error, another exception type) a bug. Returns whether `fn` finished.
template <typename F>
bool expect_ok_or_refused(const char* what, F&& fn) {
  try {
    fn();
    return true;
  } catch (const Error& e) {
    if (e.kind() == ErrorKind::internal) bug(std::string(what) + ": internal error: " + e.what());
    const std::string m = e.what();
    if (m.find('\n') != std::string::npos) bug(std::string(what) + ": a message of more than one line: " + m);
    return false;
  } catch (const std::exception& e) {
    bug(std::string(what) + ": exception that is not a dofkit::Error: " + e.what());
  }
}

/// A finished render must have the frame's size, 4 planes and finite samples.
inline void check_result(const std::string& method, const RenderResult& r, int w, int h) {
  if (r.image.width() != w || r.image.height() != h || r.image.channels() != 4)
    bug("method " + method + " returned an image of the wrong size");
  for (float v : r.image.data())
    if (!std::isfinite(v)) bug("method " + method + " returned a non-finite sample");
}

}  // namespace dofkit::fuzz
