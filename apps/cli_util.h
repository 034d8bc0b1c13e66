// SPDX-License-Identifier: Apache-2.0
#pragma once
// Helpers shared by several lfi subcommands: the progress display and
// whole-number option checks. (Output folders: lfi/core/output_folder.h.)

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <charconv>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <string>

namespace lfi::cli {

// A one-line progress bar on stderr when it is a terminal, otherwise a log
// line every 10 %.
class ProgressBar {
 public:
  void operator()(const std::string& label, double fraction);
  ProgressBar() = default;
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  ~ProgressBar();
  // Ends a bar left short of 100 % (work stopped early) on its own line.
  void finish();

 private:
  std::mutex mutex_;
  int lastDecile_ = -1;
  bool open_ = false;  // a terminal's bar line printed without its newline
  int shownPercent_ = -1;
  std::string shownLabel_;
};

// A whole-number option in [lowest, highest], in decimal. (CLI11 2.1's
// PositiveNumber would answer "--spp 0" with "Value 0 not in range 0.000000 to
// 1.797...e308", and its own conversion reads "010" as octal and "-1" as an
// unsigned 2^64 - 1: the validator, a transform, hands it the value in plain
// decimal.)
template <typename T = long long>
CLI::Validator wholeNumberIn(T lowest, T highest) {
  return CLI::Validator(
      [lowest, highest](std::string& input) -> std::string {
        T value = 0;
        const char* end = input.data() + input.size();
        const auto [at, ec] = std::from_chars(input.data(), end, value);
        if (ec != std::errc() || at != end || value < lowest || value > highest)
          return fmt::format("'{}' is not a whole number in [{}, {}]", input, lowest, highest);
        input = std::to_string(value);
        return {};
      },
      fmt::format("INT in [{}, {}]", lowest, highest));
}
CLI::Validator threadCount();
CLI::Validator seedValue();

}  // namespace lfi::cli
