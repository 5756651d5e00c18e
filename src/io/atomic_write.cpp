// Temporary-file-and-rename output (see atomic_write.hpp).
#include "io/atomic_write.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>

#include "dofkit/error.hpp"

namespace fs = std::filesystem;

namespace dofkit::io {

namespace {

std::string errno_text(int err) { return std::strerror(err); }

// A name nobody else is using: pid + process-wide counter + random bits. Creation uses
// O_EXCL, so a clash is detected rather than clobbering another file; we then retry.
std::string temp_name_for(const fs::path& target, int attempt) {
  static std::atomic<unsigned> counter{0};
  static thread_local std::mt19937 rng{std::random_device{}()};
  const std::string ext = target.extension().string();
  const std::string stem = target.stem().string();
  char tag[64];
  std::snprintf(tag, sizeof tag, ".dofkit-tmp-%ld-%u-%08x-%d", static_cast<long>(::getpid()), counter.fetch_add(1),
                static_cast<unsigned>(rng()), attempt);
  return (target.parent_path() / ("." + stem + tag + ext)).string();
}

}  // namespace

AtomicFile::AtomicFile(std::string target) : target_(std::move(target)) {
  if (target_.empty()) throw_usage("output path is empty");
  const fs::path t(target_);
  const fs::path dir = t.parent_path().empty() ? fs::path(".") : t.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw_bad_input(target_ + ": cannot write: folder " + dir.string() + " does not exist");
  if (fs::is_directory(t, ec)) throw_bad_input(target_ + ": cannot write: it is a folder");
  if (t.filename().empty()) throw_bad_input(target_ + ": cannot write: no file name");
  for (int attempt = 0; attempt < 16; ++attempt) {
    std::string candidate = temp_name_for(t.parent_path().empty() ? fs::path(".") / t.filename() : t, attempt);
    // 0666 & ~umask: the final file gets the permissions a plain open() would give it.
    const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) {
      ::close(fd);
      temp_ = std::move(candidate);
      return;
    }
    if (errno != EEXIST) throw_bad_input(target_ + ": cannot write in " + dir.string() + ": " + errno_text(errno));
  }
  throw_bad_input(target_ + ": cannot create a temporary file in " + dir.string());
}

AtomicFile::~AtomicFile() {
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicFile::commit() {
  if (committed_) return;
  // Flush the data before the rename so a crash cannot leave the new name pointing at an
  // empty file (ext4 and others may reorder the data and the rename otherwise).
  const int fd = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
  if (std::rename(temp_.c_str(), target_.c_str()) != 0) {
    const int err = errno;
    ::unlink(temp_.c_str());
    temp_.clear();
    throw_bad_input(target_ + ": cannot write: " + errno_text(err));
  }
  committed_ = true;
}

void OutputSet::add(const std::string& target, const std::function<void(const std::string&)>& write) {
  auto file = std::make_unique<AtomicFile>(target);
  write(file->temp_path());
  files_.push_back(std::move(file));
}

void OutputSet::commit() {
  for (auto& f : files_) f->commit();
}

void write_atomically(const std::string& target, const std::function<void(const std::string&)>& write) {
  AtomicFile file(target);
  write(file.temp_path());
  file.commit();
}

}  // namespace dofkit::io
