// SPDX-License-Identifier: Apache-2.0
#pragma once
// The display-to-part distance Δ, the part's lateral position and the
// display's gap, measured through the intact part with the bench's own display
// and camera (`lfi calibrate part`), against the part's model
// (lfi/core/part_model.h).
//
// Measurement: all white, all black and the Gray code patterns (as the display
// calibration's) with the intact part in place: for each camera pixel, the
// panel pixel p whose light reaches it through the part and the telecentric
// stop. The display's lens array (its stated or calibrated [display.optics])
// tells which lens p lies under (centre c) and where in it: the offset o = p − c.
//
// Model: camera pixel (u, v) looks down at x on the display's plane (the
// bench's display_per_pixel_mm and display_at_image_centre_mm, from `lfi
// calibrate display`); its ray, traced through the part model at x − L (L the
// part's reference point in the display frame), leaves the part at e with
// slope m = (d_x / d_z, d_y / d_z), and meets the display's plane, Δ below the
// reference point, at q = e + L + (Δ + e_z) / (−d_z) · (d_x, d_y). A lens
// focused on the panel (focal length = gap g) sends a ray of slope m from the
// panel point c − g m under it. So:
//   - within a lens, o = −g m: the offsets give g and L (least squares,
//     Gauss-Newton; m depends on L, not on Δ), pixels further than five robust
//     standard deviations from the fit left out;
//   - Δ moves only which lens q falls in: it is the Δ that brings each pixel's
//     q into the cell of its decoded lens, minimising Σ min(dist(q, cell), P/2)²
//     (a grid over the stated Δ ± `search`, then golden-section search).
// The lenses' focal length is taken equal to the gap (a display whose lenses
// did not focus on its panel would blur every beam it sends).
//
// Uncertainty (k = 2 expanded, as the display calibration's): g and L from the
// least squares' covariance, for each the largest of the plain one, the one
// clustered by decoded lens, and that of an error of a panel pixel / √12
// shared by the pixels of a lens (they see about the same panel pixel); Δ from
// a bootstrap over the decoded lenses (each resampled set of lenses fitted
// again, its Δ's standard deviation), L held.
//
// A lenticular sheet: the code across its axes (calib/axis_code.h; the
// camera, focused on the part, sees the display blurred along them) gives,
// per camera pixel, the band of panel points parallel to the axes its light
// comes from; o is the band's offset across its lens from the axis, the
// offsets' fit takes only their component across (n · (o + g m)), and the
// part moves in it only across the axes (lateralMeasured false: where along
// them the slopes across hardly tell, and part_centre_px is not written); Δ
// from the strip of the decoded lens that q falls in.
//
// Refusals (Errc::Device, naming the display): a line barrier (the light a
// camera pixel takes passes a slit narrower than the camera's blur at the
// display, along other rays than the model traces);
// the display out of view; fewer than `min_decoded` of the lit pixels decoded;
// no part in view (no decoded pixel's offset beyond two panel pixels: nothing
// deflects the rays); fewer than 50 decoded pixels through the part; a fit that
// does not converge (the offsets' fit after 30 steps, a gap outside half to
// twice the stated one, Δ at the edge of the search); a residual too large for
// the model (the offsets' RMS beyond three panel pixels, or more than a third
// of the pixels in another lens than Δ puts them: another part, a part
// tilted, the wrong model). Errc::Config without the camera's map on the
// display.

#include "lfi/calib/camera_scale.h"
#include "lfi/controller/bench_file.h"
#include "lfi/controller/bench_file_edit.h"
#include "lfi/core/part_model.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/light_field_capture.h"

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

namespace lfi {

struct PartCalibrationSettings {
  double search = 0.25;        // Δ searched over the stated Δ ± this fraction of it
  double minConfidence = 0.3;  // of a decoded pixel (calib::PanelCorrespondence::confidence)
  double minDecoded = 0.3;     // of the lit camera pixels
  int bootstrap = 100;         // resamplings for Δ's uncertainty
  std::uint64_t seed = 1;      // the bootstrap's
  double coverageFactor = 2;   // k
};

struct PartCalibration {
  DisplayInfo nominal;  // as the display (or the bench's [display.optics]) states it
  double statedDistance_mm = 0;
  double distance_mm = 0, distanceSigma_mm = 0;  // Δ
  Vec2 lateral_mm{0, 0}, lateralSigma_mm{0, 0};  // the part's reference point, display frame
  // False through a lenticular sheet or line barrier: the fit moved the part only across the axes (lateralSigma_mm
  // the x and y parts of that move's σ), and the bench's part_centre_px is kept.
  bool lateralMeasured = true;
  double gap_mm = 0, gapSigma_mm = 0;
  Vec2 partCentre_px{0, 0};  // L's image
  double coverageFactor = 2;
  int lit = 0, decoded = 0;  // camera pixels
  int pixels = 0;            // decoded, through the part, in the fit
  int outliers = 0;          // left out of the offsets' fit
  double offsetRms_mm = 0;   // the offsets' residual, per axis
  int otherLens = 0;         // pixels Δ puts in another lens than the decoded one
  int frames = 0;
  double seconds = 0, computeSeconds = 0;
};

// Measures through `bench` (Controller::probe()) with the part in place.
// `camera` is where the camera looks on the display; `statedDistance_mm` the
// bench's Δ, `statedPartCentre_px` where it puts the part on the image (none:
// the image's centre), the fit's start. Errc::InvalidArgument for settings
// out of range; the refusals above; what the devices throw, with the frame
// named.
PartCalibration calibratePart(BenchProbe& bench, const PartModel& part, const calib::CameraMap& camera,
                              double statedDistance_mm, std::optional<Vec2> statedPartCentre_px = std::nullopt,
                              const PartCalibrationSettings& settings = {},
                              const std::function<void(double)>& progress = {});

// What `lfi calibrate part` writes into a bench file: [geometry] distance_mm
// (Δ's one place) and part_centre_px, and [display.optics] gap_mm and
// focal_length_mm (the table added with the display's stated optics when the
// bench has none).
void setPartCalibration(BenchFileEdit& edit, const BenchFile& bench, const PartCalibration& calibration,
                        const std::string& stampUtc);

// The record (lfi-calibration-record, what "part").
std::string partCalibrationRecord(const PartCalibration& calibration, const BenchFile& bench, const PartModel& part,
                                  const std::string& stampUtc);

}  // namespace lfi
