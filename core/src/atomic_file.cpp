// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/atomic_file.h"

#include "lfi/core/error.h"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cstring>
#include <fstream>
#include <mutex>
#include <string>
#include <utility>

namespace lfi {

namespace fs = std::filesystem;

namespace {

// The process umask without changing it (umask(2) would race other threads).
mode_t currentUmask() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "Umask:") {
      std::string octal;
      status >> octal;
      return static_cast<mode_t>(std::stoul(octal, nullptr, 8));
    }
    status.ignore(1 << 16, '\n');
  }
  return 022;
}

// Flushes a directory's entries to the disk (best effort: some file systems
// cannot open or sync a directory).
void syncDirectory(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// Flushes a file's data to the disk; a failure (disk full, an I/O error on a
// network file system) means the file is not what was written: it must not
// replace the target.
void syncFile(const fs::path& file, const fs::path& target) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    fail(Errc::Io, "cannot write '{}': reopening its temporary file: {}", target.string(), std::strerror(errno));
  const int rc = ::fsync(fd), err = errno;
  ::close(fd);
  if (rc != 0 && err != EINVAL)  // (EINVAL: a file system that does not sync, such as a pipe's)
    fail(Errc::Io, "cannot write '{}': flushing it to the disk failed: {}", target.string(), std::strerror(err));
}

// The temporaries being written, for a signal that ends the process: a table
// the handler reads without allocating or locking. Paths are absolute (a later
// chdir changes nothing). (A signal while another thread reuses a slot could
// read a path half rewritten; unlink then finds no such file.)
constexpr std::size_t kTemporarySlots = 16;
struct TemporarySlot {
  std::atomic<bool> used{false};
  char path[PATH_MAX] = {};
};
std::array<TemporarySlot, kTemporarySlots> temporaries;
static_assert(std::atomic<bool>::is_always_lock_free);  // (read in a signal handler)
constexpr std::array<int, 3> kEndingSignals{SIGINT, SIGTERM, SIGHUP};
std::mutex handlersMutex;  // (guards the counts and the handlers' installation, never taken in a handler)
int liveTemporaries = 0;
std::array<bool, kEndingSignals.size()> installed{};  // our handler is in place of SIG_DFL

void removeTemporariesAndDie(int signal) {
  for (TemporarySlot& slot : temporaries)
    if (slot.used.load(std::memory_order_acquire)) ::unlink(slot.path);
  ::signal(signal, SIG_DFL);  // then the default action: the process ends as it would have
  ::raise(signal);
}

// Registers `temporary` for removal by a signal whose action is to end the
// process (signals with a handler of the program's own are left alone).
class TemporaryGuard {
 public:
  explicit TemporaryGuard(const fs::path& temporary) {
    std::error_code ec;
    const fs::path absolute = fs::absolute(temporary, ec);
    const std::string& path = ec ? temporary.native() : absolute.native();
    std::lock_guard lock(handlersMutex);
    for (TemporarySlot& s : temporaries) {
      if (path.size() >= sizeof s.path || s.used.load(std::memory_order_relaxed)) continue;
      std::memcpy(s.path, path.c_str(), path.size() + 1);
      s.used.store(true, std::memory_order_release);
      slot_ = &s;
      break;
    }
    // (Not registered, so not removed by a signal: a path of PATH_MAX or more, or kTemporarySlots writes at once.)
    if (slot_ == nullptr || liveTemporaries++ > 0) return;
    for (std::size_t i = 0; i < kEndingSignals.size(); ++i) {
      struct sigaction current {};
      ::sigaction(kEndingSignals[i], nullptr, &current);
      if (current.sa_handler != SIG_DFL) continue;
      struct sigaction ours {};
      ours.sa_handler = removeTemporariesAndDie;
      sigemptyset(&ours.sa_mask);
      ::sigaction(kEndingSignals[i], &ours, nullptr);
      installed[i] = true;
    }
  }
  ~TemporaryGuard() {
    if (slot_ == nullptr) return;
    std::lock_guard lock(handlersMutex);
    slot_->used.store(false, std::memory_order_release);
    if (--liveTemporaries > 0) return;
    for (std::size_t i = 0; i < kEndingSignals.size(); ++i) {
      if (!std::exchange(installed[i], false)) continue;
      struct sigaction current {};
      ::sigaction(kEndingSignals[i], nullptr, &current);
      if (current.sa_handler == removeTemporariesAndDie) ::signal(kEndingSignals[i], SIG_DFL);  // (not one set since)
    }
  }
  TemporaryGuard(const TemporaryGuard&) = delete;
  TemporaryGuard& operator=(const TemporaryGuard&) = delete;

 private:
  TemporarySlot* slot_ = nullptr;
};

// An open descriptor with an exclusive flock on it: a temporary's writer holds
// one for as long as it writes, and the kernel drops it when the writer ends,
// however it ends (SIGKILL included).
class LockedFd {
 public:
  // Opens `path` and takes its lock if nobody holds it; locked() says whether.
  LockedFd(const char* path, int flags) : fd_(::open(path, flags | O_CLOEXEC)) {
    if (fd_ >= 0 && ::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd_);
      fd_ = -1;
    }
  }
  // Locks `fd`, a temporary of a name of our own that nobody else holds.
  explicit LockedFd(int fd) : fd_(fd) {
    if (fd_ >= 0) ::flock(fd_, LOCK_EX);
  }
  ~LockedFd() {
    if (fd_ >= 0) ::close(fd_);
  }
  LockedFd(const LockedFd&) = delete;
  LockedFd& operator=(const LockedFd&) = delete;
  bool locked() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

// Removes the temporaries of `target` in `dir` (".<name>.tmp-XXXXXX") whose
// writer is gone: their lock can be taken. They are what a writer killed by
// SIGKILL left, which nothing could remove then; a live writer's is left alone.
void removeStaleTemporaries(const fs::path& dir, const fs::path& target) {
  const std::string prefix = "." + target.filename().string() + ".tmp-";
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() != prefix.size() + 6 || !name.starts_with(prefix)) continue;
    std::error_code typeError;
    const fs::file_type type = it->symlink_status(typeError).type();
    if (type != fs::file_type::directory && type != fs::file_type::regular) continue;
    const LockedFd lock(it->path().c_str(), type == fs::file_type::directory ? O_RDONLY | O_DIRECTORY : O_RDONLY);
    if (!lock.locked()) continue;  // being written, or not ours to open
    std::error_code ignored;
    fs::remove_all(it->path(), ignored);
  }
}

}  // namespace

fs::path resolvedTarget(const fs::path& path) {
  fs::path target = path;
  for (int links = 0;; ++links) {
    std::error_code ec;
    const fs::file_status status = fs::symlink_status(target, ec);
    if (ec && status.type() != fs::file_type::not_found)
      fail(Errc::Io, "cannot write '{}': {}", path.string(), ec.message());
    if (status.type() != fs::file_type::symlink) return target;
    if (links == 40) fail(Errc::Io, "cannot write '{}': too many levels of symbolic links", path.string());
    const fs::path next = fs::read_symlink(target, ec);
    if (ec) fail(Errc::Io, "cannot write '{}': reading its link: {}", path.string(), ec.message());
    target = next.is_absolute() ? next : target.parent_path() / next;
  }
}

void writeFileAtomically(const fs::path& requested, Overwrite overwrite,
                         const std::function<void(const fs::path&)>& writeTo) {
  if (requested.filename().empty())
    fail(Errc::InvalidArgument, "cannot write '{}': not a file name", requested.string());
  // Through a symbolic link the file it points to is written (a rename over
  // the link would replace the link), even when it is not there yet.
  const fs::path target = resolvedTarget(requested);
  std::error_code ec;
  if (overwrite == Overwrite::Refuse && fs::symlink_status(target, ec).type() != fs::file_type::not_found)
    fail(Errc::Exists, "'{}' exists; refusing to overwrite it (use --force to replace it)", requested.string());
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");

  // mkstemp gives a unique name that nothing else writes to; the writer may
  // then reopen it by path (OpenEXR does: the same file, truncated). Its lock
  // is held until the temporary is published or removed.
  removeStaleTemporaries(dir, target);
  std::string pattern = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  const int fd = ::mkstemp(pattern.data());
  if (fd < 0) fail(Errc::Io, "cannot create a temporary file next to '{}': {}", target.string(), std::strerror(errno));
  const LockedFd writing(fd);
  const TemporaryGuard guard(pattern);  // (a signal in the microseconds since mkstemp still leaves it)
  // mkstemp creates 0600, which the writer keeps while it writes; published
  // files get the mode a plain create would give them, or keep the mode of
  // the file they replace (even a read-only one: --force replaces it).
  struct stat old {};
  const mode_t mode = ::stat(target.c_str(), &old) == 0 ? (old.st_mode & 07777) : (0666 & ~currentUmask());
  ::fchmod(fd, 0600);  // (mkstemp's 0600 less the umask: 0400 under umask 0222)
  const fs::path temporary = pattern;
  try {
    writeTo(temporary);
    syncFile(temporary, target);
    ::chmod(temporary.c_str(), mode);
    if (overwrite == Overwrite::Allow) {
      if (::rename(temporary.c_str(), target.c_str()) != 0)
        fail(Errc::Io, "cannot rename '{}' to '{}': {}", temporary.string(), target.string(), std::strerror(errno));
    } else {
      // renameat2(RENAME_NOREPLACE) publishes and checks existence in one step.
      if (::renameat2(AT_FDCWD, temporary.c_str(), AT_FDCWD, target.c_str(), RENAME_NOREPLACE) != 0) {
        const int err = errno;
        if (err == EEXIST)
          fail(Errc::Exists, "'{}' exists; refusing to overwrite it (use --force to replace it)", target.string());
        if (err != EINVAL && err != ENOSYS)
          fail(Errc::Io, "cannot rename '{}' to '{}': {}", temporary.string(), target.string(), std::strerror(err));
        // Filesystem without RENAME_NOREPLACE: link() fails atomically if the target exists.
        if (::link(temporary.c_str(), target.c_str()) != 0) {
          const int lerr = errno;
          fail(lerr == EEXIST ? Errc::Exists : Errc::Io, "cannot publish '{}': {}", target.string(),
               std::strerror(lerr));
        }
        ::unlink(temporary.c_str());
      }
    }
    syncDirectory(dir);
  } catch (...) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw;
  }
}

namespace {

// writeFolderAtomically's publication by plain renames: the old folder (when
// `replace`) moves to a hidden name, then the new one takes its place, and
// the old one moves to `temporary`'s name for removal.
void publishFolderInTwoSteps(const fs::path& temporary, const fs::path& target, bool replace) {
  if (!replace) {
    if (::rename(temporary.c_str(), target.c_str()) != 0)
      fail(Errc::Io, "cannot rename '{}' to '{}': {}", temporary.string(), target.string(), std::strerror(errno));
    return;
  }
  std::string aside = temporary.string() + "-old";
  if (::rename(target.c_str(), aside.c_str()) != 0)
    fail(Errc::Io, "cannot move '{}' aside: {}", target.string(), std::strerror(errno));
  if (::rename(temporary.c_str(), target.c_str()) != 0) {
    const int err = errno;
    ::rename(aside.c_str(), target.c_str());  // (the old folder back)
    fail(Errc::Io, "cannot rename '{}' to '{}': {}", temporary.string(), target.string(), std::strerror(err));
  }
  ::rename(aside.c_str(), temporary.c_str());
}

}  // namespace

void writeFolderAtomically(const fs::path& requested, Overwrite overwrite,
                           const std::function<void(const fs::path&)>& writeTo) {
  if (requested.filename().empty() || requested.filename() == "." || requested.filename() == "..")
    fail(Errc::InvalidArgument, "cannot write '{}': not a folder name", requested.string());
  const fs::path target = resolvedTarget(requested);
  std::error_code ec;
  const fs::file_type existing = fs::symlink_status(target, ec).type();
  if (overwrite == Overwrite::Refuse && existing != fs::file_type::not_found)
    fail(Errc::Exists, "'{}' exists; refusing to overwrite it (use --force to replace it)", requested.string());
  if (existing != fs::file_type::not_found && existing != fs::file_type::directory)
    fail(Errc::Io, "cannot write the folder '{}': a file of that name is in the way", requested.string());
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  removeStaleTemporaries(dir, target);
  std::string pattern = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr)
    fail(Errc::Io, "cannot create a temporary folder next to '{}': {}", target.string(), std::strerror(errno));
  const LockedFd writing(::open(pattern.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  const fs::path temporary = pattern;
  ::chmod(temporary.c_str(), 0777 & ~currentUmask());  // (mkdtemp's 0700: the folder gets a plain mkdir's mode)
  try {
    writeTo(temporary);
    for (const fs::directory_entry& entry : fs::directory_iterator(temporary))
      if (entry.is_regular_file()) syncFile(entry.path(), target / entry.path().filename());
    syncDirectory(temporary);
    const bool exchange = existing == fs::file_type::directory;  // (Allow: Refuse failed above)
    if (::renameat2(AT_FDCWD, temporary.c_str(), AT_FDCWD, target.c_str(),
                    exchange ? RENAME_EXCHANGE : RENAME_NOREPLACE) != 0) {
      const int err = errno;
      if (err == EEXIST || err == ENOTEMPTY)
        fail(Errc::Exists, "'{}' appeared while it was being written; refusing to overwrite it", target.string());
      if (err != EINVAL && err != ENOSYS)
        fail(Errc::Io, "cannot rename '{}' to '{}': {}", temporary.string(), target.string(), std::strerror(err));
      // A file system without renameat2's flags: the old folder steps aside
      // first (for a moment `target` is absent, never mixed).
      publishFolderInTwoSteps(temporary, target, exchange);
    }
    syncDirectory(dir);
    if (exchange) fs::remove_all(temporary, ec);  // (now the old folder; a failure leaves it, hidden)
  } catch (...) {
    fs::remove_all(temporary, ec);
    throw;
  }
}

void writeFileAtomically(const fs::path& target, Overwrite overwrite, std::string_view content) {
  writeFileAtomically(target, overwrite, [&](const fs::path& temporary) {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.close();  // (flushes; errno tells why when the stream failed)
    if (!out) fail(Errc::Io, "cannot write '{}': {}", target.string(), std::strerror(errno));
  });
}

}  // namespace lfi
