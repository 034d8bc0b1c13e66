// SPDX-License-Identifier: Apache-2.0
#pragma once
// The golden model of the intact part, for golden-template comparison (MVTec
// HALCON's variation model is the reference point): an ideal image and a
// per-pixel variation, trained from images of good parts or repeated frames of
// one, with the camera's own noise as the floor where few images were seen.
//
//   field      type      units  meaning
//   ideal      CV_32FC1  DN     the mean of the trained images
//   variation  CV_32FC1  DN     their sample standard deviation, at least the
//                               camera noise sqrt(read² + gain · ideal)
//   images     int       -      how many images were trained
//
// The floor matters: from a few images a pixel's sample deviation scatters
// widely (from 20, one pixel in ten thousand reads 0.4 of the true value or
// less), and such pixels would raise alarms on good parts.
//
// Images are single-channel camera frames (CV_8U, CV_16U or CV_32F) in
// digital numbers; frame: the camera image (row 0 at the top, column 0 at the left).

#include <opencv2/core.hpp>

namespace lfi {

// The camera's noise in DN: read noise, and the DN per electron that turns a
// level's shot noise into DN (variance gain · level).
struct CameraNoise {
  double read_dn = 0;
  double gain_dnPerElectron = 0;
};

struct GoldenModel {
  cv::Mat ideal;
  cv::Mat variation;
  int images = 0;
};

class GoldenModelTrainer {
 public:
  GoldenModelTrainer() = default;
  // Copies train on independently (the sums are cloned, not shared as cv::Mat copies are).
  GoldenModelTrainer(const GoldenModelTrainer& other);
  GoldenModelTrainer& operator=(const GoldenModelTrainer& other);
  GoldenModelTrainer(GoldenModelTrainer&&) = default;
  GoldenModelTrainer& operator=(GoldenModelTrainer&&) = default;

  // Adds one image of a good part. Throws Errc::InvalidArgument for an empty or
  // multi-channel image, or one whose size or type differs from the first.
  void add(const cv::Mat& image);
  int count() const { return count_; }
  // The model of the images added so far (at least one, else Errc::InvalidArgument).
  GoldenModel model(const CameraNoise& noise) const;

  // What a stored model keeps so that training can go on later: the images'
  // mean and their sample standard deviation (0 from one image; no noise
  // floor), CV_32FC1, and the type of the images trained (CV_8UC1, ...).
  cv::Mat mean() const;
  cv::Mat spread() const;
  int imageType() const { return type_; }
  // A trainer that goes on from stored statistics as if it had seen `count`
  // images of type `imageType` with this mean and spread (exact up to the
  // float rounding of the stored images). Throws Errc::InvalidArgument for
  // images that do not match, negative spreads or a count below 1.
  static GoldenModelTrainer resume(const cv::Mat& mean, const cv::Mat& spread, int count, int imageType);

 private:
  cv::Mat sum_, sumOfSquares_;  // CV_64FC1: exact enough for millions of 16-bit images
  int type_ = -1;
  int count_ = 0;
};

}  // namespace lfi
