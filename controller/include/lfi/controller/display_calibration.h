// SPDX-License-Identifier: Apache-2.0
#pragma once
// The display's optics (a lens or pinhole array's lattice, a lenticular
// sheet's or line barrier's axes and slit) and the camera's object-space
// scale, measured with the bench's own display and camera and nothing in view
// (`lfi calibrate display`). No external target: the panel's pixel pitch is
// the known length.
//
// Lens and pinhole arrays:
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
// Lenticular sheets and line barriers:
//   code     as above                    the panel points seen along the axis
//                                        lie on the lens axes (a slit: within
//                                        its width of them), fitted with
//                                        parallel, equally spaced lines
//                                        (calib/axis_fit.h): lens pitch, slant
//                                        and offset on the panel
//   stripes  s (lenticular sheet)        the cells of every s-th axis lit, one
//                                        phase per frame: one stripe per lit
//                                        axis in the image, as wide as its
//                                        lens (a lens focused on the panel
//                                        shows its axis at every point of
//                                        it), symmetric about the axis. Each
//                                        cut into segments two pitches long;
//                                        a segment's centroid lies on the
//                                        axis, and the panel points its pixels
//                                        decoded tell where along it (nothing
//                                        bends the light along an axis): points
//                                        of known display position for the
//                                        camera's scale. A barrier's slit shows
//                                        the panel straight under it: every
//                                        decoded pixel is such a point
//   slit     1 (line barrier)            a band of n panel pixels along every
//                                        axis (n a third of the stated slit,
//                                        at least 1): behind each slit the band
//                                        is seen whole and the white panel over
//                                        the slit's width, so the slit is
//                                        n·q·cos(slant) times the white frame's
//                                        light over the band's
// The gap (and a lens's focal length) is not visible along the axis: `lfi
// calibrate part` measures it through the part.
//
// Uncertainty: the fits' standard uncertainties (covariances scaled by their
// residuals, clustered by lens column and row or by axis); the camera's scale
// carries the lens pitch's relative one too; the slit's is the spread of its
// value over the axes in view, over √axes. The calibration states expanded
// uncertainties U = k·σ with k = 2 (about 95 % for normal errors; GUM).
//
// Refusals (Errc::Device, naming the display): the display not visible (no
// camera pixel brighter under the all-white panel by the decoder's minLit);
// fewer than `min_decoded` of the lit pixels decoded; the lattice fit's and
// the axis fit's refusals (too few lens centres or axes, the residual too
// large for the model: a part in view, another packing, another slant or
// pitch); fewer than 6 spots or stripe segments; a slit too narrow for the
// band and its pixel phase to lie within it, or fewer than 3 slits whole in
// view.

#include "lfi/calib/axis_fit.h"
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
  int spotPeriod = 4;         // s: one lens in s along each lattice axis (one axis in s) lit per frame (2 .. 16)
  double spotRadius = 0.15;   // the disc lit about a lens centre, in pitches (at least 1.5 panel pixels)
  double minDecoded = 0.3;    // of the lit camera pixels
  double secondShare = 0;     // calib::DecodeSettings::secondShare (0: each camera pixel's brightest lens)
  double coverageFactor = 2;  // k of the expanded uncertainties
};

struct DisplayCalibration {
  DisplayInfo nominal;           // what the display states
  DisplayOpticsParams optics;    // nominal, with the measured values
  calib::LatticeFit lattice;     // a lens or pinhole array's
  calib::AxisFit axes;           // a lenticular sheet's or line barrier's
  double slitWidthSigma_mm = 0;  // a line barrier's (its width in `optics`)
  calib::CameraScaleFit camera;
  cv::Size image;  // the camera's
  double coverageFactor = 2;
  int frames = 0;
  int lit = 0, decoded = 0;   // camera pixels
  int spots = 0;              // spots (stripe segments) in the camera fit
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
// [display.optics] with the class, the measured values (an array's packing,
// pitch, rotation and offset; a sheet's or barrier's lens pitch, slant and
// offset, a barrier's slit width), each with its `<key>_u`, and the values it
// does not measure (gap, focal length, fill factor or pinhole diameter) as the
// display states them.
void setDisplayCalibration(BenchFileEdit& edit, const DisplayCalibration& calibration, const std::string& stampUtc);

// The calibration's record (JSON, format "lfi-calibration-record" version 1):
// what, when, how, the devices, every value with its standard and expanded
// uncertainty, the residuals, the frames and the time taken; the values
// before (the bench's scale, the optics the display stated), as `previous`.
std::string displayCalibrationRecord(const DisplayCalibration& calibration, const BenchFile& bench,
                                     const std::string& stampUtc, const std::string& cameraDescription);

}  // namespace lfi
