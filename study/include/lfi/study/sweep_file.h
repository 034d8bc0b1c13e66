// SPDX-License-Identifier: Apache-2.0
#pragma once
// A sweep file (docs/study.md, "Sweeps"): a team's own grid of display and
// bench settings over a study bench, each point the bench with some of its
// numbers replaced, checked as the bench file's own.
//
//   key        units  default    meaning
//   format     -      required   "lfi-sweep"
//   version    -      required   1
//   bench      path   required   the study's bench file (format lfi-bench), relative to this file
//   quality    -      "quick"    quick | default | high: the camera, samples and capture of every point
//   seed       -      1          the renders' and the sensor noise's
//   setups     -      both       the setups each point renders: "inverse_schlieren" (the ideal
//                                emitter), "display" (the bench's panel and optics)
//   [[axis]]   key    -          a number of the bench file, "<table>.<key>" ("display.array_pitch_mm")
//              values as key     its values, in order; or
//              from, to, steps   steps values evenly from `from` to `to` (steps >= 2)
//
// The grid is every combination of the axes' values, the first axis slowest:
// point k has axis a's value index (k / (product of the later axes' sizes)) mod
// (axis a's size). Units are the bench file's (mm, rad).

#include "lfi/core/config.h"
#include "lfi/study/study.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace lfi::study {

struct SweepAxis {
  std::string key;  // "<table>.<key>" of the bench file
  std::vector<double> values;
};

struct SweepFile {
  std::filesystem::path file;   // as given
  std::filesystem::path bench;  // the bench file, resolved against the sweep file's folder
  Quality quality = Quality::Quick;
  std::uint64_t seed = 1;
  std::vector<std::string> setups;  // in the order the file gives them
  std::vector<SweepAxis> axes;
  // A 64-bit FNV-1a hash of what the results depend on: the sweep's settings,
  // its axes, and the bench file's bytes; 16 hex digits. Shards of one sweep
  // share it (grid_sweep.h).
  std::string identity;

  std::size_t pointCount() const;
  // The bench's numbers at point `index` (< pointCount()), one per axis.
  std::vector<ConfigTable::Override> point(std::size_t index) const;
};

// Reads and checks a sweep file: every axis names a number of the bench
// file, and every point's bench loads (Bench::load's checks, naming the
// point and its values). Throws Errc::NotFound or Errc::Config naming the
// file, line and key.
SweepFile readSweepFile(const std::filesystem::path& file);

// The bench at one point of the sweep.
Bench sweepBench(const SweepFile& sweep, std::size_t index);

}  // namespace lfi::study
