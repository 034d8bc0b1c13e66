// SPDX-License-Identifier: Apache-2.0
// The part calibration's results in a bench file and its record.

#include "lfi/controller/part_calibration.h"

#include "optics_table.h"
#include "record_json.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <optional>

namespace lfi {

using detail::measured;
using detail::tomlNumber;

void setPartCalibration(BenchFileEdit& edit, const BenchFile& bench, const PartCalibration& c,
                        const std::string& stampUtc) {
  const double k = c.coverageFactor;
  const std::string comment = fmt::format("lfi calibrate part {}", stampUtc);
  detail::setMeasured(edit, "geometry", "distance_mm", {c.distance_mm}, {c.distanceSigma_mm}, k, comment);
  const double perPixel = bench.cameraOnDisplay->objectPixel_mm();
  if (c.lateralMeasured)
    detail::setMeasured(edit, "geometry", "part_centre_px", {c.partCentre_px.x, c.partCentre_px.y},
                        {c.lateralSigma_mm.x / perPixel, c.lateralSigma_mm.y / perPixel}, k, comment);
  if (!bench.displayOptics) detail::setOpticsTable(edit, c.nominal.optics, "as the display states it (not measured)");
  detail::setMeasured(edit, "display.optics", "gap_mm", {c.gap_mm}, {c.gapSigma_mm}, k, comment);
  if (c.nominal.optics.type == OpticsType::LensletArray || c.nominal.optics.type == OpticsType::Lenticular)
    detail::setMeasured(edit, "display.optics", "focal_length_mm", {c.gap_mm}, {c.gapSigma_mm}, k,
                        comment + ": the gap (the lenses focused on the panel)");
}

std::string partCalibrationRecord(const PartCalibration& c, const BenchFile& bench, const PartModel& part,
                                  const std::string& stampUtc) {
  const double k = c.coverageFactor;
  const DisplayInfo& d = c.nominal;
  nlohmann::json record = {
      {"format", "lfi-calibration-record"},
      {"version", 1},
      {"what", "part"},
      {"time_utc", stampUtc},
      {"bench", bench.file.string()},
      {"units",
       "mm, camera pixels (px); the display frame of display.h (origin at the panel's centre, x along the "
       "columns, y up the panel, z towards the camera)"},
      {"method",
       "Gray code through the display, the intact part and the telecentric camera; each decoded panel "
       "point's offset within its lens against the part model's ray slopes (gap, lateral position), "
       "and the lens each ray lands in against Δ (docs/calibration.md)"},
      {"part_model", part.description()},
      {"coverage_factor", k},
      {"display", {{"uri", bench.displayUri.text()}, {"vendor", d.vendor}, {"model", d.model}, {"serial", d.serial}}},
      {"camera", {{"uri", bench.cameraUri.text()}}},
      {"previous",
       {{"distance_mm", c.statedDistance_mm},
        {"part_centre_px", bench.partCentre_px ? nlohmann::json{bench.partCentre_px->x, bench.partCentre_px->y}
                                               : nlohmann::json("the image's centre")},
        {"gap_mm", d.optics.gap_mm}}},
      {"distance", measured(c.distance_mm, c.distanceSigma_mm, k, "mm")},
      {"lateral_x", measured(c.lateral_mm.x, c.lateralSigma_mm.x, k, "mm")},
      {"lateral_y", measured(c.lateral_mm.y, c.lateralSigma_mm.y, k, "mm")},
      {"part_centre_px", {c.partCentre_px.x, c.partCentre_px.y}},
      {"gap", measured(c.gap_mm, c.gapSigma_mm, k, "mm")},
      {"offset_residual_rms_mm", c.offsetRms_mm},
      {"pixels", c.pixels},
      {"outliers", c.outliers},
      {"rays_in_another_lens", c.otherLens},
      {"frames", c.frames},
      {"camera_pixels_lit", c.lit},
      {"camera_pixels_decoded", c.decoded},
      {"seconds", c.seconds},
      {"compute_seconds", c.computeSeconds},
  };
  return record.dump(2) + "\n";
}

}  // namespace lfi
