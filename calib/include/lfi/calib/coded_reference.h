// SPDX-License-Identifier: Apache-2.0
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
// Links: which panel pixels each camera pixel sees, gathered from one decode
// or several (a capture that decodes again with the panel pixels it has found
// left dark, to find the light that is left). A camera pixel decoded to one
// panel pixel links to it with share 1; one decoded to two sources per axis
// links to two or four, each with the product of its column's and its row's
// share of the light (PanelCorrespondence::share).
//
// Refinement (one step): a panel pixel p with weight w_p lights the camera
// pixels linked to it; their mean level, weighted by p's share in each, L_p,
// is brought to the target T by w_p ← clamp(w_p · (T / L_p)^gain, 0, 1). With
// each camera pixel lit mostly by its own panel pixel the step is Newton's on
// a linear response (gain 1); a smaller gain damps the step where panel pixels
// share camera pixels. Panel pixels no camera pixel links to stay dark.

#include "lfi/calib/coded_patterns.h"

#include <opencv2/core.hpp>

#include <vector>

namespace lfi::calib {

class PanelLinks {
 public:
  struct Link {
    int camera = 0;  // row · camera width + column
    int panel = 0;   // y · panel width + x
    float share = 1;
  };

  // Errc::InvalidArgument for an empty size.
  PanelLinks(cv::Size camera, cv::Size panel);

  // Adds the links of the camera pixels inside `mask` (CV_8UC1, camera size;
  // empty: all) decoded with at least `minConfidence`; returns how many
  // camera pixels it linked. Errc::InvalidArgument for a correspondence or
  // mask of another size, a confidence outside [0, 1], or a panel pixel
  // outside the panel.
  int add(const PanelCorrespondence& correspondence, const cv::Mat& mask, double minConfidence);

  cv::Size cameraSize() const { return camera_; }
  cv::Size panelSize() const { return panel_; }
  const std::vector<Link>& links() const { return links_; }
  // Camera pixels with a link.
  int linkedCameraPixels() const { return linkedCount_; }
  bool linked(int row, int col) const { return linked_[static_cast<size_t>(row * camera_.width + col)] != 0; }

 private:
  cv::Size camera_, panel_;
  std::vector<Link> links_;
  std::vector<unsigned char> linked_;
  int linkedCount_ = 0;
};

// Weight 1 on every linked panel pixel, 0 elsewhere (CV_32FC1, the panel's size).
cv::Mat panelWeights(const PanelLinks& links);

// How uniform the part looks: the mean and the coefficient of variation
// (standard deviation / mean) of `image` over the linked camera pixels in
// `mask` (CV_8UC1, camera size; empty: all). Errc::InvalidArgument for an
// image or mask of another size and when no such pixel is there.
struct Uniformity {
  double mean_dn = 0;
  double cv = 0;
  int pixels = 0;
};
Uniformity uniformity(const cv::Mat& image, const PanelLinks& links, const cv::Mat& mask = {});

// One refinement step (above) over the camera pixels in `mask` (empty: all):
// the new weights. `image` is the camera's image of the part under `weights`
// (CV_8U, CV_16U or CV_32F, camera size).
// Errc::InvalidArgument for inputs that do not match or a target or gain out
// of range (target > 0, gain in (0, 1]).
cv::Mat refinePanelWeights(const cv::Mat& weights, const PanelLinks& links, const cv::Mat& image, const cv::Mat& mask,
                           double target_dn, double gain = 1.0);

}  // namespace lfi::calib
