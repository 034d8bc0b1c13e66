// SPDX-License-Identifier: Apache-2.0
#pragma once
// The lens axes of a lenticular sheet (the slits of a line barrier) measured
// through the telecentric camera, with no part in view. Along the camera's
// axis a cylinder lens focused on the panel shows, at every point of the
// lens, the panel point on its axis straight across (that point's light
// leaves the lens parallel to the axis across it, and nothing bends it along
// the axis); a slit shows what lies under it. The panel pixels a Gray code
// decodes (coded_patterns.h) lie on one slanted line per lens, or in a strip
// of the slit's width about it: fitted with parallel, equally spaced lines
// they give the lens pitch, the slant and the offset of lenticular_optics.h on
// the panel's own scale.
//
// Frame and units: the display frame of display.h (origin at the panel's
// centre, x along the columns, y up the panel); the points in millimetres,
// the axes in panel pixels as lenticular_optics.h states them; the slant in
// radians from the panel's vertical, positive where the axis leans towards +x
// going up.
//
// Fit. Axis m is the line x = y tan s + c + m P (P the pitch along a row,
// c the offset of axis 0 on the centre row): linear in (tan s, c, P), least
// squares over the points in x, each given the index of its nearest axis.
// The starting axes maximise the points' phase coherence
// |Σ w e^{2πi (x − y tan s) / P}| over a grid of slants and pitches within
// `searchSlant_rad` and `searchPitch` (relative) of the nominal ones (the
// phase gives c), so the nominal slant and pitch need to be good to those
// ranges and the offset not at all. Points further than a quarter pitch, or
// five robust standard deviations (at least half a pixel), from their axis
// are left out as outliers and the fit repeated until the points kept do not
// change. The offset is given for the axis nearest the panel's centre.
//
// Uncertainty: the points of one axis share errors (they sit on the
// panel's pixel grid at phases that step along the axis; a slit's points fill
// its width unevenly), so for each quantity the largest of (1) the
// least-squares covariance, (2) the same clustered by axis (the sandwich
// H⁻¹ (Σ_m s_m s_mᵀ) H⁻¹ · G / (G − 3) over the G axes' scores), and (3) that
// of an error shared by all the points of an axis: the mean of their
// quantisation errors, a sawtooth over the N pixel columns the axis crosses
// whose whole periods average out, at most (1 px / √12) / N (an axis along
// the columns: a pixel's / √12, which no residual shows); and for the slant,
// a tilt shared by all the axes (their sawtooths lie alike on the grid) of
// that error over half the points' height. And the axes' own errors, each
// axis's mean residual, vary smoothly from axis to axis rather than
// independently (a slit's edges step through the pixels' phase from one axis
// to the next): the offset is given no better than their RMS, the pitch no
// better than that over half the span of the axes.

#include "lfi/calib/lattice_fit.h"

#include <vector>

namespace lfi::calib {

struct AxisFit {
  double pitch_px = 0;  // along a panel row
  double slant_rad = 0;
  double offset_px = 0;  // the axis nearest the panel's centre, on its centre row
  // Standard uncertainties (one standard deviation).
  double pitchSigma_px = 0, slantSigma_rad = 0, offsetSigma_px = 0;
  double residualRms_px = 0;  // of the points kept, across the axes along a row
  int points = 0;             // in the fit
  int outliers = 0;           // left out
  int axes = 0;               // with a point in the fit

  // x of axis m on panel row height y (pixels from the centre, up), and the index of the axis nearest (x, y).
  double x(int m, double y) const { return y * std::tan(slant_rad) + offset_px + m * pitch_px; }
  int nearestAxis(double x, double y) const;
};

struct AxisFitSettings {
  double searchSlant_rad = 0.05;  // the start searched over the nominal slant ± this
  double searchPitch = 0.03;      // and the nominal pitch ± this fraction of it
  int minAxes = 3;
  double maxOutlierShare = 0.25;
};

// Fits the axes to `points` (the frame above; weights the light each
// carries), `pixelPitch_mm` the panel's. Errc::InvalidArgument for a pixel or
// nominal pitch that is not positive, or settings out of range; Errc::Device (the measurement does not
// show the axes) when the points kept lie on fewer than `minAxes` axes, or
// more than `maxOutlierShare` of the weight is outliers; its message says
// which.
AxisFit fitLensAxes(const std::vector<WeightedPoint>& points, double pixelPitch_mm, double nominalPitch_px,
                    double nominalSlant_rad, const AxisFitSettings& settings = {});

}  // namespace lfi::calib
