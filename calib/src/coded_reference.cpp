// SPDX-License-Identifier: Apache-2.0
#include "lfi/calib/coded_reference.h"

#include "lfi/core/error.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace lfi::calib {

namespace {

void checkMask(const char* what, cv::Size camera, const cv::Mat& mask) {
  if (!mask.empty() && (mask.size() != camera || mask.type() != CV_8UC1))
    fail(Errc::InvalidArgument, "{}: the mask ({} x {}, type {}) is not an 8-bit image of the camera's {} x {}", what,
         mask.cols, mask.rows, cv::typeToString(mask.type()), camera.width, camera.height);
}

bool inMask(const cv::Mat& mask, int row, int col) {
  return mask.empty() || mask.at<std::uint8_t>(row, col) != 0;
}

void checkImage(const char* what, const PanelLinks& links, const cv::Mat& image, const cv::Mat& mask) {
  if (image.size() != links.cameraSize() || image.channels() != 1)
    fail(Errc::InvalidArgument,
         "{}: the image ({} x {}, {} channels) is not a single-channel image of the camera's "
         "{} x {}",
         what, image.cols, image.rows, image.channels(), links.cameraSize().width, links.cameraSize().height);
  checkMask(what, links.cameraSize(), mask);
}

}  // namespace

PanelLinks::PanelLinks(cv::Size camera, cv::Size panel) : camera_(camera), panel_(panel) {
  if (camera.empty() || panel.empty())
    fail(Errc::InvalidArgument, "panel links: the camera ({} x {}) or the panel ({} x {}) is empty", camera.width,
         camera.height, panel.width, panel.height);
  linked_.assign(static_cast<size_t>(camera.area()), 0);
}

int PanelLinks::add(const PanelCorrespondence& c, const cv::Mat& mask, double minConfidence) {
  constexpr const char* what = "panel links";
  if (c.panel.type() != CV_32SC2 || c.panel.size() != camera_ || c.confidence.size() != camera_)
    fail(Errc::InvalidArgument, "{}: the correspondence ({} x {}) is not a panel map of the camera's {} x {}", what,
         c.panel.cols, c.panel.rows, camera_.width, camera_.height);
  checkMask(what, camera_, mask);
  if (!(minConfidence >= 0 && minConfidence <= 1))
    fail(Errc::InvalidArgument, "{}: minimum confidence {} is outside [0, 1]", what, minConfidence);
  const bool two = !c.second.empty();
  int added = 0;
  for (int row = 0; row < camera_.height; ++row)
    for (int col = 0; col < camera_.width; ++col) {
      const cv::Vec2i first = c.panel.at<cv::Vec2i>(row, col);
      if (first[0] < 0 || !inMask(mask, row, col) || c.confidence.at<float>(row, col) < minConfidence) continue;
      const cv::Vec2i second = two ? c.second.at<cv::Vec2i>(row, col) : cv::Vec2i(-1, -1);
      const cv::Vec2f share = two ? c.share.at<cv::Vec2f>(row, col) : cv::Vec2f(1, 1);
      const int xs[2] = {first[0], second[0]}, ys[2] = {first[1], second[1]};
      const float xShare[2] = {share[0], 1 - share[0]}, yShare[2] = {share[1], 1 - share[1]};
      const int camera = row * camera_.width + col;
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
          if (xs[i] < 0 || ys[j] < 0) continue;
          if (xs[i] >= panel_.width || ys[j] >= panel_.height)
            fail(Errc::InvalidArgument,
                 "{}: camera pixel ({}, {}) is decoded to panel pixel ({}, {}), outside the "
                 "{} x {} panel",
                 what, col, row, xs[i], ys[j], panel_.width, panel_.height);
          links_.push_back({camera, ys[j] * panel_.width + xs[i], xShare[i] * yShare[j]});
        }
      unsigned char& linked = linked_[static_cast<size_t>(camera)];
      linkedCount_ += linked == 0;
      linked = 1;
      ++added;
    }
  return added;
}

cv::Mat panelWeights(const PanelLinks& links) {
  cv::Mat weights = cv::Mat::zeros(links.panelSize(), CV_32FC1);
  auto* w = weights.ptr<float>();
  for (const PanelLinks::Link& link : links.links()) w[link.panel] = 1;
  return weights;
}

Uniformity uniformity(const cv::Mat& image, const PanelLinks& links, const cv::Mat& mask) {
  constexpr const char* what = "uniformity";
  checkImage(what, links, image, mask);
  cv::Mat values;
  image.convertTo(values, CV_64F);
  double sum = 0, sumOfSquares = 0;
  int n = 0;
  for (int row = 0; row < values.rows; ++row)
    for (int col = 0; col < values.cols; ++col) {
      if (!links.linked(row, col) || !inMask(mask, row, col)) continue;
      const double v = values.at<double>(row, col);
      sum += v, sumOfSquares += v * v, ++n;
    }
  if (n == 0) fail(Errc::InvalidArgument, "{}: no camera pixel in the mask is linked to the panel", what);
  Uniformity u;
  u.pixels = n;
  u.mean_dn = sum / n;
  const double variance = std::max(0.0, sumOfSquares / n - u.mean_dn * u.mean_dn);
  u.cv = u.mean_dn > 0 ? std::sqrt(variance) / u.mean_dn : 0;
  return u;
}

cv::Mat refinePanelWeights(const cv::Mat& weights, const PanelLinks& links, const cv::Mat& image, const cv::Mat& mask,
                           double target_dn, double gain) {
  constexpr const char* what = "refine";
  checkImage(what, links, image, mask);
  if (weights.size() != links.panelSize() || weights.type() != CV_32FC1)
    fail(Errc::InvalidArgument, "{}: the weights ({} x {}, type {}) are not a CV_32FC1 image of the {} x {} panel",
         what, weights.cols, weights.rows, cv::typeToString(weights.type()), links.panelSize().width,
         links.panelSize().height);
  if (!(target_dn > 0) || !std::isfinite(target_dn) || !(gain > 0 && gain <= 1))
    fail(Errc::InvalidArgument, "{}: target {} DN must be positive and gain {} in (0, 1]", what, target_dn, gain);
  // Each panel pixel's camera pixels: their levels summed by the pixel's share in them, and the shares.
  const auto cells = static_cast<size_t>(weights.total());
  std::vector<double> level(cells, 0.0), count(cells, 0.0);
  cv::Mat values;
  image.convertTo(values, CV_64F);
  const auto* v = values.ptr<double>();
  const int width = links.cameraSize().width;
  for (const PanelLinks::Link& link : links.links()) {
    if (!inMask(mask, link.camera / width, link.camera % width)) continue;
    level[static_cast<size_t>(link.panel)] += link.share * v[link.camera];
    count[static_cast<size_t>(link.panel)] += link.share;
  }
  cv::Mat next = weights.clone();
  auto* w = next.ptr<float>();
  for (size_t k = 0; k < cells; ++k) {
    if (!(count[k] > 0)) continue;
    const double mean = level[k] / count[k];
    // A panel pixel seen dark goes to full drive (the most it can do); one seen at the target stays.
    const double factor = mean > 0 ? std::pow(target_dn / mean, gain) : 1e30;
    w[k] = static_cast<float>(std::clamp(w[k] * factor, 0.0, 1.0));
  }
  return next;
}

}  // namespace lfi::calib
