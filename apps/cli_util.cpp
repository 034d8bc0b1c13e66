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

}  // namespace lfi::cli
