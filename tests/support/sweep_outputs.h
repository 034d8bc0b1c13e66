// SPDX-License-Identifier: Apache-2.0
#pragma once
// Sweeps in tests (tests/study/sweep_test.cpp, tests/apps/lfi_cluster_test.cpp):
// the study's reference bench made small, and a sweep's outputs read back to
// compare two runs.

#include "text_edit.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <map>
#include <string>

namespace lfi::testing_support {

// data/benches/reference.toml with a 128 x 128 camera of 4x the pixel (32 x 32 at the quick quality's
// binning, the same field), so that a point renders in a fraction of a second.
inline std::string smallStudyBench() {
  std::string text = readText(std::filesystem::path(LFI_SOURCE_DIR) / "data" / "benches" / "reference.toml");
  replaceOnce(text, "width = 512", "width = 128");
  replaceOnce(text, "height = 512", "height = 128");
  replaceOnce(text, "pixel_pitch_mm = 0.0138", "pixel_pitch_mm = 0.0552");
  return text;
}

// Every file under `folder`/images by its path from `folder`, with its bytes.
inline std::map<std::string, std::string> sweepImages(const std::filesystem::path& folder) {
  std::map<std::string, std::string> out;
  for (const auto& f : std::filesystem::recursive_directory_iterator(folder / "images"))
    if (f.is_regular_file()) out[f.path().lexically_relative(folder).string()] = readText(f.path());
  return out;
}

// A study.json less its provenance (which names the files as given).
inline nlohmann::ordered_json resultsWithoutProvenance(const std::filesystem::path& studyJson) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(readText(studyJson));
  j.erase("provenance");
  return j;
}

}  // namespace lfi::testing_support
