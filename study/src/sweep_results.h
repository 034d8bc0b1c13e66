// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_study: a sweep's documents (grid_sweep.h): study.json's
// header, the results assembled from the points' entries, a shard's record,
// and their files.

#include "lfi/core/atomic_file.h"
#include "lfi/study/grid_sweep.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace lfi::study::detail {

// "point-NNNNNN", a point's folder under images/.
std::string pointFolder(std::size_t index);

// What study.json says of the sweep before its points: format, version,
// units, quality, provenance, setups, criterion, axes.
nlohmann::ordered_json sweepHeader(const SweepFile& sweep);

// study.json's document: the header, the points' entries in order, the answers, complete.
nlohmann::ordered_json sweepResults(const nlohmann::ordered_json& header, const nlohmann::ordered_json& points);

// study.json and report.html, atomically.
void writeSweepResults(const std::filesystem::path& out, Overwrite overwrite, const nlohmann::ordered_json& results);

// shard.json's document, and the file.
nlohmann::ordered_json shardRecord(const nlohmann::ordered_json& header, const SweepShard& shard,
                                   std::size_t pointCount, const nlohmann::ordered_json& points);
void writeShardRecord(const std::filesystem::path& out, Overwrite overwrite, const nlohmann::ordered_json& record);

}  // namespace lfi::study::detail
