// SPDX-License-Identifier: Apache-2.0
#include "gray_code_view.h"

#include "lfi/core/error.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace lfi::detail {

cv::Mat FrameTaker::operator()(const cv::Mat& levels, const char* what) {
  if (progress_) progress_(static_cast<double>(frames_) / total_);
  try {
    cv::Mat image = bench_.take(levels);
    ++frames_;
    return image;
  } catch (const Error& e) {
    fail(e.code(), "{}: frame {} ({}) of display '{}': {}", who_, frames_ + 1, what, display_, e.what());
  }
}

void requireLensArray(const DisplayInfo& info, const char* who) {
  if (!fullParallax(info.optics.type))
    fail(Errc::Device,
         "{}: display '{}' has {} optics; the calibration measures lens and pinhole arrays (a "
         "lenticular sheet's or a line barrier's is not built)",
         who, info.deviceId, toString(info.optics.type));
}

GrayCodeView takeGrayCode(FrameTaker& take, const DisplayInfo& info, double fullScale_dn, double secondShare,
                          double minDecoded, const char* who, const char* why) {
  const calib::CodedPatternSet set = calib::grayCodePatterns(info.panelWidth_px, info.panelHeight_px);
  const double dnPer8Bit = fullScale_dn / 255;
  calib::DecodeSettings decode;
  decode.secondShare = secondShare;
  decode.minLit_dn = std::max(1, static_cast<int>(std::lround(decode.minLit_dn * dnPer8Bit)));
  decode.minContrast_dn = std::max(1, static_cast<int>(std::lround(decode.minContrast_dn * dnPer8Bit)));
  const auto decodable = [](const cv::Mat& frame) {
    cv::Mat out;
    frame.convertTo(out, CV_16U);
    return out;
  };
  GrayCodeView view;
  view.white = take(set.white, "all white");
  view.black = take(set.black, "all black");
  cv::max(view.white - view.black, 0, view.light);
  std::vector<cv::Mat> frames;
  for (size_t k = 0; k < set.patterns.size(); ++k)
    frames.push_back(decodable(take(set.patterns[k], k % 2 == 0 ? "pattern" : "inverse pattern")));
  const auto start = Clock::now();
  view.correspondence = calib::decodeGrayCode(frames, decodable(view.white), decodable(view.black), set.layout, decode);
  view.decodeSeconds = seconds(Clock::now() - start);
  const calib::PanelCorrespondence& c = view.correspondence;
  if (c.lit == 0)
    fail(Errc::Device,
         "{}: the camera sees no change between the all-white and the all-black panel of display '{}' (none of its "
         "{} pixels by {} DN): the display is not in the camera's view, or it is dark or covered",
         who, info.deviceId, view.white.total(), decode.minLit_dn);
  if (c.decoded < minDecoded * c.lit)
    fail(Errc::Device, "{}: {} of the {} camera pixels that see display '{}' decoded, fewer than min_decoded = {}: {}",
         who, c.decoded, c.lit, info.deviceId, minDecoded, why);
  return view;
}

}  // namespace lfi::detail
