#include "lfi/calib/coded_reference.h"

#include "lfi/core/error.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace lfi::calib {

namespace {

void checkCamera(const char* what, const PanelCorrespondence& c, const cv::Mat& mask) {
  if (c.panel.empty() || c.panel.type() != CV_32SC2)
    fail(Errc::InvalidArgument, "{}: the correspondence is empty or not a CV_32SC2 panel map", what);
  if (!mask.empty() && (mask.size() != c.panel.size() || mask.type() != CV_8UC1))
    fail(Errc::InvalidArgument, "{}: the mask ({} x {}, type {}) is not an 8-bit image of the camera's {} x {}", what,
         mask.cols, mask.rows, cv::typeToString(mask.type()), c.panel.cols, c.panel.rows);
}

void checkImage(const char* what, const PanelCorrespondence& c, const cv::Mat& image) {
  if (image.size() != c.panel.size() || image.channels() != 1)
    fail(Errc::InvalidArgument, "{}: the image ({} x {}, {} channels) is not a single-channel image of the camera's "
         "{} x {}", what, image.cols, image.rows, image.channels(), c.panel.cols, c.panel.rows);
}

bool inMask(const cv::Mat& mask, int row, int col) { return mask.empty() || mask.at<std::uint8_t>(row, col) != 0; }

}  // namespace

cv::Mat panelWeightsFromCorrespondence(const PanelCorrespondence& c, const cv::Mat& mask, cv::Size panel,
                                       double minConfidence) {
  constexpr const char* what = "coded reference";
  checkCamera(what, c, mask);
  if (panel.width < 1 || panel.height < 1)
    fail(Errc::InvalidArgument, "{}: panel {} x {} is empty", what, panel.width, panel.height);
  if (!(minConfidence >= 0 && minConfidence <= 1))
    fail(Errc::InvalidArgument, "{}: minimum confidence {} is outside [0, 1]", what, minConfidence);
  cv::Mat weights = cv::Mat::zeros(panel, CV_32FC1);
  for (int row = 0; row < c.panel.rows; ++row)
    for (int col = 0; col < c.panel.cols; ++col) {
      const cv::Vec2i p = c.panel.at<cv::Vec2i>(row, col);
      if (p[0] < 0 || !inMask(mask, row, col) || c.confidence.at<float>(row, col) < minConfidence) continue;
      if (p[0] >= panel.width || p[1] >= panel.height)
        fail(Errc::InvalidArgument, "{}: camera pixel ({}, {}) is decoded to panel pixel ({}, {}), outside the {} x "
             "{} panel", what, col, row, p[0], p[1], panel.width, panel.height);
      weights.at<float>(p[1], p[0]) = 1;
    }
  return weights;
}

Uniformity uniformity(const cv::Mat& image, const PanelCorrespondence& c, const cv::Mat& mask) {
  constexpr const char* what = "uniformity";
  checkCamera(what, c, mask);
  checkImage(what, c, image);
  cv::Mat values;
  image.convertTo(values, CV_64F);
  double sum = 0, sumOfSquares = 0;
  int n = 0;
  for (int row = 0; row < values.rows; ++row)
    for (int col = 0; col < values.cols; ++col) {
      if (c.panel.at<cv::Vec2i>(row, col)[0] < 0 || !inMask(mask, row, col)) continue;
      const double v = values.at<double>(row, col);
      sum += v, sumOfSquares += v * v, ++n;
    }
  if (n == 0) fail(Errc::InvalidArgument, "{}: no decoded camera pixel in the mask", what);
  Uniformity u;
  u.pixels = n;
  u.mean_dn = sum / n;
  const double variance = std::max(0.0, sumOfSquares / n - u.mean_dn * u.mean_dn);
  u.cv = u.mean_dn > 0 ? std::sqrt(variance) / u.mean_dn : 0;
  return u;
}

cv::Mat refinePanelWeights(const cv::Mat& weights, const PanelCorrespondence& c, const cv::Mat& image,
                           const cv::Mat& mask, double target_dn, double gain) {
  constexpr const char* what = "refine";
  checkCamera(what, c, mask);
  checkImage(what, c, image);
  if (weights.empty() || weights.type() != CV_32FC1)
    fail(Errc::InvalidArgument, "{}: the weights are empty or not a CV_32FC1 panel image", what);
  if (!(target_dn > 0) || !std::isfinite(target_dn) || !(gain > 0 && gain <= 1))
    fail(Errc::InvalidArgument, "{}: target {} DN must be positive and gain {} in (0, 1]", what, target_dn, gain);
  // Each panel pixel's camera pixels: their summed level and count.
  const auto cells = static_cast<size_t>(weights.rows) * static_cast<size_t>(weights.cols);
  std::vector<double> level(cells, 0.0);
  std::vector<int> count(cells, 0);
  cv::Mat values;
  image.convertTo(values, CV_64F);
  for (int row = 0; row < values.rows; ++row)
    for (int col = 0; col < values.cols; ++col) {
      const cv::Vec2i p = c.panel.at<cv::Vec2i>(row, col);
      if (p[0] < 0 || !inMask(mask, row, col)) continue;
      if (p[0] >= weights.cols || p[1] >= weights.rows)
        fail(Errc::InvalidArgument, "{}: camera pixel ({}, {}) is decoded to panel pixel ({}, {}), outside the {} x "
             "{} weights", what, col, row, p[0], p[1], weights.cols, weights.rows);
      const size_t k = static_cast<size_t>(p[1]) * static_cast<size_t>(weights.cols) + static_cast<size_t>(p[0]);
      level[k] += values.at<double>(row, col);
      ++count[k];
    }
  cv::Mat next = weights.clone();
  for (int y = 0; y < weights.rows; ++y)
    for (int x = 0; x < weights.cols; ++x) {
      const size_t k = static_cast<size_t>(y) * static_cast<size_t>(weights.cols) + static_cast<size_t>(x);
      float& w = next.at<float>(y, x);
      if (count[k] == 0) continue;
      const double mean = level[k] / count[k];
      // A panel pixel seen dark goes to full drive (the most it can do); one seen at the target stays.
      const double factor = mean > 0 ? std::pow(target_dn / mean, gain) : 1e30;
      w = static_cast<float>(std::clamp(w * factor, 0.0, 1.0));
    }
  return next;
}

}  // namespace lfi::calib
