#include "lfi/inspection/defects.h"

#include "lfi/core/error.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace lfi {

namespace {

void check(const cv::Mat& image, const GoldenModel& model, const cv::Mat& mask, const DetectionSettings& s) {
  if (model.ideal.empty() || model.ideal.type() != CV_32FC1 || model.variation.size() != model.ideal.size() ||
      model.variation.type() != CV_32FC1)
    fail(Errc::InvalidArgument, "defects: the golden model is empty or not a pair of float images of one size");
  if (image.size() != model.ideal.size() || image.channels() != 1)
    fail(Errc::InvalidArgument, "defects: image {} x {} with {} channel(s) does not match the golden model's {} x {}",
         image.cols, image.rows, image.channels(), model.ideal.cols, model.ideal.rows);
  if (!mask.empty() && (mask.size() != image.size() || mask.type() != CV_8UC1))
    fail(Errc::InvalidArgument, "defects: mask {} x {} of type {} is not an 8-bit image of the image's {} x {}",
         mask.cols, mask.rows, mask.type(), image.cols, image.rows);
  if (!(s.absolute_dn >= 0) || !(s.relative >= 0) || !std::isfinite(s.absolute_dn + s.relative))
    fail(Errc::InvalidArgument, "defects: thresholds a = {} DN, b = {} must be finite and >= 0", s.absolute_dn,
         s.relative);
  if (!(s.smoothing_px >= 0 && s.smoothing_px <= 100))
    fail(Errc::InvalidArgument, "defects: smoothing {} px is outside [0, 100]", s.smoothing_px);
  if (s.closing_px < 0 || s.closing_px > 100 || s.minArea_px < 1)
    fail(Errc::InvalidArgument, "defects: closing {} px must be in [0, 100] and the minimum area {} px at least 1",
         s.closing_px, s.minArea_px);
}

}  // namespace

std::vector<Defect> findDefects(const cv::Mat& image, const GoldenModel& model, const cv::Mat& mask,
                                const DetectionSettings& settings) {
  check(image, model, mask, settings);
  cv::Mat values, difference;
  image.convertTo(values, CV_32F);
  cv::subtract(values, model.ideal, difference);

  // Smoothing lowers independent noise by the root of the sum of the kernel's
  // squared weights: (sum of k_i²) for the separable 2-D Gaussian k_i k_j.
  cv::Mat smoothed = difference;
  double noiseFactor = 1;
  if (settings.smoothing_px > 0) {
    const int size = 2 * static_cast<int>(std::ceil(3 * settings.smoothing_px)) + 1;
    const cv::Mat kernel = cv::getGaussianKernel(size, settings.smoothing_px, CV_64F);
    noiseFactor = kernel.dot(kernel);
    cv::sepFilter2D(difference, smoothed, CV_32F, kernel, kernel, cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
  }
  cv::Mat threshold;
  model.variation.convertTo(threshold, CV_32F, settings.relative * noiseFactor);
  cv::max(threshold, settings.absolute_dn, threshold);
  cv::Mat off = cv::abs(smoothed) > threshold;  // CV_8U, 255 where off
  if (settings.closing_px > 0) {
    const cv::Mat disc = cv::getStructuringElement(
        cv::MORPH_ELLIPSE, cv::Size(2 * settings.closing_px + 1, 2 * settings.closing_px + 1));
    cv::morphologyEx(off, off, cv::MORPH_CLOSE, disc);
  }
  if (!mask.empty()) off.setTo(0, mask == 0);

  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(off, labels, stats, centroids, 8, CV_32S);
  std::vector<Defect> defects;
  std::vector<double> sum(static_cast<size_t>(count), 0.0), contrastSum(static_cast<size_t>(count), 0.0),
      peak(static_cast<size_t>(count), 0.0);
  for (int row = 0; row < labels.rows; ++row) {
    const int* label = labels.ptr<int>(row);
    const float* d = difference.ptr<float>(row);
    const float* ideal = model.ideal.ptr<float>(row);
    for (int col = 0; col < labels.cols; ++col) {
      const auto k = static_cast<size_t>(label[col]);
      if (k == 0) continue;
      const double contrast = ideal[col] > 0 ? d[col] / ideal[col] : 0.0;
      sum[k] += d[col];
      contrastSum[k] += contrast;
      if (std::abs(contrast) > std::abs(peak[k])) peak[k] = contrast;
    }
  }
  for (int k = 1; k < count; ++k) {
    const int area = stats.at<int>(k, cv::CC_STAT_AREA);
    if (area < settings.minArea_px) continue;
    Defect defect;
    defect.centroid_px = {centroids.at<double>(k, 0), centroids.at<double>(k, 1)};
    defect.area_px = area;
    defect.bounds_px = {stats.at<int>(k, cv::CC_STAT_LEFT), stats.at<int>(k, cv::CC_STAT_TOP),
                        stats.at<int>(k, cv::CC_STAT_WIDTH), stats.at<int>(k, cv::CC_STAT_HEIGHT)};
    const auto i = static_cast<size_t>(k);
    defect.peakContrast = peak[i];
    defect.meanContrast = contrastSum[i] / area;
    defect.dark = sum[i] < 0;
    defects.push_back(defect);
  }
  std::sort(defects.begin(), defects.end(), [](const Defect& a, const Defect& b) { return a.area_px > b.area_px; });
  return defects;
}

}  // namespace lfi
