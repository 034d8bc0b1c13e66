// SPDX-License-Identifier: Apache-2.0
#pragma once
// What `lfi capture`, `lfi train` and `lfi inspect` do with a bench file
// (docs/inspection.md), for the command line tool and the Python package
// alike: one code path, the same files and the same errors.

#include "lfi/controller/bench_file.h"
#include "lfi/controller/inspection_record.h"
#include "lfi/controller/inspector.h"
#include "lfi/controller/reference_capture.h"
#include "lfi/controller/reference_package.h"
#include "lfi/core/atomic_file.h"
#include "lfi/core/part_model.h"

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

namespace lfi {

// The bench with a simulated part: the part under its camera is the one of
// `scene` (the camera's and the display's sim: URIs point at it; the
// reference stays the bench's). Errc::Config for a bench whose camera or
// display is not sim: (a physical bench inspects the part under its camera).
BenchFile withSimulatedPart(BenchFile bench, const std::filesystem::path& scene);

// The part's model the bench names ([geometry] part_model, a scene file), or null.
std::shared_ptr<const PartModel> benchPartModel(const BenchFile& bench);

// "<prefix>-<time>": the folder of one inspection or run, named by its UTC
// time (ISO 8601 without its colons, for other file systems' sake).
std::string timedFolderName(const char* prefix, const std::string& timeUtc);

// Takes the bench's reference package and writes it to its [reference]
// folder (`overwrite` Allow replaces one there). `progress` gets the step and
// its fraction done. Errc::Exists before any device opens for a package there
// and Overwrite::Refuse.
struct CaptureResult {
  ReferencePackage package;
  ReferenceCoverage coverage;
  std::string captureDevice;  // the reference capture's description
};
CaptureResult captureReference(const BenchFile& bench, Overwrite overwrite,
                               const std::function<void(const char*, double)>& progress = {});

// Adds `images` images of good parts (each the mean of the bench's inspection
// frames) to the golden model of the bench's reference package and writes it.
// `devices`: the bench, or withSimulatedPart's. `beforeEach(i)` runs before
// image i (0-based) is taken and returns false to stop: Errc::Cancelled then,
// nothing written. Returns the number of images the model holds.
int trainGoldenModel(const BenchFile& bench, const BenchFile& devices, int images,
                     const std::function<bool(int)>& beforeEach = {});

// One part inspected against the bench's reference package, blind: the record
// and its images written into `folder` (created; empty: a new timed folder in
// the bench's [output] folder), record.json never overwritten.
struct InspectResult {
  PartInspection part;
  InspectionRecord record;
  std::filesystem::path folder;
};
InspectResult inspectOnePart(const BenchFile& bench, const BenchFile& devices, const std::filesystem::path& folder);

}  // namespace lfi
