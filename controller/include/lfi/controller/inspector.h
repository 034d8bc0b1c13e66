// SPDX-License-Identifier: Apache-2.0
#pragma once
// Part after part against a reference package (reference_package.h): the
// package's reference shown once (its panel image, or its light field with
// the drive scale it was trained with),
// then for each part its image (the mean of the bench's `frames`), the
// golden-model comparison (defects.h) and the verdict by the bench's rules
// (verdict.h). No ground truth is used. The camera noise floor of the model is
// the bench's, for a mean of `frames` frames (variance / frames).

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/bench_file.h"
#include "lfi/controller/controller.h"
#include "lfi/controller/reference_package.h"
#include "lfi/core/part_model.h"
#include "lfi/inspection/defects.h"
#include "lfi/inspection/golden_model.h"
#include "lfi/inspection/verdict.h"

#include <memory>

namespace lfi {

struct PartInspection {
  cv::Mat image;  // CV_32FC1, DN: the mean of the frames
  PartVerdict verdict;
  double analysis_ms = 0;  // from the image in hand to the verdict
};

class Inspector {
 public:
  // The devices stay the caller's; the camera must be Configured or Streaming.
  // Errc::Config when the package's panel image does not fit the display's panel.
  // With the part's model (the bench's [geometry] part_model, which the
  // caller loads), each defect is placed inside the part too.
  Inspector(const BenchFile& bench, const ReferencePackage& package, Display& display, Camera& camera,
            std::shared_ptr<const PartModel> part = nullptr);
  ~Inspector();

  // Shows the reference: the package's panel image when it has one, else its
  // light field (Errc::Device when the display refuses it).
  void showReference();
  // The part's image, not judged; throws what Controller::inspect throws, and
  // Errc::Device when the display no longer shows the reference after it
  // (Controller::requireShowing).
  cv::Mat takeImage();
  // Takes the part's image and judges it; throws what takeImage throws.
  PartInspection inspectPart();
  // Judges an image (CV_8U, CV_16U or CV_32F, the package's size).
  PartVerdict judge(const cv::Mat& image) const;

  const cv::Mat& mask() const { return mask_; }

 private:
  const BenchFile& bench_;
  double white_;
  cv::Mat mask_;
  PartFrame frame_;
  std::shared_ptr<const PartModel> part_;
  DefectFinder finder_;
  cv::Mat panel_;                                // the package's panel image, or empty
  std::unique_ptr<StoredLightField> reference_;  // else its light field (also the controller's capture)
  Controller controller_;
};

// The camera noise floor of a mean of `frames` frames.
CameraNoise noiseOfMean(const CameraNoise& perFrame, int frames);

}  // namespace lfi
