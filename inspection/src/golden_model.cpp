// SPDX-License-Identifier: Apache-2.0
#include "lfi/inspection/golden_model.h"

#include "lfi/core/error.h"

#include <cmath>

namespace lfi {

GoldenModelTrainer::GoldenModelTrainer(const GoldenModelTrainer& other)
    : sum_(other.sum_.clone()), sumOfSquares_(other.sumOfSquares_.clone()), type_(other.type_), count_(other.count_) {}

GoldenModelTrainer& GoldenModelTrainer::operator=(const GoldenModelTrainer& other) {
  if (this != &other) *this = GoldenModelTrainer(other);
  return *this;
}

void GoldenModelTrainer::add(const cv::Mat& image) {
  if (image.empty() || image.channels() != 1)
    fail(Errc::InvalidArgument,
         "golden model: an image must be single-channel and not empty (got {} x {}, {} "
         "channels)",
         image.cols, image.rows, image.channels());
  if (image.depth() != CV_8U && image.depth() != CV_16U && image.depth() != CV_32F)
    fail(Errc::InvalidArgument, "golden model: image depth {} is not 8-bit, 16-bit or float", image.depth());
  if (count_ > 0 && (image.size() != sum_.size() || image.type() != type_))
    fail(Errc::InvalidArgument, "golden model: image {} x {} of type {} differs from the trained {} x {} of type {}",
         image.cols, image.rows, image.type(), sum_.cols, sum_.rows, type_);
  cv::Mat values;
  image.convertTo(values, CV_64F);
  if (count_ == 0) {
    sum_ = cv::Mat::zeros(image.size(), CV_64FC1);
    sumOfSquares_ = cv::Mat::zeros(image.size(), CV_64FC1);
    type_ = image.type();
  }
  sum_ += values;
  sumOfSquares_ += values.mul(values);
  ++count_;
}

GoldenModel GoldenModelTrainer::model(const CameraNoise& noise) const {
  if (count_ == 0) fail(Errc::InvalidArgument, "golden model: no image trained");
  if (!(noise.read_dn >= 0) || !(noise.gain_dnPerElectron >= 0) ||
      !std::isfinite(noise.read_dn + noise.gain_dnPerElectron))
    fail(Errc::InvalidArgument, "golden model: camera noise read {} DN, gain {} DN/e- must be finite and >= 0",
         noise.read_dn, noise.gain_dnPerElectron);
  GoldenModel m;
  m.images = count_;
  const cv::Mat mean = sum_ / count_;
  mean.convertTo(m.ideal, CV_32F);
  m.variation.create(sum_.size(), CV_32FC1);
  for (int row = 0; row < sum_.rows; ++row) {
    const double* s = sum_.ptr<double>(row);
    const double* s2 = sumOfSquares_.ptr<double>(row);
    float* out = m.variation.ptr<float>(row);
    for (int col = 0; col < sum_.cols; ++col) {
      const double mu = s[col] / count_;
      // The sample variance (n - 1), none from one image; never below the camera's noise.
      const double sample = count_ > 1 ? std::max(0.0, (s2[col] - count_ * mu * mu) / (count_ - 1)) : 0.0;
      const double floor = noise.read_dn * noise.read_dn + noise.gain_dnPerElectron * std::max(mu, 0.0);
      out[col] = static_cast<float>(std::sqrt(std::max(sample, floor)));
    }
  }
  return m;
}

cv::Mat GoldenModelTrainer::mean() const {
  if (count_ == 0) fail(Errc::InvalidArgument, "golden model: no image trained");
  cv::Mat m;
  sum_.convertTo(m, CV_32F, 1.0 / count_);
  return m;
}

cv::Mat GoldenModelTrainer::spread() const {
  return model(CameraNoise{}).variation;  // (no floor: the sample deviation itself)
}

GoldenModelTrainer GoldenModelTrainer::resume(const cv::Mat& mean, const cv::Mat& spread, int count, int imageType) {
  if (count < 1) fail(Errc::InvalidArgument, "golden model: {} images trained is not a count to resume from", count);
  if (mean.empty() || mean.type() != CV_32FC1 || spread.type() != CV_32FC1 || spread.size() != mean.size())
    fail(Errc::InvalidArgument,
         "golden model: the stored mean ({} x {}) and spread ({} x {}) must be float images "
         "of one size",
         mean.cols, mean.rows, spread.cols, spread.rows);
  if (imageType != CV_8UC1 && imageType != CV_16UC1 && imageType != CV_32FC1)
    fail(Errc::InvalidArgument, "golden model: image type {} is not 8-bit, 16-bit or float single-channel", imageType);
  double lowest = 0;
  cv::minMaxLoc(spread, &lowest);
  if (!(lowest >= 0) || !cv::checkRange(spread) || !cv::checkRange(mean))
    fail(Errc::InvalidArgument, "golden model: the stored spread has a negative or non-finite value");
  GoldenModelTrainer t;
  t.count_ = count;
  t.type_ = imageType;
  mean.convertTo(t.sum_, CV_64F, count);
  // sum of squares = (n - 1) s² + n μ²
  cv::Mat m64, s64;
  mean.convertTo(m64, CV_64F);
  spread.convertTo(s64, CV_64F);
  t.sumOfSquares_ = s64.mul(s64) * (count - 1) + m64.mul(m64) * count;
  return t;
}

}  // namespace lfi
