// SPDX-License-Identifier: Apache-2.0
#pragma once
// Calibration of the display-to-part distance Δ, the parameter the inverse
// schlieren method is most sensitive to (docs/calibration.md).
//
// Principle: radiance is constant along a ray in free space, so the light
// field recorded on a plane can be re-expressed on any parallel plane
// (propagateLightField). If the display actually sits ε further from the part
// than the plane the light field was captured on, showing the light field
// propagated by -ε restores the field at the part, and the intact part appears
// brightest. The calibration shows the light field propagated for a series of
// candidate errors, measures the intact part's brightness through the
// telecentric camera for each, and takes the centre of the peak: half-way
// between the two candidates' positions, interpolated, where the brightness
// falls below a quarter of the way down from the brightest to the dimmest.
// (The peak is flat-topped on a real display, whose angular sampling gives it
// a depth of field: its top alone does not locate it.)
//
// Units: mm. Sign: ε > 0 means the display is further from the part than Δ.

#include "lfi/core/light_field.h"

#include <opencv2/core.hpp>

#include <functional>
#include <vector>

namespace lfi::calib {

// The light field on the plane moved by dz along the plane's +z (towards the
// part for dz > 0): L'(q, d) = L(q - dz (dx/dz, dy/dz), d), sampled at every
// element centre and angular pixel centre of the same geometry with `lookup`.
// The result's distance_mm is the input's minus dz; Errc::InvalidArgument when
// that would be negative (the plane past the part) or dz is not finite.
LightField propagateLightField(const LightField& lightField, double dz_mm,
                               LightFieldLookup lookup = LightFieldLookup::Interpolated);

// Shows a light field on the display and returns the camera's image of the
// intact part (any pixel type; converted to float).
using InspectFunction = std::function<cv::Mat(const LightField&)>;

struct DisplayDistanceScan {
  std::vector<double> candidates_mm;  // the ε tried
  std::vector<double> brightness;     // figure of merit per candidate
  double dark = 0;                    // the same with the display dark (a light field of zeros)
  double noise = 0;        // the frame-to-frame noise of a mean over the region: the larger from two dark images and
                           // from the brightest candidate's two images
  double darkNoise = 0;    // the same from the two dark images alone, without the caller's floor
  double level = 0;        // the brightness at which the peak's flanks are located
  double estimate_mm = 0;  // ε at the centre of the peak
  double width_mm = 0;     // the peak's width at `level`
};

// Scans the candidate errors and returns the estimate. `roi` selects the
// part's pixels (CV_8UC1, non-zero = use; empty = the whole image); the figure
// of merit is the mean image value there. A dark light field is shown twice
// first, and the brightest candidate again after the scan: the spread of the
// difference of each pair over the region sets the noise of a mean (the larger;
// the dark pair's, a pixel's share of it, never below `pixelNoiseFloor`, in the
// image's units; for a camera's averaged digital numbers, a DN's quantisation,
// whatever the frames averaged, 1/√12: frames that are all alike, the case the
// floor is for, do not average their rounding away). Throws, with the scan's brightness
// per candidate where there is one:
//   Errc::InvalidArgument  a reference without its distance (0: not set), fewer
//                          than three candidates, candidates not finite and
//                          strictly increasing, one that puts the display at or
//                          past the part, an empty or non-CV_8UC1 ROI, a ROI of
//                          another size than the images, an image of more than one
//                          channel, or a scan whose brightness does not fall to the
//                          level on both sides of the brightest candidate (scan
//                          further that way) or rises again outside that peak to
//                          three times the noise of a mean above the level (two peaks)
//   Errc::Device           no image, non-finite values, an image of another size
//                          than the first, a brightness whose rise across the
//                          scan is not ten times the noise of a mean (display
//                          dark, camera saturated, ROI off the part), or a
//                          brightest candidate whose two means differ by more
//                          than five times the noise of their difference (drift)
//   (and whatever `inspect` throws, with its code, naming the candidate)
// What calibrateDisplayDistance checks of the reference's geometry and the
// candidates before it shows anything (a distance set, at least three finite,
// strictly increasing candidates, none at or past the part), for a caller to
// check before it captures the reference. Throws Errc::InvalidArgument.
void checkDisplayDistanceCandidates(const LightFieldGeometry& reference, const std::vector<double>& candidates_mm);

DisplayDistanceScan calibrateDisplayDistance(const LightField& captured, const InspectFunction& inspect,
                                             const std::vector<double>& candidates_mm, const cv::Mat& roi = {},
                                             double pixelNoiseFloor = 0);

}  // namespace lfi::calib
