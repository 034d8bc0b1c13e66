// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/part_records.h"

#include "lfi/core/exr_io.h"
#include "lfi/core/image.h"

#include <fmt/format.h>

namespace fs = std::filesystem;

namespace lfi {

namespace {

InspectionRecord recordStart(const BenchFile& bench, std::uint64_t number, const std::string& timeUtc) {
  InspectionRecord r;
  r.part = number;
  r.time_utc = timeUtc;
  r.benchFile = fs::absolute(bench.file).string();
  r.benchHash = bench.referenceHash();
  r.reference = fs::absolute(bench.referenceFolder).string();
  r.coverageFactor = bench.coverageFactor;
  if (!bench.partModel.empty()) r.insideDepth_mm = bench.defectDepth_mm;
  return r;
}

}  // namespace

InspectionRecord partRecord(const BenchFile& bench, const Inspector& inspector, const PartInspection& part,
                            std::uint64_t number, const std::string& timeUtc, const fs::path& folder,
                            const std::string& stem) {
  InspectionRecord r = recordStart(bench, number, timeUtc);
  r.verdict = part.verdict;
  r.analysis_ms = part.analysis_ms;
  const bool keep =
      bench.saveImages == SaveImages::All || (bench.saveImages == SaveImages::Failed && !part.verdict.pass);
  if (keep) {
    const std::string image = stem + ".exr", overlay = stem + "-overlay.png";
    writeRadianceExr(
        folder / image, part.image,
        {bench.objectPixel_mm, fmt::format("part {} (DN, mean of {} frames)", number, bench.inspectionFrames),
         kCameraDigitalNumbers});
    writePngAtomically(folder / overlay, overlayImage(part.image, part.verdict, inspector.mask()), Overwrite::Refuse);
    r.images = {{"image", image}, {"overlay", overlay}};
  }
  return r;
}

InspectionRecord errorRecord(const BenchFile& bench, std::uint64_t number, const std::string& timeUtc,
                             const std::string& error) {
  InspectionRecord r = recordStart(bench, number, timeUtc);
  r.error = error;
  return r;
}

}  // namespace lfi
