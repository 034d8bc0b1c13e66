// SPDX-License-Identifier: Apache-2.0
#include "lfi/calib/chessboard_target.h"

#include "lfi/core/error.h"

#include <opencv2/calib3d.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>

namespace lfi::calib {

namespace {

// `image` to 8 bits between its 0.5th and 99.5th percentiles: a few hot or dead pixels do not set the range.
cv::Mat stretched(const cv::Mat& image) {
  std::vector<float> values(image.begin<float>(), image.end<float>());
  std::erase_if(values, [](float v) { return !std::isfinite(v); });
  if (values.empty()) return cv::Mat::zeros(image.size(), CV_8UC1);
  const auto at = [&](double share) {
    auto nth = values.begin() + static_cast<std::ptrdiff_t>(share * static_cast<double>(values.size() - 1));
    std::nth_element(values.begin(), nth, values.end());
    return static_cast<double>(*nth);
  };
  const double low = at(0.005), high = at(0.995);
  cv::Mat out;
  const double gain = high > low ? 255 / (high - low) : 0;
  image.convertTo(out, CV_8UC1, gain, -gain * low);  // (saturating; NaN goes to 0)
  return out;
}

}  // namespace

ChessboardTarget ChessboardTarget::parse(const std::string& corners, double square_mm) {
  ChessboardTarget t;
  const auto x = corners.find('x');
  const auto number = [&](std::size_t begin, std::size_t end, int& value) {
    const char* first = corners.data() + begin;
    const char* last = corners.data() + end;
    const auto [ptr, ec] = std::from_chars(first, last, value);
    return ec == std::errc() && ptr == last && first != last && *first >= '0' && *first <= '9';
  };
  if (x == std::string::npos || !number(0, x, t.corners.width) || !number(x + 1, corners.size(), t.corners.height))
    fail(Errc::InvalidArgument, "chessboard target: corners '{}' is not COLSxROWS (inner corners, e.g. 6x6)", corners);
  if (std::min(t.corners.width, t.corners.height) < 3 || std::max(t.corners.width, t.corners.height) > 100)
    fail(Errc::InvalidArgument, "chessboard target: corners '{}': each side takes 3 .. 100 inner corners", corners);
  if (!(square_mm >= 0.001 && square_mm <= 1000))
    fail(Errc::InvalidArgument, "chessboard target: a square of {} mm is outside 0.001 .. 1000 mm", square_mm);
  t.square_mm = square_mm;
  return t;
}

std::string ChessboardTarget::describe() const {
  return fmt::format("{} x {} inner corners, {:g} mm squares", corners.width, corners.height, square_mm);
}

std::vector<CameraPoint> findChessboard(const cv::Mat& image, const ChessboardTarget& target) {
  if (image.type() != CV_32FC1 || image.empty())
    fail(Errc::InvalidArgument, "findChessboard: a CV_32FC1 image is needed");
  std::vector<cv::Point2f> found;
  // ACCURACY: the corners refined on the board's own model (the sector-based detector's sub-pixel step). No
  // NORMALIZE_IMAGE: its histogram equalisation amplifies the camera's noise (a board under 2 % noise is missed).
  if (!cv::findChessboardCornersSB(stretched(image), target.corners, found, cv::CALIB_CB_ACCURACY) ||
      static_cast<int>(found.size()) != target.corners.area())
    fail(Errc::Device,
         "no chessboard of {} in the camera's {} x {} image: the target out of view, unlit, of another size, cut "
         "by the image's edge, or its squares under about 4 pixels",
         target.describe(), image.cols, image.rows);
  std::vector<CameraPoint> points;
  points.reserve(found.size());
  const Vec2 middle(0.5 * (target.corners.width - 1), 0.5 * (target.corners.height - 1));
  for (int j = 0; j < target.corners.height; ++j)
    for (int i = 0; i < target.corners.width; ++i) {
      const cv::Point2f& c = found[static_cast<std::size_t>(j * target.corners.width + i)];
      points.push_back({{c.x, c.y}, (Vec2(i, j) - middle) * target.square_mm, {i, j}});
    }
  return points;
}

}  // namespace lfi::calib
