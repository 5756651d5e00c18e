// Temporary-file-and-rename output (see atomic_write.hpp).
#include "io/atomic_write.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <random>
#include <set>

#include "dofkit/error.hpp"

namespace fs = std::filesystem;

namespace dofkit::io {

namespace {

std::string errno_text(int err) { return std::strerror(err); }

constexpr const char* kTag = ".dofkit-tmp-";

// --- the signal handler's list of live temporaries -----------------------------------------
// Fixed slots the handler can read without locks or allocation: a writer claims a free slot
// (0 → 1), copies the path and publishes it (→ 2); the handler unlinks every published path.
constexpr int kSlots = 64;
constexpr std::size_t kSlotPath = 4096;
struct Slot {
  std::atomic<int> state{0};  // 0 free, 1 being filled, 2 live
  char path[kSlotPath];
};
Slot g_slots[kSlots];

int claim_slot(const std::string& path) {
  if (path.size() >= kSlotPath) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (g_slots[i].state.compare_exchange_strong(expected, 1)) {
      std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
      g_slots[i].state.store(2);
      return i;
    }
  }
  return -1;  // more than 64 at once: not cleaned on a signal (the next write removes it)
}

void release_slot(int i) {
  if (i >= 0) g_slots[i].state.store(0);
}

extern "C" void on_terminating_signal(int sig) {
  for (Slot& s : g_slots)
    if (s.state.load() == 2) ::unlink(s.path);
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

// --- names -------------------------------------------------------------------------------

// At most `n` bytes of `s`, not cutting a UTF-8 sequence.
std::string utf8_prefix(const std::string& s, std::size_t n) {
  if (s.size() <= n) return s;
  while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xc0) == 0x80) --n;
  return s.substr(0, n);
}

// A hidden name nobody can predict: part of the target's stem (to recognise it), the tag,
// this process's id (for the stale-file cleanup) and 16 random letters (80 bits); the
// target's extension, if it is short, so format-by-extension libraries recognise the file.
std::string temp_name_for(const fs::path& target) {
  static const char kLetters[] = "abcdefghijklmnopqrstuvwxyz234567";
  static thread_local std::mt19937_64 rng{[] {
    std::random_device rd;
    return (static_cast<std::uint64_t>(rd()) << 32) ^ rd() ^ static_cast<std::uint64_t>(::getpid());
  }()};
  std::string ext = target.extension().string();
  if (ext.size() > 16) ext.clear();
  std::string name(1, '.');
  name += utf8_prefix(target.stem().string(), 32);
  name += kTag;
  name += std::to_string(::getpid());
  name += '-';
  for (int i = 0; i < 16; ++i) name += kLetters[rng() % 32];
  return name + ext;
}

// The process id a temporary's name records, or -1 if the name is not one of ours.
long temp_owner_pid(const char* name) {
  if (name[0] != '.') return -1;
  const char* at = std::strstr(name, kTag);
  if (!at) return -1;
  at += std::strlen(kTag);
  long pid = 0;
  int digits = 0;
  for (; *at >= '0' && *at <= '9' && digits < 10; ++at, ++digits) pid = pid * 10 + (*at - '0');
  return digits > 0 && *at == '-' ? pid : -1;
}

// Removes, once per folder and process, the temporaries of processes that no longer exist
// (killed mid-write by SIGKILL or a crash), if they are regular files of this user.
void remove_stale_temporaries(const std::string& dir) {
  static std::mutex mu;
  static std::set<std::string> done;
  {
    const std::lock_guard<std::mutex> lock(mu);
    if (!done.insert(dir).second) return;
  }
  DIR* d = ::opendir(dir.c_str());
  if (!d) return;
  const int dfd = ::dirfd(d);
  while (const dirent* e = ::readdir(d)) {
    const long pid = temp_owner_pid(e->d_name);
    if (pid <= 0 || pid == ::getpid()) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to ask)
    struct stat st {};
    if (::fstatat(dfd, e->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode) || st.st_uid != ::geteuid())
      continue;
    ::unlinkat(dfd, e->d_name, 0);
  }
  ::closedir(d);
}

// Whether the file's permission bits let this user write it: the owner's, the group's or
// the others' write bit, whichever class the user is in. Deliberately without root's
// override: a read-only file, or another user's private one, is not replaced even by root.
bool permits_writing(const struct stat& st) {
  if (st.st_uid == ::geteuid()) return (st.st_mode & S_IWUSR) != 0;
  bool in_group = st.st_gid == ::getegid();
  if (!in_group) {
    gid_t groups[256];
    const int n = ::getgroups(256, groups);
    for (int i = 0; i < n && !in_group; ++i) in_group = groups[i] == st.st_gid;
  }
  if (in_group) return (st.st_mode & S_IWGRP) != 0;
  return (st.st_mode & S_IWOTH) != 0;
}

const char* kind_of(mode_t mode) {
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a named pipe (fifo)";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

void install_signal_cleanup() {
  struct sigaction sa {};
  sa.sa_handler = on_terminating_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction old {};
    // A signal the parent set to be ignored (nohup) stays ignored.
    if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    ::sigaction(sig, &sa, nullptr);
  }
}

AtomicFile::AtomicFile(std::string target) : target_(std::move(target)) {
  if (target_.empty()) throw_usage("output path is empty");
  const fs::path t(target_);
  const fs::path dir = t.parent_path().empty() ? fs::path(".") : t.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw_bad_input(target_ + ": cannot write: folder " + dir.string() + " does not exist");
  if (t.filename().empty()) throw_bad_input(target_ + ": cannot write: no file name");
  // What is there now: nothing, a symlink (replaced), or a regular file we may write.
  struct stat st {};
  if (::lstat(target_.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) throw_bad_input(target_ + ": cannot write: it is a folder");
    if (!S_ISREG(st.st_mode) && !S_ISLNK(st.st_mode))
      throw_bad_input(target_ + ": cannot write: it is " + kind_of(st.st_mode) + ", not a regular file; refusing to " +
                      "replace it");
    if (S_ISREG(st.st_mode)) {
      if (!permits_writing(st) || ::access(target_.c_str(), W_OK) != 0) {
        char mode[8];
        std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
        throw_bad_input(target_ + ": cannot write: the existing file is not writable by you (mode " + mode +
                        "); refusing to replace it");
      }
      had_target_ = true;
      mode_ = st.st_mode & 0777;  // never a set-id bit on a file we wrote
      uid_ = st.st_uid;
      gid_ = st.st_gid;
    }
  } else if (errno != ENOENT) {
    throw_bad_input(target_ + ": cannot write: " + errno_text(errno));
  }
  remove_stale_temporaries(dir.string());
  for (int attempt = 0; attempt < 16; ++attempt) {
    std::string candidate = (dir / temp_name_for(t)).string();
    // Published to the signal handler before the file exists: claimed after open(), a signal
    // in between left the temporary behind (HostileCli.Finding8 signals the moment the file
    // appears). Unlinking a name not yet created, or already renamed, is harmless.
    const int slot = claim_slot(candidate);
    // 0666 & ~umask: a new file gets the permissions a plain open() would give it.
    const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd >= 0) {
      fd_ = fd;
      temp_ = std::move(candidate);
      slot_ = slot;
      return;
    }
    const int err = errno;
    release_slot(slot);
    if (err != EEXIST) throw_bad_input(target_ + ": cannot write in " + dir.string() + ": " + errno_text(err));
  }
  throw_bad_input(target_ + ": cannot create a temporary file in " + dir.string());
}

AtomicFile::~AtomicFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
  release_slot(slot_);
}

void AtomicFile::commit() {
  if (committed_) return;
  const auto fail = [&](int err) {
    ::unlink(temp_.c_str());
    temp_.clear();
    throw_bad_input(target_ + ": cannot write: " + errno_text(err));
  };
  if (had_target_) {
    // The replaced file's permissions; its owner and group where the system allows (root,
    // or a group this user is in).
    if (::fchmod(fd_, mode_) != 0) fail(errno);
    if (::fchown(fd_, uid_, gid_) != 0) (void)::fchown(fd_, static_cast<uid_t>(-1), gid_);
  }
  // Flush the data before the rename so a crash cannot leave the new name pointing at an
  // empty file (ext4 and others may reorder the data and the rename otherwise).
  ::fsync(fd_);
  ::close(fd_);
  fd_ = -1;
  // What was checked when the temporary was made may have changed since: never replace
  // anything but a regular file or a symlink.
  struct stat st {};
  if (::lstat(target_.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISLNK(st.st_mode)) {
    ::unlink(temp_.c_str());
    temp_.clear();
    throw_bad_input(target_ + ": cannot write: it is now " +
                    (S_ISDIR(st.st_mode) ? std::string("a folder") : std::string(kind_of(st.st_mode))) +
                    "; refusing to replace it");
  }
  if (std::rename(temp_.c_str(), target_.c_str()) != 0) fail(errno);
  committed_ = true;
  release_slot(slot_);
  slot_ = -1;
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
