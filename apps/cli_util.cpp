// SPDX-License-Identifier: Apache-2.0
// Helpers shared by several lfi subcommands: the progress display, whole-number
// option checks, and the checks on output paths made before any work.

#include "cli_util.h"

#include "lfi/core/error.h"
#include "lfi/core/log.h"
#include "lfi/sim/scene_file.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <system_error>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

constexpr long long kMostThreads = 4096;

}  // namespace

void ProgressBar::operator()(const std::string& label, double fraction) {
  std::lock_guard lock(mutex_);
  const int percent = static_cast<int>(fraction * 100);
  if (isatty(STDERR_FILENO)) {
    if (open_ && percent == shownPercent_ && label == shownLabel_) return;  // (nothing new to draw)
    shownPercent_ = percent, shownLabel_ = label;
    const int filled = static_cast<int>(fraction * 30);
    fmt::print(stderr, "\r[{:<30}] {:3d}% {:<40}", std::string(static_cast<size_t>(filled), '#'), percent,
               label.substr(0, 40));
    open_ = fraction < 1;
    if (!open_) fmt::print(stderr, "\n");
  } else if (percent / 10 != lastDecile_) {
    lastDecile_ = percent / 10;
    spdlog::info("{:3d}% {}", percent, label);
  }
}

ProgressBar::~ProgressBar() {           // (an error unwinding past a bar prints on a line of its own)
  if (open_) std::fputs("\n", stderr);  // (no fmt::print: it may throw, and a destructor must not)
}

void ProgressBar::finish() {
  std::lock_guard lock(mutex_);
  if (open_) fmt::print(stderr, "\n");
  open_ = false;
}

CLI::Validator threadCount() {
  return wholeNumberIn(0LL, kMostThreads);
}
CLI::Validator seedValue() {
  return wholeNumberIn<std::uint64_t>(0, lfi::sim::kLargestSeed);
}

void requireOutputFolder(const fs::path& given, const char* command, const char* source) {
  const fs::path folder = given.empty() ? fs::path(".") : given;  // (the parent of a bare file name)
  std::error_code made;
  fs::create_directories(folder, made);
  if (made || !fs::is_directory(folder, made))
    lfi::fail(lfi::Errc::Io, "{}: cannot make the folder '{}' for {}: {}", command, folder.string(), source,
              made ? made.message() : std::string("a file of that name is in the way"));
  if (::access(folder.c_str(), W_OK | X_OK) != 0)  // (files are made in it: it must be searchable too)
    lfi::fail(lfi::Errc::Io, "{}: cannot write into '{}' for {}: {}", command, folder.string(), source,
              std::strerror(errno));
}

void refuseExisting(const std::vector<fs::path>& files, bool force, const char* command) {
  if (force) return;
  for (const fs::path& file : files) {
    std::error_code ec;
    if (fs::exists(file, ec))
      lfi::fail(lfi::Errc::Exists, "'{}' exists; refusing to overwrite it (use --force to replace it)", file.string());
    if (ec) lfi::fail(lfi::Errc::Io, "{}: cannot look for '{}': {}", command, file.string(), ec.message());
  }
}

}  // namespace lfi::cli
