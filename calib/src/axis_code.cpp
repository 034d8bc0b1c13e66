// SPDX-License-Identifier: Apache-2.0
#include "lfi/calib/axis_code.h"

#include "lfi/core/error.h"

#include <cmath>
#include <limits>

namespace lfi::calib {

AxisCodeSet axisCodePatterns(int width_px, int height_px, double slant_rad) {
  if (width_px <= 0 || height_px <= 0)
    fail(Errc::InvalidArgument, "axis code: a panel of {} x {} pixels", width_px, height_px);
  if (!(std::abs(slant_rad) < M_PI / 4))
    fail(Errc::InvalidArgument, "axis code: slant {} rad is outside ±π/4", slant_rad);
  AxisCodeSet set;
  set.slant_rad = slant_rad;
  const double t = std::tan(slant_rad);
  const auto xi = [&](int col, int row) { return (col + 0.5 - 0.5 * width_px) - (0.5 * height_px - row - 0.5) * t; };
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const int col : {0, width_px - 1})
    for (const int row : {0, height_px - 1}) lo = std::min(lo, xi(col, row)), hi = std::max(hi, xi(col, row));
  set.xi0_px = std::floor(lo);
  set.bands = static_cast<int>(std::floor(hi - set.xi0_px)) + 1;
  while ((1 << set.bits) < set.bands) ++set.bits;
  set.white = cv::Mat(height_px, width_px, CV_8UC1, cv::Scalar(255));
  set.black = cv::Mat::zeros(height_px, width_px, CV_8UC1);
  cv::Mat band(height_px, width_px, CV_32SC1);
  for (int row = 0; row < height_px; ++row)
    for (int col = 0; col < width_px; ++col) {
      const int b = static_cast<int>(std::floor(xi(col, row) - set.xi0_px));
      band.at<int>(row, col) = b ^ (b >> 1);  // its Gray code
    }
  for (int bit = set.bits - 1; bit >= 0; --bit) {
    cv::Mat pattern(height_px, width_px, CV_8UC1);
    for (int row = 0; row < height_px; ++row)
      for (int col = 0; col < width_px; ++col)
        pattern.at<std::uint8_t>(row, col) = (band.at<int>(row, col) >> bit) & 1 ? 255 : 0;
    set.patterns.push_back(pattern);
    set.patterns.push_back(255 - pattern);
  }
  return set;
}

AxisCorrespondence decodeAxisCode(const std::vector<cv::Mat>& frames, const cv::Mat& white, const cv::Mat& black,
                                  const AxisCodeSet& set, const DecodeSettings& settings) {
  if (frames.size() != set.patterns.size())
    fail(Errc::InvalidArgument, "axis code: {} frames for {} patterns", frames.size(), set.patterns.size());
  const auto asFloat = [&](const cv::Mat& m, const char* what) {
    if (m.empty() || m.channels() != 1 || m.size() != white.size())
      fail(Errc::InvalidArgument, "axis code: the {} frame is empty, not single-channel or not {} x {}", what,
           white.cols, white.rows);
    cv::Mat out;
    m.convertTo(out, CV_32F);
    return out;
  };
  const cv::Mat w = asFloat(white, "white"), b = asFloat(black, "black");
  std::vector<cv::Mat> f;
  for (const cv::Mat& m : frames) f.push_back(asFloat(m, "pattern"));
  AxisCorrespondence out;
  out.xi = cv::Mat(w.size(), CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  out.confidence = cv::Mat::zeros(w.size(), CV_32FC1);
  for (int row = 0; row < w.rows; ++row)
    for (int col = 0; col < w.cols; ++col) {
      const float light = w.at<float>(row, col) - b.at<float>(row, col);
      if (!(light >= settings.minLit_dn)) continue;
      ++out.lit;
      int gray = 0;
      float least = light;
      bool decoded = true;
      for (int bit = 0; bit < set.bits && decoded; ++bit) {
        const float d = f[2 * bit].at<float>(row, col) - f[2 * bit + 1].at<float>(row, col);
        const float contrast = std::abs(d);
        if (contrast < settings.minContrast_dn || contrast < settings.minContrastFraction * light) decoded = false;
        least = std::min(least, contrast);
        gray = (gray << 1) | (d > 0 ? 1 : 0);
      }
      if (!decoded) continue;
      int bandIndex = 0;
      for (int g = gray; g; g >>= 1) bandIndex ^= g;  // Gray to binary
      if (bandIndex >= set.bands) continue;
      out.xi.at<float>(row, col) = static_cast<float>(set.xi0_px + bandIndex + 0.5);
      out.confidence.at<float>(row, col) = least / light;
      ++out.decoded;
    }
  return out;
}

}  // namespace lfi::calib
