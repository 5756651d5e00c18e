// The output file of the direct writers (png_direct, tiff_direct): created for writing,
// written in pieces, then flushed and closed, every failure an Error(bad_input) that names the
// display path, the step and the system's reason.
#pragma once
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include "dofkit/error.hpp"

namespace dofkit::io {

class OutFile {
 public:
  OutFile(const std::string& file, std::string display_path) : display_(std::move(display_path)) {
    errno = 0;
    f_ = std::fopen(file.c_str(), "wb");
    if (!f_) fail("cannot create the file");
  }
  ~OutFile() {
    if (f_) std::fclose(f_);  // after an error: the caller's temporary file is removed
  }
  OutFile(const OutFile&) = delete;
  OutFile& operator=(const OutFile&) = delete;

  /// Writes n bytes; `what` names them in the error.
  void write(const void* p, std::size_t n, const char* what) {
    if (n && std::fwrite(p, 1, n, f_) != n) fail(what);
  }

  /// Flushes and closes; throws if either fails (a full disk shows here).
  void close() {
    std::FILE* f = f_;
    f_ = nullptr;
    if (std::fflush(f) != 0) {
      std::fclose(f);
      fail("flush");
    }
    if (std::fclose(f) != 0) fail("close");
  }

 private:
  [[noreturn]] void fail(const char* what) const {
    throw_bad_input(display_ + ": cannot write: " + what + (errno ? std::string(": ") + std::strerror(errno) : ""));
  }
  std::FILE* f_ = nullptr;
  std::string display_;
};

}  // namespace dofkit::io
