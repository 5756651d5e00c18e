// Atomic file output: a result appears under its final name complete, or not at all.
//
// A writer first creates a temporary file in the *same folder* as the target (so the final
// rename(2) never crosses a file system and is atomic), writes into it, flushes it to disk and
// renames it over the target. If anything fails before commit() — an exception, a crash of
// the encoder, the process being killed — the target is untouched: it neither appears
// half-written nor loses its previous content. Destroying an uncommitted AtomicFile removes
// its temporary file, and so does SIGINT / SIGTERM / SIGHUP once install_signal_cleanup() has
// run (the CLI does); a temporary left by a process that died otherwise (SIGKILL, a crash) is
// removed by the next write of this user to the same folder.
//
// The temporary is created with O_EXCL | O_NOFOLLOW under a name nobody can predict
// (".<up to 32 bytes of the target's stem>.dofkit-tmp-<pid>-<16 random letters><ext>", at
// most 88 bytes, so any target name the system allows has one), never through a symlink.
// An existing target must be a regular file the caller may write (a device, fifo or socket
// of that name, or a file whose permission bits do not let this user write it — even
// root — is refused rather than replaced); its permission bits
// (and, where the system lets us, its owner and group) are carried over to the new file. A
// symlink at the target's name is replaced by the new file; the file it pointed to is not
// touched.
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
  /// naming `target` if its folder does not exist or is not writable, or if `target` exists
  /// and is a folder, not a regular file, or not writable by the caller.
  explicit AtomicFile(std::string target);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& target() const noexcept { return target_; }
  /// Where to write the content (already exists, empty, mode 0666 minus umask).
  const std::string& temp_path() const noexcept { return temp_; }
  /// Gives the temporary the existing target's mode (and owner, where allowed), fsyncs it and
  /// renames it onto the target. Throws Error(bad_input) naming the target on failure (the
  /// temporary file is then removed).
  void commit();
  bool committed() const noexcept { return committed_; }

 private:
  std::string target_;
  std::string temp_;
  int fd_ = -1;    // the temporary, open for fchmod / fsync
  int slot_ = -1;  // its entry in the signal handler's list, -1 if none
  bool had_target_ = false;
  unsigned mode_ = 0;  // the existing target's permission bits
  unsigned uid_ = 0, gid_ = 0;
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

/// Installs handlers for SIGINT, SIGTERM and SIGHUP that remove every temporary file of a live
/// AtomicFile, then let the signal end the process as it would have (a shell reports the exit
/// status 128 + signal). For programs (the CLI); a library user keeps its own handlers.
void install_signal_cleanup();

/// Convenience: writes one file atomically.
void write_atomically(const std::string& target, const std::function<void(const std::string& temp_path)>& write);

}  // namespace dofkit::io
