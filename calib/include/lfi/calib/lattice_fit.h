// SPDX-License-Identifier: Apache-2.0
#pragma once
// The lens (pinhole) array of a full-parallax display measured through the
// telecentric camera, with no part in view. Along the camera's axis a lens
// focused on the panel shows the panel point straight under its centre (that
// point's light leaves it parallel to the axis), and a pinhole shows what lies
// under its hole: the panel pixels a Gray code decodes (coded_patterns.h)
// gather in one small cluster per lens, centred on the lens's centre. Their
// centroids, fitted with the lattice of lens_lattice.h, give the array's
// pitch, rotation and offset on the panel's own scale: the panel's pixel
// pitch is the known length.
//
// Frame: the display frame of display.h (origin at the panel's centre, x
// along the columns, y up the panel), millimetres and radians.
//
// Fit. The lattice c(i, j) = o + P R(θ) L(i, j) with L = (i, j) (square) or
// (i + j / 2, j √3 / 2) (hexagonal) is linear in (o_x, o_y, P cos θ, P sin θ):
// least squares over the cluster centroids, each given the index of its
// nearest lattice point. The starting lattice comes from the centroids
// themselves (the median length and angle of the vectors between neighbours,
// the angle folded into the packing's symmetry about the nominal rotation),
// so the nominal pitch and rotation only need to be good to about a fifth of
// a pitch over the neighbour distance. A first fit takes the centroids within
// five pitches of the starting lattice's origin (its pitch and angle are as
// coarse as the panel's pixels), the next ones all. Centroids further than a
// quarter pitch, or five robust standard deviations, from their lattice point
// are left out as outliers (a misdecoded pixel, a ray something deflected) and
// the fit is repeated until the centroids kept do not change.
//
// Uncertainty: each centroid is known to about one panel pixel (the
// quantum q), and the error is not independent from lens to lens: the lenses
// of one lattice column sit at about the same panel column and share its
// quantisation, and so on along a row. The standard uncertainties are
// therefore the largest, for each quantity, of (1) the least-squares
// covariance σ² (JᵀJ)⁻¹ with σ² the residual variance, (2) the same
// clustered by lattice column (x residuals) and row (y residuals)
// (the sandwich H⁻¹ (Σ_g s_g s_gᵀ) H⁻¹ · G / (G − 2) over the G groups' scores
// s_g = Σ Jᵀ r), and (3) the covariance of an error of q / √12 shared by all
// the centres of a column (in x) and of a row (in y), independent between
// them; propagated to pitch, rotation and offset. The offset is given for the
// lens nearest the panel's centre, which is how lens (0, 0) is chosen (the
// lattice is the same from any lens).

#include "lfi/core/geometry.h"
#include "lfi/drivers/display.h"

#include <array>
#include <vector>

namespace lfi::calib {

struct WeightedPoint {
  Vec2 position_mm;
  double weight = 1;
};

// Joins points closer than `radius_mm` to one another (single linkage) and
// returns each group's weighted centroid and total weight, heaviest first.
// Errc::InvalidArgument for a radius that is not positive or a weight that
// is not finite and positive.
std::vector<WeightedPoint> clusterPoints(const std::vector<WeightedPoint>& points, double radius_mm);

struct LatticeFit {
  LensPacking packing = LensPacking::Square;
  double pitch_mm = 0;
  double rotation_rad = 0;  // within the packing's symmetry: |θ| <= π/4 (square), π/6 (hexagonal)
  Vec2 offset_mm{0, 0};     // the lens nearest the panel's centre
  // Standard uncertainties (one standard deviation).
  double pitchSigma_mm = 0;
  double rotationSigma_rad = 0;
  Vec2 offsetSigma_mm{0, 0};
  double residualRms_mm = 0;  // of the centroids kept, per axis
  int centres = 0;            // centroids in the fit
  int outliers = 0;           // centroids left out

  // The lattice point (lens centre) of index (i, j), and the index of the
  // lattice point nearest `p`.
  Vec2 centre(int i, int j) const;
  std::array<int, 2> nearestIndex(const Vec2& p) const;
};

// Fits the lattice to lens centres (above), `quantum_mm` the panel's pixel
// pitch. Errc::InvalidArgument for a nominal pitch or a quantum that is not
// positive; Errc::Device (the measurement does not
// show a lattice) with fewer than `minCentres` (at least 3) centres, when no
// two centres are neighbours at about the nominal pitch, when the centres
// kept do not span two rows and two columns, or when more than
// `maxOutlierShare` of them are outliers; its message says which.
LatticeFit fitLensLattice(const std::vector<WeightedPoint>& centres, LensPacking packing, double nominalPitch_mm,
                          double nominalRotation_rad, double quantum_mm, int minCentres = 9,
                          double maxOutlierShare = 0.25);

}  // namespace lfi::calib
