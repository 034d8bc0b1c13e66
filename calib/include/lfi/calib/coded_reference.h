#pragma once
// The coded reference's panel image from decoded correspondences
// (coded_patterns.h), and its closed-loop refinement: the panel pixels whose
// light reaches the intact part's camera pixels are lit, then each one's
// weight is corrected from the camera's image of the part under them, until
// the part looks uniformly bright.
//
// Frames: panel weights are a CV_32FC1 image of the panel's size (x right,
// y down, as the display's panel image), each in [0, 1], the drive level as
// a fraction of full; camera images and the part's mask are the camera's
// (row 0 at the top), images in DN.
//
// Refinement (one step): a panel pixel p with weight w_p lights the camera
// pixels decoded to it; their mean level in the part's mask, L_p, is brought
// to the target T by w_p ← clamp(w_p · (T / L_p)^gain, 0, 1). With each
// camera pixel lit mostly by its own panel pixel the step is Newton's on a
// linear response (gain 1); a smaller gain damps the step where neighbouring
// panel pixels share camera pixels. Panel pixels no camera pixel in the mask
// is decoded to stay dark.

#include "lfi/calib/coded_patterns.h"

#include <opencv2/core.hpp>

namespace lfi::calib {

// The panel pixels that camera pixels inside `mask` (CV_8UC1, camera size;
// empty: all) are decoded to with at least `minConfidence`, at weight 1; all
// others 0. Errc::InvalidArgument for a mask of another size or type, a
// confidence outside [0, 1] or a panel size below 1.
cv::Mat panelWeightsFromCorrespondence(const PanelCorrespondence& correspondence, const cv::Mat& mask,
                                       cv::Size panel, double minConfidence);

// How uniform the part looks: the mean and the coefficient of variation
// (standard deviation / mean) of `image` over the decoded camera pixels in
// `mask`. Errc::InvalidArgument when no such pixel is there.
struct Uniformity {
  double mean_dn = 0;
  double cv = 0;
  int pixels = 0;
};
Uniformity uniformity(const cv::Mat& image, const PanelCorrespondence& correspondence, const cv::Mat& mask);

// One refinement step (above): the new weights. `image` is the camera's image
// of the part under `weights` (CV_8U, CV_16U or CV_32F, camera size).
// Errc::InvalidArgument for inputs that do not match or a target or gain out
// of range (target > 0, gain in (0, 1]).
cv::Mat refinePanelWeights(const cv::Mat& weights, const PanelCorrespondence& correspondence, const cv::Mat& image,
                           const cv::Mat& mask, double target_dn, double gain = 1.0);

}  // namespace lfi::calib
