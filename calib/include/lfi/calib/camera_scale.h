// SPDX-License-Identifier: Apache-2.0
#pragma once
// The telecentric camera's object-space scale from points of known position
// in the display frame seen in its image: lens centres of a measured lens
// array (lattice_fit.h), lit one sparse set at a time so that each shows as a
// spot of its own. An object-side telecentric lens images every plane along
// its axis at one scale, so the scale found on the display's plane holds on
// the part's.
//
// Model: the affine camera display = A d + t, with d = camera pixel − the
// image's centre ((w − 1) / 2, (h − 1) / 2): A (mm per pixel: scale,
// rotation, shear and a mirror image) and t (the display point at the image's
// centre), least squares in the display's millimetres. A second fit adds the
// lens's residual radial distortion, display = A g(d) + t with
// g(d) = d (1 + κ |d|² / R²), R the distance from the centre to a corner
// pixel's centre (Gauss-Newton from the affine solution): κ R is the pixels by
// which the image's corner lies nearer the centre (κ > 0, barrel) or further
// from it (κ < 0) than an affine camera would image the same point. It is
// reported, not applied: the scale is the affine one, the field's mean, which
// is what a bench's one object_pixel_mm can hold, and κ trades with the scale
// (fitted together, the scale's uncertainty grows several times).
//
// Uncertainty: the spots of one lattice column sit at about the same phase on
// the camera's pixel grid and share the centroid's sampling error, and so on
// along a row; the covariance is the largest of the least-squares one
// (σ² (JᵀJ)⁻¹), the one clustered by lattice column (x residuals) and row
// (y residuals), as in lattice_fit.h, and the one of a stated error shared by
// the points of a column (in u) and of a row (in v): a point detector's bias,
// which depends on that phase, where the residuals are too few to show it.
// centreSigma_mm leaves out an error all the spots' centroids share (their
// sampling phase on the pixel grid moves them alike): a hundredth of a pixel
// on the simulated bench.
//
// Units: camera pixels (OpenCV's: the top-left pixel's centre at (0, 0)),
// display millimetres and radians.

#include "lfi/core/geometry.h"

#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <optional>
#include <vector>

namespace lfi::calib {

// Where an affine camera's pixels look on the display's plane (the display
// frame): display = perPixel_mm (px − c) + atImageCentre_mm, c the image's
// centre ((w − 1) / 2, (h − 1) / 2). What fitCameraScale measures, and what a
// bench file keeps ([geometry] display_per_pixel_mm, display_at_image_centre_mm).
struct CameraMap {
  cv::Matx22d perPixel_mm = cv::Matx22d::zeros();  // A: the display's (x, y) per camera pixel (u, v)
  Vec2 atImageCentre_mm{0, 0};                     // t: the display point the image's centre sees
  // One camera pixel's side on the display's (and the part's) plane: √|det A|.
  double objectPixel_mm() const { return std::sqrt(std::abs(cv::determinant(perPixel_mm))); }
  // The display point camera pixel `px` sees, and the camera pixel that sees display point `q`, on an image of
  // `image` pixels.
  Vec2 displayPoint(const Vec2& px, cv::Size image) const;
  Vec2 cameraPoint(const Vec2& q, cv::Size image) const;
};

struct CameraPoint {
  Vec2 camera_px;
  Vec2 display_mm;
  std::array<int, 2> lens{0, 0};  // the lens's lattice column and row (the uncertainty's groups)
};

struct CameraScaleFit {
  CameraMap map;                        // A and t
  double distortion_px = 0;             // κ R (the second fit)
  double objectPixel_mm = 0;            // √|det A|: one camera pixel's side on the part
  double pixelX_mm = 0, pixelY_mm = 0;  // the lengths of A's columns: a step along a row, down a column
  double rotation_rad = 0;              // of the image's rows (+u) against the display's x axis
  bool mirrored = false;                // det A < 0: the image shows the display mirrored
  // Standard uncertainties (one standard deviation).
  double objectPixelSigma_mm = 0;  // with the display scale's own
  double distortionSigma_px = 0;
  Vec2 centreSigma_mm{0, 0};
  cv::Matx22d perPixelSigma_mm = cv::Matx22d::zeros();  // each element of A's, with the display scale's own
  double residualRms_mm = 0;                            // per axis
  int points = 0;
};

// Fits the model above. The display positions share the uncertainty of the
// frame they were measured in: `display.scale` the relative standard
// uncertainty of their scale (a lens array pitch's σ / pitch), which goes into
// objectPixelSigma_mm, and `display.shift_mm` that of their origin (the lens
// array's offset), which goes into centreSigma_mm. `sharedSigma_px` is the
// standard uncertainty of the error shared by a column's (row's) points above.
// Errc::InvalidArgument for an empty image size or a negative
// `sharedSigma_px`; Errc::Device for fewer than
// 6 points or points that do not span the image in two directions.
struct DisplayFrameSigma {
  double scale = 0;
  Vec2 shift_mm{0, 0};
};
CameraScaleFit fitCameraScale(const std::vector<CameraPoint>& points, cv::Size image,
                              const DisplayFrameSigma& display = {}, double sharedSigma_px = 0);

// The centroid of `image` (CV_32FC1, the background already subtracted) in
// the square window of half-side `radius_px` about `guess`, moved to the
// centroid and taken again until it moves less than 0.01 pixel (at most 5
// times): the centre of a symmetric spot, with its light summed. Empty when the
// window leaves the image or holds less light than `minLight`.
struct Spot {
  Vec2 centre_px;
  double light = 0;
};
std::optional<Spot> spotCentroid(const cv::Mat& image, const Vec2& guess, double radius_px, double minLight);

}  // namespace lfi::calib
