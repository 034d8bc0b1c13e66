// SPDX-License-Identifier: Apache-2.0
// The atomic writer (core/atomic_file.h) under faults repeated until they are
// boring: a writer killed at random moments, by SIGKILL (nothing can run after
// it) and by SIGTERM (its cleanup runs), while it replaces a file or a folder
// again and again; and a disk that fills up mid-write (a small tmpfs, in a
// mount namespace of a child's own).

#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"

#include "lfi_test_support.h"
#include "text_edit.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <sched.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <thread>

namespace {

namespace fs = std::filesystem;
using lfi::Errc;
using lfi::Overwrite;
using lfi::testing_support::readText;

// Version `v` of the file: a line naming it, then 256 KiB of one letter.
std::string versionText(long v) {
  return fmt::format("version {}\n", v) + std::string(256 * 1024, static_cast<char>('a' + v % 26));
}

// The version `text` is, or -1 when it is not one whole version.
long wholeVersion(const std::string& text) {
  long v = -1;
  if (std::sscanf(text.c_str(), "version %ld\n", &v) != 1 || v < 0) return -1;
  return text == versionText(v) ? v : -1;
}

class AtomicFileFaults : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(testing::TempDir()) / fmt::format("lfi-atomic-faults-{}-{}",
                                                      testing::UnitTest::GetInstance()->current_test_info()->name(),
                                                      ::getpid());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  // The hidden temporaries in the folder.
  int temporaries() const {
    int n = 0;
    for (const auto& entry : fs::directory_iterator(dir_)) n += entry.path().filename().string().starts_with(".");
    return n;
  }
  fs::path dir_;
};

// A file (a folder of two files) replaced again and again by a child killed after a random 0 to 5 ms, 100
// times with SIGKILL and 100 with SIGTERM each: it is always one whole version, never a mix or cut short; a
// kill leaves at most the temporary being written (SIGKILL always can; SIGTERM removes a file's, but not in the
// microseconds before its removal is set up, nor a folder's), and the next write removes that and replaces the
// file (folder) as asked.
class Replaced {
 public:
  virtual ~Replaced() = default;
  virtual void write(long version) const = 0;
  virtual long read() const = 0;  // the whole version there, or -1
};

class ReplacedFile : public Replaced {
 public:
  explicit ReplacedFile(fs::path p) : path_(std::move(p)) {}
  void write(long v) const override { lfi::writeFileAtomically(path_, Overwrite::Allow, versionText(v)); }
  long read() const override { return wholeVersion(readText(path_)); }

 private:
  fs::path path_;
};

class ReplacedFolder : public Replaced {
 public:
  explicit ReplacedFolder(fs::path p) : path_(std::move(p)) {}
  void write(long v) const override {
    lfi::writeFolderAtomically(path_, Overwrite::Allow, [v](const fs::path& folder) {
      std::ofstream(folder / "lightfield.exr", std::ios::binary) << versionText(v);
      std::ofstream(folder / "reference.json", std::ios::binary) << versionText(v);
    });
  }
  long read() const override {
    const long a = wholeVersion(readText(path_ / "lightfield.exr"));
    return a == wholeVersion(readText(path_ / "reference.json")) ? a : -1;
  }

 private:
  fs::path path_;
};

void killWritersAtRandom(const Replaced& replaced, const std::function<int()>& temporaries) {
  replaced.write(0);
  std::mt19937 random(20261128);
  std::uniform_int_distribution<int> delay_us(0, 5000);
  long next = 1;
  for (const int signal : {SIGKILL, SIGTERM}) {
    int replacedByChild = 0, left = 0;
    for (int kill = 0; kill < 100; ++kill) {
      SCOPED_TRACE(fmt::format("signal {}, kill {}", signal, kill));
      const long first = next;
      next += 1'000'000;  // (each child writes versions of its own)
      const pid_t child = ::fork();
      ASSERT_GE(child, 0);
      if (child == 0) {  // (the child only writes through the atomic writer: no lock another thread may hold)
        std::signal(SIGTERM, SIG_DFL);
        for (long v = first;; ++v) replaced.write(v);
      }
      std::this_thread::sleep_for(std::chrono::microseconds(delay_us(random)));
      ::kill(child, signal);
      int status = 0;
      ASSERT_EQ(::waitpid(child, &status, 0), child);
      EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal) << "status " << status;
      const long found = replaced.read();
      ASSERT_GE(found, 0) << "not one whole version after the kill";
      replacedByChild += found >= first;
      const int temporariesLeft = temporaries();
      left += temporariesLeft;
      EXPECT_LE(temporariesLeft, 1) << "more than the temporary being written was left";
      const long after = next++;
      replaced.write(after);
      ASSERT_EQ(replaced.read(), after);
      EXPECT_EQ(temporaries(), 0) << "the next write left what the killed one had";
    }
    std::printf(
        "[ info     ] signal %d: 100 kills, %d after the child had replaced it; %d temporaries left, "
        "removed by the next write\n",
        signal, replacedByChild, left);
  }
}

TEST_F(AtomicFileFaults, AFileWriterKilledAtARandomMomentLeavesAWholeVersion) {
  killWritersAtRandom(ReplacedFile(dir_ / "reference.json"), [this] { return temporaries(); });
}

TEST_F(AtomicFileFaults, AFolderWriterKilledAtARandomMomentLeavesAWholeVersion) {
  killWritersAtRandom(ReplacedFolder(dir_ / "reference"), [this] { return temporaries(); });
}

// Whether this process may make a mount namespace of its own with a tmpfs at `disk` (root, unshare), asked in a
// child that does nothing else.
bool canMountATmpfs(const fs::path& disk) {
  const pid_t child = ::fork();
  if (child == 0) {
    const bool ok = ::unshare(CLONE_NEWNS) == 0 && ::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) == 0 &&
                    ::mount("tmpfs", disk.c_str(), "tmpfs", 0, "size=256k") == 0;
    ::_exit(ok ? 0 : 1);
  }
  int status = 0;
  return child > 0 && ::waitpid(child, &status, 0) == child && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

// In a mount namespace of its own, a 256 KiB tmpfs at `disk` holds an old file and an old folder; replacing each
// with 1 MiB must fail. Writes what went wrong to stderr and exits 0 when nothing did.
[[noreturn]] void fillTheDisk(const fs::path& disk) {
  std::string report;
  const auto check = [&](bool ok, const std::string& what) {
    if (!ok) report += what + "\n";
  };
  if (::unshare(CLONE_NEWNS) != 0 || ::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
      ::mount("tmpfs", disk.c_str(), "tmpfs", 0, "size=256k") != 0) {
    std::fputs("no tmpfs in a mount namespace of its own\n", stderr);
    std::_Exit(1);
  }
  const fs::path file = disk / "calibration.json", folder = disk / "reference";
  lfi::writeFileAtomically(file, Overwrite::Allow, std::string_view("old"));
  lfi::writeFolderAtomically(folder, Overwrite::Allow,
                             [](const fs::path& f) { std::ofstream(f / "a.txt") << "old folder"; });
  const std::string big(1 << 20, 'x');
  try {
    lfi::writeFileAtomically(file, Overwrite::Allow, big);
    check(false, "a 1 MiB file was written on a 256 KiB disk");
  } catch (const lfi::Error& e) {
    check(e.code() == Errc::Io, fmt::format("file: code {}, not Io: {}", static_cast<int>(e.code()), e.what()));
    check(std::string(e.what()).find(file.string()) != std::string::npos, "file: not named: " + std::string(e.what()));
  }
  check(readText(file) == "old", "the old file was changed");
  try {
    // The folder's content written by the library's own writer (an image of noise, 1 MiB that does not
    // compress): it, not this test, must see the write fail.
    cv::Mat noise(512, 512, CV_32FC1);
    cv::randu(noise, 0.f, 1.f);
    lfi::writeFolderAtomically(folder, Overwrite::Allow, [&](const fs::path& f) {
      lfi::writeRadianceExr(f / "image.exr", noise, {}, Overwrite::Allow);
    });
    check(false, "a 1 MiB folder was written on a 256 KiB disk");
  } catch (const lfi::Error& e) {
    check(e.code() == Errc::Io, fmt::format("folder: code {}, not Io: {}", static_cast<int>(e.code()), e.what()));
    check(std::string(e.what()).find("image.exr") != std::string::npos,
          "folder: the image not named: " + std::string(e.what()));
  }
  check(readText(folder / "a.txt") == "old folder", "the old folder was changed");
  for (const auto& entry : fs::directory_iterator(disk))
    check(!entry.path().filename().string().starts_with("."), "a temporary was left: " + entry.path().string());
  ::umount(disk.c_str());
  std::error_code ignored;
  fs::remove_all(disk.parent_path(), ignored);  // this process's own test folder (its fixture's, pid in the name)
  std::fputs(report.c_str(), stderr);
  std::fflush(stderr);
  std::_Exit(report.empty() ? 0 : 1);
}

// A disk that fills up mid-write: replacing a file or a folder is an Errc::Io error naming the file (the
// folder's, for the folder), the old one stays whole, and no temporary is left.
TEST_F(AtomicFileFaults, AFullDiskIsAClearErrorAndKeepsTheOldFile) {
  const fs::path disk = dir_ / "disk";
  fs::create_directories(disk);
  if (!canMountATmpfs(disk)) LFI_SKIP_WITHOUT_TOOL("root and a mount namespace of its own (unshare)");
  // The writes run in a fresh process (the threadsafe death test runs this binary again): a fork of this one
  // would inherit OpenEXR's thread pool, which an earlier test started, without its threads, and wait on it.
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(fillTheDisk(disk), ::testing::ExitedWithCode(0), "");
}

}  // namespace
