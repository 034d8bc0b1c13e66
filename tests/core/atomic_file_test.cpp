// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/atomic_file.h"

#include "lfi/core/error.h"

#include <fmt/format.h>
#include "lfi_test_support.h"
#include "text_edit.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
using lfi::Errc;
using lfi::Overwrite;
using lfi::testing_support::readText;

using lfi::testing_support::throwsError;

void writePlain(const fs::path& path, const std::string& content) {
  std::ofstream(path, std::ios::binary) << content;
}

class AtomicFile : public testing::Test {
 protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(testing::TempDir()) /
           fmt::format("lfi-atomic-{}-{}-{}", info->name(), ::getpid(), counter.fetch_add(1));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  // Names of everything in the test directory, sorted (hidden temporaries included).
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  fs::path dir_;
};

using Names = std::vector<std::string>;

TEST_F(AtomicFile, InterruptedWriteKeepsOldFileAndRemovesTemporary) {
  const fs::path target = dir_ / "calibration.json";
  writePlain(target, "old content");
  fs::path seenTemporary;
  bool temporaryExisted = false;
  try {
    lfi::writeFileAtomically(target, Overwrite::Allow, [&](const fs::path& temporary) {
      seenTemporary = temporary;
      std::ofstream(temporary, std::ios::binary) << "new cont";  // part of the new content...
      temporaryExisted = fs::exists(temporary);
      throw std::runtime_error("writer interrupted");  // ...then the writer fails
    });
    ADD_FAILURE() << "the writer's exception did not propagate";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "writer interrupted");  // the writer's own exception, unchanged
  }
  // The temporary was a real file next to the target, not the target itself.
  EXPECT_TRUE(temporaryExisted);
  EXPECT_EQ(seenTemporary.parent_path(), target.parent_path());
  EXPECT_NE(seenTemporary, target);
  EXPECT_FALSE(fs::exists(seenTemporary));
  EXPECT_EQ(readText(target), "old content");
  EXPECT_EQ(entries(), (Names{"calibration.json"}));
}

TEST_F(AtomicFile, InterruptedWriteOfNewFileLeavesNothing) {
  const fs::path target = dir_ / "new.bin";
  EXPECT_TRUE(throwsError(
      [&] {
        lfi::writeFileAtomically(target, Overwrite::Refuse, [](const fs::path& temporary) {
          std::ofstream(temporary) << "partial";
          lfi::fail(Errc::Cancelled, "stopped by the user");
        });
      },
      Errc::Cancelled, {"stopped by the user"}));
  EXPECT_EQ(entries(), Names{});
}

// Ctrl-C, or a SIGTERM from a job's time limit, while a file is being written
// ends the process as it always would, but leaves no hidden temporary behind;
// a signal the program handles itself is left to it, and the default action
// is back once nothing is being written.
TEST_F(AtomicFile, ASignalThatEndsTheProcessMidWriteLeavesNoTemporary) {
  for (const int signal : {SIGINT, SIGTERM, SIGHUP}) {
    const fs::path target = dir_ / "lightfield.exr";
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {  // (the child only writes through the atomic writer: no lock another thread may hold)
      std::signal(signal, SIG_DFL);  // (a shell may have started the tests with SIGINT ignored)
      lfi::writeFileAtomically(target, Overwrite::Refuse, [signal](const fs::path& temporary) {
        std::ofstream(temporary, std::ios::binary) << "half a light field";
        ::raise(signal);
      });
      ::_exit(0);  // not reached: the signal ended the child
    }
    int status = 0;
    pid_t reaped = 0;
    for (int i = 0; i < 1000 && (reaped = ::waitpid(child, &status, WNOHANG)) == 0; ++i)  // up to 10 s, never a hang
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (reaped == 0) {
      ::kill(child, SIGKILL);
      ::waitpid(child, &status, 0);
    }
    ASSERT_EQ(reaped, child) << "the child neither ended nor was ended by signal " << signal;
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal) << "signal " << signal << ", status " << status;
    EXPECT_EQ(entries(), Names{}) << "signal " << signal;
  }
  // After a write the disposition is the default again; a program's own handler is left in place.
  const auto previous = std::signal(SIGTERM, SIG_DFL);
  lfi::writeFileAtomically(dir_ / "plain.txt", Overwrite::Refuse, std::string_view("text"));
  struct sigaction action {};
  ::sigaction(SIGTERM, nullptr, &action);
  EXPECT_EQ(action.sa_handler, SIG_DFL);
  static std::atomic<int> handled{0};
  std::signal(SIGTERM, [](int) { handled.fetch_add(1); });
  lfi::writeFileAtomically(dir_ / "kept.txt", Overwrite::Refuse, [](const fs::path& temporary) {
    std::ofstream(temporary) << "written";
    ::raise(SIGTERM);  // the program's handler takes it, and the write goes on
  });
  std::signal(SIGTERM, previous);
  EXPECT_EQ(handled.load(), 1);
  EXPECT_EQ(readText(dir_ / "kept.txt"), "written");
}

TEST_F(AtomicFile, RefuseKeepsExistingTarget) {
  const fs::path target = dir_ / "result.csv";
  writePlain(target, "original");
  EXPECT_TRUE(throwsError(
      [&] {
        lfi::writeFileAtomically(target, Overwrite::Refuse,
                                 [](const fs::path& temporary) { std::ofstream(temporary) << "replacement"; });
      },
      Errc::Exists, {target.string()}));
  EXPECT_EQ(readText(target), "original");
  EXPECT_EQ(entries(), (Names{"result.csv"}));
}

TEST_F(AtomicFile, RefuseDetectsTargetCreatedDuringWrite) {
  // Another process creates the target while we write: the publish step itself must refuse.
  const fs::path target = dir_ / "race.txt";
  EXPECT_TRUE(throwsError(
      [&] {
        lfi::writeFileAtomically(target, Overwrite::Refuse, [&](const fs::path& temporary) {
          std::ofstream(temporary) << "ours";
          writePlain(target, "theirs");
        });
      },
      Errc::Exists, {target.string()}));
  EXPECT_EQ(readText(target), "theirs");
  EXPECT_EQ(entries(), (Names{"race.txt"}));
}

TEST_F(AtomicFile, RefuseCreatesMissingTarget) {
  const fs::path target = dir_ / "fresh.txt";
  lfi::writeFileAtomically(target, Overwrite::Refuse, [](const fs::path& temporary) {
    std::ofstream(temporary, std::ios::binary) << "fresh content";
  });
  EXPECT_EQ(readText(target), "fresh content");
  EXPECT_EQ(entries(), (Names{"fresh.txt"}));
}

TEST_F(AtomicFile, AllowReplacesExistingTarget) {
  const fs::path target = dir_ / "result.csv";
  writePlain(target, "a much longer original content that must not leave a tail behind");
  lfi::writeFileAtomically(target, Overwrite::Allow,
                           [](const fs::path& temporary) { std::ofstream(temporary, std::ios::binary) << "short"; });
  EXPECT_EQ(readText(target), "short");
  EXPECT_EQ(entries(), (Names{"result.csv"}));
}

TEST_F(AtomicFile, MissingDirectoryIsIoErrorNamingPath) {
  const fs::path target = dir_ / "no" / "such" / "dir" / "out.txt";
  bool writerCalled = false;
  EXPECT_TRUE(throwsError(
      [&] { lfi::writeFileAtomically(target, Overwrite::Allow, [&](const fs::path&) { writerCalled = true; }); },
      Errc::Io, {target.string()}));
  EXPECT_FALSE(writerCalled);
  EXPECT_TRUE(
      throwsError([&] { lfi::writeFileAtomically(target, Overwrite::Refuse, "text"); }, Errc::Io, {target.string()}));
  EXPECT_FALSE(fs::exists(dir_ / "no"));
}

TEST_F(AtomicFile, StringOverloadWritesExactBytes) {
  const fs::path target = dir_ / "blob.bin";
  const std::string content("line 1\nline 2\r\n\0binary\xff\x00tail", 28);
  lfi::writeFileAtomically(target, Overwrite::Refuse, content);
  EXPECT_EQ(readText(target), content);
  EXPECT_EQ(fs::file_size(target), content.size());
  EXPECT_TRUE(throwsError([&] { lfi::writeFileAtomically(target, Overwrite::Refuse, "other"); }, Errc::Exists,
                          {target.string()}));
  EXPECT_EQ(readText(target), content);
  lfi::writeFileAtomically(target, Overwrite::Allow, "other");
  EXPECT_EQ(readText(target), "other");
  lfi::writeFileAtomically(target, Overwrite::Allow, std::string_view());
  EXPECT_EQ(readText(target), "");
  EXPECT_TRUE(fs::exists(target));
  EXPECT_EQ(entries(), (Names{"blob.bin"}));
}

TEST_F(AtomicFile, TargetWithoutFileNameIsRejected) {
  EXPECT_TRUE(throwsError([&] { lfi::writeFileAtomically(dir_ / "", Overwrite::Allow, "x"); }, Errc::InvalidArgument,
                          {"not a file name"}));
  EXPECT_EQ(entries(), Names{});
}

TEST_F(AtomicFile, PublishedFileHasUmaskModeAndReplacementKeepsMode) {
  // A plain create gives 0666 & ~umask; mkstemp's private 0600 must not leak.
  const mode_t mask = ::umask(027);
  const fs::path target = dir_ / "mode.txt";
  lfi::writeFileAtomically(target, Overwrite::Refuse, "a");
  struct stat st {};
  ASSERT_EQ(::stat(target.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u);
  ASSERT_EQ(::chmod(target.c_str(), 0604), 0);
  lfi::writeFileAtomically(target, Overwrite::Allow, "b");
  ASSERT_EQ(::stat(target.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0604u);
  // A read-only file replaced on request stays read-only; the writer writes
  // the temporary while it is still its own 0600 (it failed with EACCES for a
  // user other than root, after all the work).
  ASSERT_EQ(::chmod(target.c_str(), 0444), 0);
  lfi::writeFileAtomically(target, Overwrite::Allow, [](const fs::path& temporary) {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    ASSERT_TRUE(out.good()) << "the temporary is not writable while it is written";
    out << "c";
  });
  EXPECT_EQ(readText(target), "c");
  ASSERT_EQ(::stat(target.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0444u);
  // The same under a umask that takes the owner's write bit.
  ::umask(0222);
  const fs::path fresh = dir_ / "fresh.txt";
  lfi::writeFileAtomically(fresh, Overwrite::Refuse, [](const fs::path& temporary) {
    struct stat own {};
    ASSERT_EQ(::stat(temporary.c_str(), &own), 0);
    EXPECT_EQ(own.st_mode & 0777, 0600u);
    std::ofstream(temporary, std::ios::binary) << "d";
  });
  ASSERT_EQ(::stat(fresh.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0444u);
  ::umask(mask);
}

// A target that is a symbolic link: the file it points to is written (a
// file that exists only with --force), next to it, and the link stays; a
// dangling link's file is created where it points.
TEST_F(AtomicFile, ASymbolicLinkKeepsPointingAtTheWrittenFile) {
  fs::create_directories(dir_ / "real");
  writePlain(dir_ / "real" / "s.txt", "old");
  fs::create_symlink(fs::path("real") / "s.txt", dir_ / "s.txt");
  fs::create_symlink("s.txt", dir_ / "link-to-link.txt");
  EXPECT_TRUE(throwsError([&] { lfi::writeFileAtomically(dir_ / "link-to-link.txt", Overwrite::Refuse, "new"); },
                          Errc::Exists, {"link-to-link.txt", "--force"}));
  lfi::writeFileAtomically(dir_ / "link-to-link.txt", Overwrite::Allow, "new");
  EXPECT_TRUE(fs::is_symlink(dir_ / "s.txt"));
  EXPECT_TRUE(fs::is_symlink(dir_ / "link-to-link.txt"));
  EXPECT_EQ(readText(dir_ / "real" / "s.txt"), "new");
  for (const bool force : {false, true}) {
    const std::string name = force ? "forced.txt" : "dangling.txt";
    fs::create_symlink(fs::path("real") / ("to-" + name), dir_ / name);
    lfi::writeFileAtomically(dir_ / name, force ? Overwrite::Allow : Overwrite::Refuse, "x");
    EXPECT_TRUE(fs::is_symlink(dir_ / name)) << name;
    EXPECT_EQ(readText(dir_ / "real" / ("to-" + name)), "x") << name;
  }
  EXPECT_EQ(entries(), (Names{"dangling.txt", "forced.txt", "link-to-link.txt", "real", "s.txt"}));
  std::vector<std::string> real;
  for (const auto& entry : fs::directory_iterator(dir_ / "real")) real.push_back(entry.path().filename().string());
  std::sort(real.begin(), real.end());
  EXPECT_EQ(real, (Names{"s.txt", "to-dangling.txt", "to-forced.txt"}));  // no temporary left beside them
  fs::create_symlink("loop-b", dir_ / "loop-a");
  fs::create_symlink("loop-a", dir_ / "loop-b");
  EXPECT_TRUE(throwsError([&] { lfi::writeFileAtomically(dir_ / "loop-a", Overwrite::Allow, "x"); }, Errc::Io,
                          {"loop-a", "symbolic links"}));
}

// A folder of files published as one (a reference package).
void writePackage(const fs::path& folder, const std::string& content) {
  writePlain(folder / "a.txt", content);
  writePlain(folder / "b.txt", content + content);
}

TEST_F(AtomicFile, AFolderIsPublishedWholeAndNeverReplacedUnasked) {
  const fs::path target = dir_ / "package";
  lfi::writeFolderAtomically(target, Overwrite::Refuse, [](const fs::path& tmp) { writePackage(tmp, "one"); });
  EXPECT_EQ(readText(target / "a.txt"), "one");
  EXPECT_EQ(readText(target / "b.txt"), "oneone");
  EXPECT_EQ(entries(), (Names{"package"}));
  bool called = false;
  EXPECT_TRUE(throwsError(
      [&] { lfi::writeFolderAtomically(target, Overwrite::Refuse, [&](const fs::path&) { called = true; }); },
      Errc::Exists, {"package", "--force"}));
  EXPECT_FALSE(called) << "an existing folder is refused before any work";
  EXPECT_EQ(readText(target / "a.txt"), "one");
}

TEST_F(AtomicFile, AFolderReplacedWithAllowHoldsOnlyTheNewFiles) {
  const fs::path target = dir_ / "package";
  lfi::writeFolderAtomically(target, Overwrite::Refuse, [](const fs::path& tmp) {
    writePackage(tmp, "old");
    writePlain(tmp / "stale.txt", "only in the old one");
  });
  lfi::writeFolderAtomically(target, Overwrite::Allow, [](const fs::path& tmp) { writePackage(tmp, "new"); });
  EXPECT_EQ(readText(target / "a.txt"), "new");
  EXPECT_FALSE(fs::exists(target / "stale.txt"));
  EXPECT_EQ(entries(), (Names{"package"})) << "the old folder is removed, no temporary is left";
}

TEST_F(AtomicFile, AFolderWriteThatFailsLeavesTheOldFolderAndNoTemporary) {
  const fs::path target = dir_ / "package";
  lfi::writeFolderAtomically(target, Overwrite::Refuse, [](const fs::path& tmp) { writePackage(tmp, "old"); });
  EXPECT_THROW(lfi::writeFolderAtomically(target, Overwrite::Allow,
                                          [](const fs::path& tmp) {
                                            writePackage(tmp, "half");
                                            throw std::runtime_error("the writer failed");
                                          }),
               std::runtime_error);
  EXPECT_EQ(readText(target / "a.txt"), "old");
  EXPECT_EQ(entries(), (Names{"package"}));
}

TEST_F(AtomicFile, AFileInTheWayOfAFolderIsAnError) {
  writePlain(dir_ / "package", "a file");
  EXPECT_TRUE(throwsError(
      [&] {
        lfi::writeFolderAtomically(dir_ / "package", Overwrite::Allow,
                                   [](const fs::path& tmp) { writePackage(tmp, "x"); });
      },
      Errc::Io, {"package", "in the way"}));
  EXPECT_EQ(readText(dir_ / "package"), "a file");
  EXPECT_EQ(entries(), (Names{"package"}));
}

}  // namespace
