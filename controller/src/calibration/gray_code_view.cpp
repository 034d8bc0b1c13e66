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

namespace {

// The decoder's thresholds, stated for 8-bit frames, at the camera's full scale.
calib::DecodeSettings scaledDecodeSettings(double fullScale_dn, double secondShare) {
  const double dnPer8Bit = fullScale_dn / 255;
  calib::DecodeSettings decode;
  decode.secondShare = secondShare;
  decode.minLit_dn = std::max(1, static_cast<int>(std::lround(decode.minLit_dn * dnPer8Bit)));
  decode.minContrast_dn = std::max(1, static_cast<int>(std::lround(decode.minContrast_dn * dnPer8Bit)));
  return decode;
}

void requireDecoded(int lit, int decoded, size_t pixels, int minLit_dn, const DisplayInfo& info, double minDecoded,
                    const char* who, const char* why) {
  if (lit == 0)
    fail(Errc::Device,
         "{}: the camera sees no change between the all-white and the all-black panel of display '{}' (none of its "
         "{} pixels by {} DN): the display is not in the camera's view, or it is dark or covered",
         who, info.deviceId, pixels, minLit_dn);
  if (decoded < minDecoded * lit)
    fail(Errc::Device, "{}: {} of the {} camera pixels that see display '{}' decoded, fewer than min_decoded = {}: {}",
         who, decoded, lit, info.deviceId, minDecoded, why);
}

}  // namespace

GrayCodeView takeGrayCode(FrameTaker& take, const DisplayInfo& info, double fullScale_dn, double secondShare,
                          double minDecoded, const char* who, const char* why) {
  const calib::CodedPatternSet set = calib::grayCodePatterns(info.panelWidth_px, info.panelHeight_px);
  const calib::DecodeSettings decode = scaledDecodeSettings(fullScale_dn, secondShare);
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
  requireDecoded(view.correspondence.lit, view.correspondence.decoded, view.white.total(), decode.minLit_dn, info,
                 minDecoded, who, why);
  return view;
}

AxisCodeView takeAxisCode(FrameTaker& take, const DisplayInfo& info, double fullScale_dn, double minDecoded,
                          const char* who, const char* why) {
  const calib::AxisCodeSet set =
      calib::axisCodePatterns(info.panelWidth_px, info.panelHeight_px, info.optics.slant_rad);
  const calib::DecodeSettings decode = scaledDecodeSettings(fullScale_dn, 0);
  AxisCodeView view;
  view.white = take(set.white, "all white");
  view.black = take(set.black, "all black");
  std::vector<cv::Mat> frames;
  for (size_t k = 0; k < set.patterns.size(); ++k)
    frames.push_back(take(set.patterns[k], k % 2 == 0 ? "axis pattern" : "inverse axis pattern"));
  const auto start = Clock::now();
  view.correspondence = calib::decodeAxisCode(frames, view.white, view.black, set, decode);
  view.decodeSeconds = seconds(Clock::now() - start);
  requireDecoded(view.correspondence.lit, view.correspondence.decoded, view.white.total(), decode.minLit_dn, info,
                 minDecoded, who, why);
  return view;
}

}  // namespace lfi::detail
