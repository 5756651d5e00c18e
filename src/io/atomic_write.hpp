// Atomic file output: a result appears under its final name complete, or not at all.
//
// A writer first creates a temporary file in the *same folder* as the target (so the final
// rename(2) never crosses a file system and is atomic), writes into it, flushes it to disk and
// renames it over the target. If anything fails before commit() — an exception, a crash of
// the encoder, the process being killed — the target is untouched: it neither appears
// half-written nor loses its previous content. Destroying an uncommitted AtomicFile removes
// its temporary file.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace dofkit::io {

/// One output file written through a temporary sibling.
class AtomicFile {
 public:
  /// Creates an empty temporary file next to `target` (same folder, same extension so
  /// format-by-extension libraries still recognise it, hidden name). Throws Error(bad_input)
  /// naming `target` if its folder does not exist or is not writable, or if `target` is a
  /// folder.
  explicit AtomicFile(std::string target);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& target() const noexcept { return target_; }
  /// Where to write the content (already exists, empty, mode 0666 minus umask).
  const std::string& temp_path() const noexcept { return temp_; }
  /// fsyncs the temporary file and renames it onto the target. Throws Error(bad_input)
  /// naming the target on failure (the temporary file is then removed).
  void commit();
  bool committed() const noexcept { return committed_; }

 private:
  std::string target_;
  std::string temp_;
  bool committed_ = false;
};

/// Several outputs of one run that should appear together: each is written to its own
/// temporary file first, and only when every write has succeeded are they renamed into
/// place (in the order they were added). If a write fails, no target is touched. (A rename
/// failing half-way through commit() — e.g. the disk vanishing — can still leave the earlier
/// targets renamed; each target itself is always complete.)
class OutputSet {
 public:
  /// Registers `target` and runs `write(temp_path)`; an exception from `write` propagates
  /// and nothing is committed.
  void add(const std::string& target, const std::function<void(const std::string& temp_path)>& write);
  /// Renames every temporary file onto its target.
  void commit();

 private:
  std::vector<std::unique_ptr<AtomicFile>> files_;
};

/// Convenience: writes one file atomically.
void write_atomically(const std::string& target, const std::function<void(const std::string& temp_path)>& write);

}  // namespace dofkit::io
