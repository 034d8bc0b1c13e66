// SPDX-License-Identifier: Apache-2.0
#pragma once
// The display's lens (pinhole) array and the camera's object-space scale,
// measured with the bench's own display and camera and nothing in view
// (`lfi calibrate display`). No external target: the panel's pixel pitch is
// the known length.
//
//   step     frames                      what
//   code     2 + 2·⌈log2 W⌉ + 2·⌈log2 H⌉   all white, all black and the Gray code
//                                        patterns (calib/coded_patterns.h):
//                                        which panel pixels each camera pixel
//                                        sees along the axis, i.e. the pixels
//                                        under the lens centres; clustered per
//                                        lens and fitted with the lattice
//                                        (calib/lattice_fit.h): pitch, rotation
//                                        and offset on the panel
//   spots    s²                          the pixels within `spot_radius` of every
//                                        s-th lens centre along each lattice
//                                        axis lit, one phase per frame: one
//                                        spot per lens in the camera's image;
//                                        their centroids against the lens
//                                        centres give the camera's scale
//                                        (calib/camera_scale.h)
//
// A lens of an array focused on the panel sends the point under its centre
// out along the axis; the telecentric camera takes the rays within its
// aperture of the axis, from panel points within gap·NA of the centre.
// Lighting a disc about the centre wider than that (spot_radius) makes each
// spot symmetric about the lens's centre whatever the panel's pixels, so its
// centroid is the lens centre's image.
//
// Uncertainty: the fits' standard uncertainties (covariances scaled by their
// residuals); the camera's scale carries the lens pitch's relative one too.
// The calibration states expanded uncertainties U = k·σ with k = 2 (about
// 95 % for normal errors; GUM).
//
// Refusals (Errc::Device, naming the display): a display of a class without a
// lens or pinhole array (a lenticular sheet's calibration is not built); the
// display not visible (no camera pixel brighter under the all-white panel by
// the decoder's minLit); fewer than `min_decoded` of the lit pixels decoded;
// the lattice fit's refusals (too few lens centres, the residual too large
// for the model: a part in view, another packing); fewer than 6 spots.

#include "lfi/calib/camera_scale.h"
#include "lfi/calib/lattice_fit.h"
#include "lfi/controller/bench_file.h"
#include "lfi/controller/bench_file_edit.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/light_field_capture.h"

#include <functional>
#include <string>

namespace lfi {

struct DisplayCalibrationSettings {
  int spotPeriod = 4;         // s: one lens in s along each lattice axis lit per spot frame (2 .. 16)
  double spotRadius = 0.15;   // the disc lit about a lens centre, in pitches (at least 1.5 panel pixels)
  double minDecoded = 0.3;    // of the lit camera pixels
  double secondShare = 0;     // calib::DecodeSettings::secondShare (0: each camera pixel's brightest lens)
  double coverageFactor = 2;  // k of the expanded uncertainties
};

struct DisplayCalibration {
  DisplayInfo nominal;         // what the display states
  DisplayOpticsParams optics;  // nominal, with the measured pitch, rotation and offset
  calib::LatticeFit lattice;
  calib::CameraScaleFit camera;
  cv::Size image;  // the camera's
  double coverageFactor = 2;
  int frames = 0;
  int lit = 0, decoded = 0;   // camera pixels
  int spots = 0;              // spots in the camera fit
  double seconds = 0;         // the whole calibration
  double computeSeconds = 0;  // of it, decoding and fitting
};

// Measures through `bench` (Controller::probe()). `progress` gets the fraction
// of frames taken. Errc::InvalidArgument for settings out of range; the
// refusals above; what the devices throw, with the frame named.
DisplayCalibration calibrateDisplay(BenchProbe& bench, const DisplayCalibrationSettings& settings = {},
                                    const std::function<void(double)>& progress = {});

// What `lfi calibrate display` writes into a bench file (bench_file_edit.h):
// [camera] object_pixel_mm, [geometry] display_per_pixel_mm and
// display_at_image_centre_mm (where the camera looks on the display), and
// [display.optics] with the class, the packing,
// the measured pitch, rotation and offset, and the values it does not measure
// (gap, focal length, fill factor or pinhole diameter) as the display states
// them; each line's comment names the calibration, its time and its U (k).
void setDisplayCalibration(BenchFileEdit& edit, const DisplayCalibration& calibration, const std::string& stampUtc);

// The calibration's record (JSON, format "lfi-calibration-record" version 1):
// what, when, how, the devices, every value with its standard and expanded
// uncertainty, the residuals, the frames and the time taken; the values
// before (the bench's scale, the optics the display stated), as `previous`.
std::string displayCalibrationRecord(const DisplayCalibration& calibration, const BenchFile& bench,
                                     const std::string& stampUtc, const std::string& cameraDescription);

}  // namespace lfi
