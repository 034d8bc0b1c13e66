// SPDX-License-Identifier: Apache-2.0
// The chessboard target's corners found with OpenCV's calib3d on images of
// known answer: a board drawn under a known affine camera (each pixel the
// share of its area that is white, as a sensor integrates it), with and
// without noise; the scale fitted from them; the boards it must refuse.

#include "lfi/calib/chessboard_target.h"
#include "lfi/core/error.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

using namespace lfi;
using namespace lfi::calib;
using lfi::testing_support::throwsError;

// A board of (corners + 1) squares of `square_mm`, its inner corners' middle at `centre_px`, seen by a camera of
// `pixel_mm` per pixel turned by `rotation_rad`; white (1) between the squares and around the board, black (0)
// on the board's dark squares; each pixel the mean of 8 x 8 samples over its area.
struct Board {
  cv::Size corners{7, 5};
  double square_mm = 2.0, pixel_mm = 0.25, rotation_rad = 0.05;
  Vec2 centre_px{60.3, 48.7};

  // The target-frame point camera pixel `px` sees.
  Vec2 target(const Vec2& px) const {
    const Vec2 d = (px - centre_px) * pixel_mm;
    const double c = std::cos(rotation_rad), s = std::sin(rotation_rad);
    return {c * d.x + s * d.y, -s * d.x + c * d.y};
  }
  Vec2 camera(const Vec2& q) const {
    const double c = std::cos(rotation_rad), s = std::sin(rotation_rad);
    return centre_px + Vec2(c * q.x - s * q.y, s * q.x + c * q.y) / pixel_mm;
  }
  cv::Mat image(cv::Size size) const {
    cv::Mat out(size, CV_32FC1);
    const Vec2 half(0.5 * (corners.width + 1) * square_mm, 0.5 * (corners.height + 1) * square_mm);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x) {
        double white = 0;
        for (int b = 0; b < 8; ++b)
          for (int a = 0; a < 8; ++a) {
            const Vec2 q = target({x - 0.5 + (a + 0.5) / 8, y - 0.5 + (b + 0.5) / 8}) + half;
            const bool on = q.x >= 0 && q.y >= 0 && q.x < 2 * half.x && q.y < 2 * half.y;
            const int i = static_cast<int>(std::floor(q.x / square_mm)),
                      j = static_cast<int>(std::floor(q.y / square_mm));
            white += on && (i + j) % 2 == 0 ? 0 : 1;
          }
        out.at<float>(y, x) = static_cast<float>(white / 64);
      }
    return out;
  }
};

const cv::Size kImage{120, 100};

TEST(ChessboardTarget, FindsEveryCornerAndGivesTheCameraScale) {
  const Board board;
  const ChessboardTarget target = ChessboardTarget::parse("7x5", board.square_mm);
  const std::vector<CameraPoint> points = findChessboard(board.image(kImage), target);
  ASSERT_EQ(points.size(), 35u);
  // Neighbouring corners one square apart in the target frame, and one square's pixels apart in the image.
  for (const CameraPoint& p : points)
    for (const CameraPoint& q : points)
      if (std::abs(p.lens[0] - q.lens[0]) + std::abs(p.lens[1] - q.lens[1]) == 1) {
        EXPECT_NEAR((p.display_mm - q.display_mm).length(), board.square_mm, 1e-12);
        EXPECT_NEAR((p.camera_px - q.camera_px).length(), board.square_mm / board.pixel_mm, 0.2);
      }
  // Every found corner is a true corner of the board: the true corner nearest it within a tenth of a pixel.
  for (const CameraPoint& p : points) {
    const Vec2 q = board.target(p.camera_px) / board.square_mm;
    const Vec2 corner(std::round(q.x + 0.5 * (board.corners.width - 1)) - 0.5 * (board.corners.width - 1),
                      std::round(q.y + 0.5 * (board.corners.height - 1)) - 0.5 * (board.corners.height - 1));
    EXPECT_LT((board.camera(corner * board.square_mm) - p.camera_px).length(), 0.1) << p.camera_px;
  }
  // The scale: a point at the image's corner (78 px out) within a tenth of a pixel.
  const CameraScaleFit fit = fitCameraScale(points, kImage);
  EXPECT_NEAR(fit.objectPixel_mm, board.pixel_mm, board.pixel_mm * 0.1 / 78);
  EXPECT_NEAR(fit.pixelX_mm, board.pixel_mm, board.pixel_mm * 0.1 / 78);
  EXPECT_NEAR(fit.pixelY_mm, board.pixel_mm, board.pixel_mm * 0.1 / 78);
}

TEST(ChessboardTarget, CornersLieWithinTheDetectorsStatedBias) {
  // 100 boards of 6 x 6 squares of 6 pixels (±3 %) at random phases (±2 px) and turns (±5°) on a 56 x 56 image,
  // no noise: the corners' error along each axis, rms, against kChessboardCornerBias_px. The rms of 100 boards'
  // phases is known to about 1 / √200 = 7 %: within two of that above the stated value.
  std::mt19937 random(3);
  std::uniform_real_distribution<double> unit(-1, 1);
  const cv::Size image(56, 56);
  double sum2 = 0;
  int n = 0;
  for (int trial = 0; trial < 100; ++trial) {
    Board board;
    board.corners = {5, 5};
    board.square_mm = 3;
    board.pixel_mm = 0.5 * (1 + 0.03 * unit(random));
    board.rotation_rad = 0.09 * unit(random);
    board.centre_px = {27.5 + 2 * unit(random), 27.5 + 2 * unit(random)};
    for (const CameraPoint& p : findChessboard(board.image(image), ChessboardTarget::parse("5x5", 3))) {
      const Vec2 q = board.target(p.camera_px) / board.square_mm;
      const Vec2 error = board.camera(Vec2(std::round(q.x), std::round(q.y)) * board.square_mm) - p.camera_px;
      sum2 += error.length2() / 2;
      ++n;
    }
  }
  ASSERT_EQ(n, 2500);
  EXPECT_LE(std::sqrt(sum2 / n), kChessboardCornerBias_px * (1 + 2 / std::sqrt(200.0)));
}

TEST(ChessboardTarget, NoiseMovesTheScaleWithinItsUncertainty) {
  // Noise of 2 % of the white level, 20 draws: the fit's k = 2 uncertainty covers the scale's error in at least
  // 18 (90 %; about 95 % expected).
  const Board board;
  const cv::Mat clean = board.image(kImage);
  std::mt19937 random(7);
  std::normal_distribution<float> noise(0, 0.02f);
  int covered = 0;
  for (int draw = 0; draw < 20; ++draw) {
    cv::Mat noisy = clean.clone();
    for (float& v : cv::Mat_<float>(noisy)) v += noise(random);
    const CameraScaleFit fit = fitCameraScale(findChessboard(noisy, ChessboardTarget::parse("7x5", 2.0)), kImage, {},
                                              kChessboardCornerBias_px);
    covered += std::abs(fit.objectPixel_mm - board.pixel_mm) <= 2 * fit.objectPixelSigma_mm;
  }
  EXPECT_GE(covered, 18);
}

TEST(ChessboardTarget, RefusesABoardOfAnotherSizeAndAnImageWithoutOne) {
  const Board board;
  const cv::Mat image = board.image(kImage);
  EXPECT_TRUE(throwsError([&] { findChessboard(image, ChessboardTarget::parse("8x5", 2)); }, Errc::Device,
                          {"no chessboard of 8 x 5 inner corners, 2 mm squares"}));
  EXPECT_TRUE(
      throwsError([&] { findChessboard(cv::Mat(kImage, CV_32FC1, cv::Scalar(1)), ChessboardTarget::parse("7x5", 2)); },
                  Errc::Device, {"no chessboard of 7 x 5"}));
  // The board cut by the image's edge.
  Board cut = board;
  cut.centre_px = {20, 48.7};
  EXPECT_TRUE(throwsError([&] { findChessboard(cut.image(kImage), ChessboardTarget::parse("7x5", 2)); }, Errc::Device,
                          {"cut by the image's edge"}));
  EXPECT_TRUE(throwsError([&] { findChessboard(cv::Mat(kImage, CV_8UC1), ChessboardTarget::parse("7x5", 2)); },
                          Errc::InvalidArgument, {"CV_32FC1"}));
}

TEST(ChessboardTarget, ParsesTheCornersAndRefusesWhatIsNotABoard) {
  const ChessboardTarget t = ChessboardTarget::parse("9x6", 2.5);
  EXPECT_EQ(t.corners, cv::Size(9, 6));
  EXPECT_EQ(t.square_mm, 2.5);
  EXPECT_EQ(t.describe(), "9 x 6 inner corners, 2.5 mm squares");
  for (const char* bad : {"9", "9x", "x6", "9x6x", "9 x 6", "-9x6", "9.5x6", ""})
    EXPECT_TRUE(throwsError([&] { ChessboardTarget::parse(bad, 2); }, Errc::InvalidArgument, {"is not COLSxROWS"}))
        << bad;
  EXPECT_TRUE(throwsError([] { ChessboardTarget::parse("2x6", 2); }, Errc::InvalidArgument, {"3 .. 100"}));
  EXPECT_TRUE(throwsError([] { ChessboardTarget::parse("9x101", 2); }, Errc::InvalidArgument, {"3 .. 100"}));
  EXPECT_TRUE(throwsError([] { ChessboardTarget::parse("9x6", 0); }, Errc::InvalidArgument, {"0.001 .. 1000 mm"}));
  EXPECT_TRUE(throwsError([] { ChessboardTarget::parse("9x6", NAN); }, Errc::InvalidArgument, {"0.001 .. 1000 mm"}));
}

}  // namespace
