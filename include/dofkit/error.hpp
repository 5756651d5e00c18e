// dofkit — typed errors.
#pragma once
#include <stdexcept>
#include <string>

namespace dofkit {

/// What went wrong, and therefore which exit code the CLI uses.
enum class ErrorKind {
  usage,      ///< bad parameter or flag (CLI exit code 2)
  bad_input,  ///< unreadable, corrupt or inconsistent input data (CLI exit code 3)
  internal,   ///< a bug or resource failure inside dofkit (CLI exit code 1)
};

/// `text` with every control character written as an escape (a newline as \n, others as
/// \xHH): a path or a decoder's message that holds one still gives one line.
inline std::string one_line(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char ch : text) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c >= 0x20 && c != 0x7f) {
      out += ch;
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else {
      static const char hex[] = "0123456789abcdef";
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

/// The only exception type dofkit throws. `what()` is one line that names the file,
/// channel, pixel or parameter concerned and the problem (control characters escaped).
class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(one_line(message)), kind_(kind) {}
  ErrorKind kind() const noexcept { return kind_; }
  /// CLI exit code for this error: usage 2, bad input 3, internal 1.
  int exit_code() const noexcept { return kind_ == ErrorKind::usage ? 2 : kind_ == ErrorKind::bad_input ? 3 : 1; }

 private:
  ErrorKind kind_;
};

[[noreturn]] inline void throw_usage(const std::string& m) { throw Error(ErrorKind::usage, m); }
[[noreturn]] inline void throw_bad_input(const std::string& m) { throw Error(ErrorKind::bad_input, m); }
[[noreturn]] inline void throw_internal(const std::string& m) { throw Error(ErrorKind::internal, m); }

}  // namespace dofkit
