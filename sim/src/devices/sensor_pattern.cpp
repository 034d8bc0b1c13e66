// SPDX-License-Identifier: Apache-2.0
#include "lfi/sim/devices/sensor_pattern.h"

#include "lfi/sim/render.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <random>

namespace lfi::sim {

namespace {

// Per-pixel standard normal deviates of the whole sensor, reproducible from `seed` (one stream per row).
cv::Mat normalDeviates(int width, int height, std::uint64_t seed) {
  cv::Mat z(height, width, CV_32FC1);
  for (int r = 0; r < height; ++r) {
    std::mt19937_64 engine(splitMix64(seed ^ splitMix64(static_cast<std::uint64_t>(r) + 1)));
    std::normal_distribution<float> normal;
    auto* row = z.ptr<float>(r);
    for (int c = 0; c < width; ++c) row[c] = normal(engine);
  }
  return z;
}

// The mean of each binning x binning block (the sensor's last columns and rows that make no whole block are left out).
cv::Mat binned(const cv::Mat& full, int binning) {
  if (binning == 1) return full;
  const int width = full.cols / binning, height = full.rows / binning;
  cv::Mat out;
  cv::resize(full(cv::Rect(0, 0, width * binning, height * binning)), out, cv::Size(width, height), 0, 0,
             cv::INTER_AREA);
  return out;
}

}  // namespace

SensorPattern sensorPattern(const CameraSensorParameters& p, int width, int height, int binning) {
  SensorPattern pattern;
  if (p.vignetting > 0 || p.gainFpn > 0) {
    cv::Mat response(height, width, CV_32FC1);
    const double cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
    const double corner2 = std::max(cx * cx + cy * cy, 1e-30);
    const cv::Mat z = p.gainFpn > 0 ? normalDeviates(width, height, p.patternSeed) : cv::Mat();
    for (int r = 0; r < height; ++r) {
      auto* out = response.ptr<float>(r);
      const float* n = z.empty() ? nullptr : z.ptr<float>(r);
      for (int c = 0; c < width; ++c) {
        const double r2 = ((c - cx) * (c - cx) + (r - cy) * (r - cy)) / corner2;
        const double prnu = n ? std::max(0.0, 1 + p.gainFpn * n[c]) : 1.0;
        out[c] = static_cast<float>((1 - p.vignetting * r2) * prnu);
      }
    }
    pattern.response = binned(response, binning);
  }
  if (p.blackLevel_dn != 0 || p.darkFpn_dn > 0) {
    cv::Mat offset(height, width, CV_32FC1, cv::Scalar(p.blackLevel_dn));
    if (p.darkFpn_dn > 0)  // (another stream than the response's)
      cv::scaleAdd(normalDeviates(width, height, ~p.patternSeed), p.darkFpn_dn, offset, offset);
    pattern.offset_dn = binned(offset, binning);
  }
  return pattern;
}

}  // namespace lfi::sim
