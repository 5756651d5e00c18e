#include "core/pass_profile.hpp"

#include <atomic>
#include <mutex>

namespace dofkit::core {

namespace {

std::atomic<bool> g_on{false};

struct Record {
  std::mutex m;
  std::vector<PassTime> times;  // in first-open order
};
Record& record() {
  static Record r;
  return r;
}

// The open scopes of this thread, outermost first.
thread_local std::vector<const char*> t_open;

// The entry of `path` in the record, created (with no time yet) where new; r.m held.
PassTime& entry(Record& r, const std::string& path) {
  for (PassTime& t : r.times)
    if (t.path == path) return t;
  r.times.push_back({path, 0.0, 0});
  return r.times.back();
}

}  // namespace

void set_pass_profiling(bool on) {
  if (on) take_pass_profile();
  g_on.store(on, std::memory_order_relaxed);
}

std::vector<PassTime> take_pass_profile() {
  Record& r = record();
  std::lock_guard<std::mutex> lock(r.m);
  std::vector<PassTime> out;
  out.swap(r.times);
  return out;
}

PassScope::PassScope(const char* name) : on_(g_on.load(std::memory_order_relaxed)) {
  if (!on_) return;
  t_open.push_back(name);
  for (const char* n : t_open) {
    if (!path_.empty()) path_.push_back('/');
    path_.append(n);
  }
  {
    Record& r = record();
    std::lock_guard<std::mutex> lock(r.m);
    entry(r, path_);  // the path's place in the order: when its first scope opened
  }
  t0_ = std::chrono::steady_clock::now();
}

PassScope::~PassScope() {
  if (!on_) return;
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0_).count();
  t_open.pop_back();
  Record& r = record();
  std::lock_guard<std::mutex> lock(r.m);
  PassTime& t = entry(r, path_);
  t.ms += ms;
  t.calls += 1;
}

}  // namespace dofkit::core
