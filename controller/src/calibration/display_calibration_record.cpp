// SPDX-License-Identifier: Apache-2.0
// The display calibration's results in a bench file and its record.

#include "lfi/controller/display_calibration.h"

#include "optics_table.h"
#include "record_json.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace lfi {

using detail::measured;

void setDisplayCalibration(BenchFileEdit& edit, const DisplayCalibration& c, const std::string& stampUtc) {
  const double k = c.coverageFactor;
  const std::string comment = fmt::format("lfi calibrate display {}", stampUtc);
  const calib::CameraScaleFit& m = c.camera;
  detail::setMeasured(edit, "camera", "object_pixel_mm", {m.objectPixel_mm}, {m.objectPixelSigma_mm}, k, comment);
  const cv::Matx22d &a = m.map.perPixel_mm, &as = m.perPixelSigma_mm;
  detail::setMeasured(edit, "geometry", "display_per_pixel_mm", {a(0, 0), a(0, 1), a(1, 0), a(1, 1)},
                      {as(0, 0), as(0, 1), as(1, 0), as(1, 1)}, k, comment);
  detail::setMeasured(edit, "geometry", "display_at_image_centre_mm",
                      {m.map.atImageCentre_mm.x, m.map.atImageCentre_mm.y}, {m.centreSigma_mm.x, m.centreSigma_mm.y}, k,
                      comment);
  const DisplayOpticsParams& o = c.optics;
  detail::setOpticsTable(edit, o, "as the display states it (not measured)");
  const auto set = [&](const char* key, std::vector<double> values, std::vector<double> sigmas) {
    detail::setMeasured(edit, "display.optics", key, values, sigmas, k, comment);
  };
  if (fullParallax(o.type)) {
    set("array_pitch_mm", {o.arrayPitch_mm}, {c.lattice.pitchSigma_mm});
    set("rotation_rad", {o.rotation_rad}, {c.lattice.rotationSigma_rad});
    set("array_offset_mm", {o.arrayOffsetX_mm, o.arrayOffsetY_mm},
        {c.lattice.offsetSigma_mm.x, c.lattice.offsetSigma_mm.y});
  } else {
    set("lens_pitch_px", {o.lensPitch_px}, {c.axes.pitchSigma_px});
    set("slant_rad", {o.slant_rad}, {c.axes.slantSigma_rad});
    set("offset_px", {o.offset_px}, {c.axes.offsetSigma_px});
    if (o.type == OpticsType::LineBarrier) set("slit_width_mm", {o.slitWidth_mm}, {c.slitWidthSigma_mm});
  }
}

std::string displayCalibrationRecord(const DisplayCalibration& c, const BenchFile& bench, const std::string& stampUtc,
                                     const std::string& cameraDescription) {
  const double k = c.coverageFactor;
  const DisplayInfo& d = c.nominal;
  nlohmann::json previous = {{"object_pixel_mm", bench.objectPixel_mm}};
  if (fullParallax(d.optics.type)) {
    previous["array_pitch_mm"] = d.optics.arrayPitch_mm;
    previous["rotation_rad"] = d.optics.rotation_rad;
    previous["array_offset_mm"] = {d.optics.arrayOffsetX_mm, d.optics.arrayOffsetY_mm};
  } else {
    previous["lens_pitch_px"] = d.optics.lensPitch_px;
    previous["slant_rad"] = d.optics.slant_rad;
    previous["offset_px"] = d.optics.offset_px;
    if (d.optics.type == OpticsType::LineBarrier) previous["slit_width_mm"] = d.optics.slitWidth_mm;
  }
  nlohmann::json record = {
      {"format", "lfi-calibration-record"},
      {"version", 1},
      {"what", "display"},
      {"time_utc", stampUtc},
      {"bench", bench.file.string()},
      {"units",
       "mm, rad, camera pixels (px); the display frame of display.h (origin at the panel's centre, x "
       "along the columns, y up the panel)"},
      {"method", fullParallax(d.optics.type)
                     ? "Gray code through the display and the telecentric camera with nothing in view: the panel "
                       "pixels seen along the axis clustered per lens and fitted with the lens lattice; then spots "
                       "under every s-th lens, their centroids against the lattice fitted with an affine camera "
                       "(docs/calibration.md)"
                     : "Gray code through the display and the telecentric camera with nothing in view: the panel "
                       "pixels seen along the axis fitted with parallel, equally spaced lens axes; then the cells of "
                       "every s-th axis lit, the stripes' segment centroids against the axes (and the decoded place "
                       "along them) fitted with an affine camera; a line barrier's slit from a band along every axis "
                       "against the white panel's light (docs/calibration.md)"},
      {"coverage_factor", k},
      {"display",
       {{"uri", bench.displayUri.text()},
        {"vendor", d.vendor},
        {"model", d.model},
        {"serial", d.serial},
        {"panel_px", {d.panelWidth_px, d.panelHeight_px}},
        {"pixel_pitch_mm", d.pixelPitch_mm},
        {"optics", toString(d.optics.type)},
        {"packing", toString(d.optics.packing)}}},
      {"camera",
       {{"uri", bench.cameraUri.text()}, {"device", cameraDescription}, {"image_px", {c.image.width, c.image.height}}}},
      {"previous", previous},
      {"camera_scale",
       {{"object_pixel", measured(c.camera.objectPixel_mm, c.camera.objectPixelSigma_mm, k, "mm")},
        {"pixel_x_mm", c.camera.pixelX_mm},
        {"pixel_y_mm", c.camera.pixelY_mm},
        {"rotation_rad", c.camera.rotation_rad},
        {"mirrored", c.camera.mirrored},
        {"image_centre_on_display_mm", {c.camera.map.atImageCentre_mm.x, c.camera.map.atImageCentre_mm.y}},
        {"distortion_at_corner", measured(c.camera.distortion_px, c.camera.distortionSigma_px, k, "px")},
        {"residual_rms_mm", c.camera.residualRms_mm},
        {"spots", c.spots}}},
      {"frames", c.frames},
      {"camera_pixels_lit", c.lit},
      {"camera_pixels_decoded", c.decoded},
      {"seconds", c.seconds},
      {"compute_seconds", c.computeSeconds},
  };
  if (fullParallax(d.optics.type)) {
    record["lens_array"] = {{"pitch", measured(c.lattice.pitch_mm, c.lattice.pitchSigma_mm, k, "mm")},
                            {"rotation", measured(c.lattice.rotation_rad, c.lattice.rotationSigma_rad, k, "rad")},
                            {"offset_x", measured(c.lattice.offset_mm.x, c.lattice.offsetSigma_mm.x, k, "mm")},
                            {"offset_y", measured(c.lattice.offset_mm.y, c.lattice.offsetSigma_mm.y, k, "mm")},
                            {"residual_rms_mm", c.lattice.residualRms_mm},
                            {"centres", c.lattice.centres},
                            {"outliers", c.lattice.outliers}};
  } else {
    record["display"].erase("packing");
    record["lens_axes"] = {{"pitch", measured(c.axes.pitch_px, c.axes.pitchSigma_px, k, "px")},
                           {"slant", measured(c.axes.slant_rad, c.axes.slantSigma_rad, k, "rad")},
                           {"offset", measured(c.axes.offset_px, c.axes.offsetSigma_px, k, "px")},
                           {"residual_rms_px", c.axes.residualRms_px},
                           {"axes", c.axes.axes},
                           {"points", c.axes.points},
                           {"outliers", c.axes.outliers}};
    if (d.optics.type == OpticsType::LineBarrier)
      record["lens_axes"]["slit_width"] = measured(c.optics.slitWidth_mm, c.slitWidthSigma_mm, k, "mm");
  }
  return record.dump(2) + "\n";
}

}  // namespace lfi
