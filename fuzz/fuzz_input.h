// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the fuzz targets share. Each target hands libFuzzer's bytes to one of
// lfi's readers of outside input, as a file where the reader takes a path (in
// a folder of the process's own under the temporary folder, removed at exit).
// An lfi::Error is the clear error a bad input must give and ends the input;
// anything else (another exception, a crash, a sanitizer's report, a hang, a
// leak) escapes to libFuzzer, which reports it.

#include "lfi/core/error.h"

#include <spdlog/spdlog.h>

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace lfi::fuzz {

inline const std::filesystem::path& folder() {
  static const std::filesystem::path dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("lfi-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(folder(), ignored);
    });
    spdlog::set_level(spdlog::level::off);  // the readers' warnings are not findings
    return d;
  }();
  return dir;
}

// Writes the input to `name` in folder() and returns its path.
inline std::filesystem::path writeInput(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = folder() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

inline std::string_view text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// Runs `read`; an lfi::Error ends the input as expected.
template <typename Read>
void expectCleanRefusal(Read&& read) {
  try {
    read();
  } catch (const lfi::Error&) {
  }
}

}  // namespace lfi::fuzz
