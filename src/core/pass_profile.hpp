// Wall time per named pass, for `dofkit bench --passes`: where a frame's time goes, measured
// by the code that runs, not by instrumentation added for one measurement and thrown away.
//
// A method's orchestrating code (the thread that calls render(), never a parallel_for body)
// opens a PassScope around each pass. While profiling is off a scope costs one relaxed atomic
// load. While it is on, each scope adds its wall time to its path — the names of the open
// scopes joined by '/', e.g. "mcguire/horizontal" — so nested scopes are included in their
// parents' times.
#pragma once
#include <chrono>
#include <string>
#include <vector>

namespace dofkit::core {

/// Starts (true) or stops recording; starting also clears what was recorded.
void set_pass_profiling(bool on);

struct PassTime {
  std::string path;  // e.g. "sterna/gather"
  double ms = 0;     // summed wall time of the scopes with this path since the last take
  int calls = 0;     // how many scopes with this path closed
};

/// What was recorded since the last call (paths in the order their first scope opened), and
/// clears it.
std::vector<PassTime> take_pass_profile();

/// Times the code from here to the end of the enclosing block as pass `name` (a literal or
/// another string that outlives the scope).
class PassScope {
 public:
  explicit PassScope(const char* name);
  ~PassScope();
  PassScope(const PassScope&) = delete;
  PassScope& operator=(const PassScope&) = delete;

 private:
  bool on_;
  std::string path_;
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace dofkit::core
