// SPDX-License-Identifier: Apache-2.0
#pragma once
// What `lfi inspect` and `lfi run` keep of a part: its record and, by the
// bench's [output] save_images, its image (EXR, DN) and overlay (PNG).

#include "lfi/controller/bench_file.h"
#include "lfi/controller/inspection_record.h"
#include "lfi/controller/inspector.h"

#include <filesystem>
#include <string>

namespace lfi {

// The record of an inspected part; its images written into `folder` as
// <stem>.exr and <stem>-overlay.png when the bench keeps them (never over an
// existing file).
InspectionRecord partRecord(const BenchFile& bench, const Inspector& inspector, const PartInspection& part,
                            std::uint64_t number, const std::string& timeUtc, const std::filesystem::path& folder,
                            const std::string& stem);

// The record of a part that could not be inspected.
InspectionRecord errorRecord(const BenchFile& bench, std::uint64_t number, const std::string& timeUtc,
                             const std::string& error);

}  // namespace lfi
