// SPDX-License-Identifier: Apache-2.0
#pragma once
// A sweep file's grid computed on one machine, or as N shards on many, and
// the shards merged into what the one machine writes (docs/study.md,
// "Sweeps"; docs/cluster.md).
//
// Each point is the bench with the point's numbers (sweep_file.h): its
// reference light field captured, every scene of the study rendered in each
// of the sweep's setups and judged by the study's criterion. A point's
// numbers depend on the sweep alone, never on which shard computes it or
// how many there are.
//
// A sweep's folder (`lfi study --sweep FILE --out OUT`, or `lfi study merge`):
//   study.json     format "lfi-sweep-results", version 1: the sweep, its axes,
//                  one entry per point in order, and per setup and defect the
//                  points that detect it (answers)
//   images/point-NNNNNN/<scene>_<setup>.exr, .png, _diff.png
//   report.html
// A shard's folder (`--shard i/N`): shard.json (format "lfi-sweep-shard",
// version 1: the sweep's identity, lfi's version, i and N, its points'
// entries) and its points' images. Every file is written atomically: a task
// run again replaces its shard's files and nothing else.

#include "lfi/study/sweep_file.h"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace lfi::study {

// Shard `index` of `count`, 1-based.
struct SweepShard {
  int index = 1;
  int count = 1;
};

// "i/N" with 1 <= i <= N <= 100000; Errc::InvalidArgument naming the text otherwise.
SweepShard parseShard(const std::string& text);

// The points of a shard: every k < points with k mod N = i - 1.
std::vector<std::size_t> shardPoints(std::size_t points, const SweepShard& shard);

struct SweepOptions {
  std::optional<SweepShard> shard;  // none: the whole sweep, merged in place
  int threads = 0;                  // 0: every core
  bool overwrite = false;           // replace an earlier run's files in the folder
  std::function<void(const std::string&, double)> progress;
};

// lfi's version, as shards record it.
const char* lfiVersion();

// Computes the sweep (or its shard) into `out` and returns study.json's
// document (or shard.json's). Errc::Exists when the folder has a run's files
// and `overwrite` is not set; a point that cannot be computed throws naming
// the point and its values.
nlohmann::ordered_json runSweep(const SweepFile& sweep, const std::filesystem::path& out, const SweepOptions& options);

// Merges shard folders into `out`: their images copied byte for byte, and
// study.json and report.html written as the unsharded run writes them.
// Checks first, and merges nothing when: a folder has no shard.json or an
// unreadable one (Errc::InvalidFile naming it), the shards come from
// different sweeps or lfi versions (naming both folders), a shard is there
// twice or missing, or the points are not covered exactly once (naming the
// shards).
nlohmann::ordered_json mergeSweepShards(const std::filesystem::path& out,
                                        const std::vector<std::filesystem::path>& shards, bool overwrite);

}  // namespace lfi::study
