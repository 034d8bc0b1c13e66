// SPDX-License-Identifier: Apache-2.0
#pragma once
// The bench file tests' fixture: a bench whose devices are never opened, and
// the helpers that edit it, read it, and check the errors it gives.

#include "lfi/controller/bench_file.h"

#include "lfi_test_support.h"
#include "test_folder.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>

namespace lfi::bench_file_test {

namespace fs = std::filesystem;
using lfi::testing_support::TestFolder;
using lfi::testing_support::throwsError;

// A bench whose devices are never opened: every key set, relative paths in
// [capture], [reference] and [output].
inline const std::string kBench = R"(# A bench for the tests.
format = "lfi-inspection-bench"
version = 1

[camera]
uri = "aravis:Fake-GV01"
exposure_us = 10000
pixel_format = "Mono12"
trigger = "software"
object_pixel_mm = 0.5
read_noise_dn = 0.98
dn_per_electron = 0.39

[display]
uri = "usb:1209:4c46/LFI-0001"

[capture]
uri = "sim:../scenes/bench.toml?spp=8"

[geometry]
distance_mm = 30
part_centre_px = [27.5, 27.5]

[reference]
folder = "reference"
mask_radius_mm = 12.2
mask_lit_fraction = 0.25

[inspection]
relative = 6
smallest_defect_mm = 1.0
closing_mm = 0.5

[output]
folder = "../inspections"
)";

// `text` with the one occurrence of `from` replaced by `to`.
inline std::string replaced(const std::string& text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "'" << from << "' is not in the bench text";
  EXPECT_EQ(text.find(from, at + 1), std::string::npos) << "'" << from << "' is in the bench text twice";
  if (at == std::string::npos) return text;
  return text.substr(0, at) + to + text.substr(at + from.size());
}

// The 1-based line of `text` that holds `fragment`.
inline int lineOf(const std::string& text, const std::string& fragment) {
  const size_t at = text.find(fragment);
  EXPECT_NE(at, std::string::npos) << "'" << fragment << "' is not in the text";
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

// 64-bit FNV-1a, written out from its definition (checked against the
// published test vectors below) to check referenceHash() independently.
inline std::string fnv1a64(const std::string& text) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const unsigned char c : text) {
    h ^= c;
    h *= 0x100000001b3ull;
  }
  return fmt::format("{:016x}", h);
}

class BenchFileTest : public testing::Test {
 protected:
  BenchFileTest()
      : folder_("lfi-bench-file-" + std::string(testing::UnitTest::GetInstance()->current_test_info()->name())) {
    fs::create_directories(folder_ / "benches");
  }
  // Writes `text` as benches/<name> and returns its path.
  fs::path write(const std::string& text, const std::string& name = "bench.toml") const {
    return folder_.write("benches/" + name, text);
  }
  BenchFile read(const std::string& text, const std::string& name = "bench.toml") const {
    return readBenchFile(write(text, name));
  }
  // Passes when reading `text` throws Errc::Config whose message holds
  // "<file>:<line>: " followed by `message` (e.g. "key 'camera.gain' = 2000 is outside").
  testing::AssertionResult refusedAt(const std::string& text, int line, const std::string& message) const {
    const fs::path file = write(text);
    return throwsError([&] { readBenchFile(file); }, Errc::Config,
                       {fmt::format("{}:{}: {}", file.string(), line, message)});
  }

  TestFolder folder_;
};

}  // namespace lfi::bench_file_test
