// SPDX-License-Identifier: Apache-2.0
#pragma once
// A chessboard target (a printed board, or chrome on glass back-lit by the
// display) found in the camera's image with OpenCV's calib3d
// (cv::findChessboardCornersSB, sub-pixel corners), as points of known
// position for the camera's scale (camera_scale.h).
//
// Target frame: millimetres in the board's plane, origin at the middle of the
// inner corners, x along the corners' rows as OpenCV orders them and y along
// its columns. A chessboard of an even number of squares looks the same
// turned by 90° or 180°, and its corners carry no handedness, so the frame's
// orientation on the board (and with it the camera's rotation and mirror
// image against the board) is not determined: only lengths are (the scale,
// the pixel's two sides, the lens's distortion).
//
// Units: camera pixels (OpenCV's: the top-left pixel's centre at (0, 0)), mm.

#include "lfi/calib/camera_scale.h"

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace lfi::calib {

// The standard uncertainty of a corner's position along each image axis that
// the detector's own bias leaves: it depends on the corner's phase on the
// pixel grid, which the corners of one column (row) share, so it goes into
// fitCameraScale as the error shared by a column's (row's) points. Measured on
// boards drawn under known cameras, squares of 6 pixels at any phase and turn:
// 0.020 px rms (test: ChessboardTarget.CornersLieWithinTheDetectorsStatedBias).
inline constexpr double kChessboardCornerBias_px = 0.02;

struct ChessboardTarget {
  cv::Size corners{0, 0};  // inner corners along a row and a column of squares (OpenCV's pattern size)
  double square_mm = 0;    // a square's side

  // "COLSxROWS" inner corners and the square's side, as given on a command line.
  // Errc::InvalidArgument naming the text: not COLSxROWS, fewer than 3 or more than 100 corners a side, a
  // square outside 0.001 .. 1000 mm.
  static ChessboardTarget parse(const std::string& corners, double square_mm);
  std::string describe() const;  // "6 x 6 inner corners, 3 mm squares"
};

// The target's inner corners in `image` (CV_32FC1, the background already
// subtracted or not: the image is stretched to 8 bits between its 0.5th and
// 99.5th percentiles), each with its position in the target frame and its
// corner column and row as `lens` (the uncertainty's groups, camera_scale.h).
// Errc::Device when no board of that many corners is in the image (none in
// view, another size, too blurred or cut by the image's edge);
// Errc::InvalidArgument for an image of another type.
std::vector<CameraPoint> findChessboard(const cv::Mat& image, const ChessboardTarget& target);

}  // namespace lfi::calib
