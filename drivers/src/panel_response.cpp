// SPDX-License-Identifier: Apache-2.0
// A panel's drive-to-light curves and backlight, and the drive for a light (panel_response.h).

#include "lfi/drivers/panel_response.h"

#include "lfi/core/error.h"

#include <algorithm>
#include <cmath>

namespace lfi {

namespace {

const char* curveName(std::size_t curves, std::size_t c) {
  if (curves == 1) return "light";
  return c == 0 ? "red" : c == 1 ? "green" : "blue";
}

}  // namespace

void PanelResponse::validate(const PanelResponseParams& params) {
  const std::vector<double>& levels = params.levels;
  if (levels.size() < 2 || levels.front() != 0 || levels.back() != 255)
    fail(Errc::InvalidArgument, "panel response: levels must run from 0 to 255 ({} given)", levels.size());
  for (std::size_t i = 1; i < levels.size(); ++i)
    if (!(levels[i] > levels[i - 1]))
      fail(Errc::InvalidArgument, "panel response: levels[{}] = {} does not rise from levels[{}] = {}", i, levels[i],
           i - 1, levels[i - 1]);
  const std::size_t curves = params.light.size();
  if (curves != 1 && curves != 3)
    fail(Errc::InvalidArgument, "panel response: {} curves (one, or red, green and blue)", curves);
  for (std::size_t c = 0; c < curves; ++c) {
    const std::vector<double>& light = params.light[c];
    const char* name = curveName(curves, c);
    if (light.size() != levels.size())
      fail(Errc::InvalidArgument, "panel response: {} has {} values for {} levels", name, light.size(), levels.size());
    if (light.front() != 0 || light.back() != 1)
      fail(Errc::InvalidArgument, "panel response: {} is {} at level 0 and {} at 255, not 0 and 1", name, light.front(),
           light.back());
    for (std::size_t i = 1; i < light.size(); ++i)
      if (!(light[i] >= light[i - 1]))  // (NaN fails)
        fail(Errc::InvalidArgument,
             "panel response: {} is not monotonic: {} at level {:g} after {} at level {:g} (a panel's light does not "
             "fall as its drive rises)",
             name, light[i], levels[i], light[i - 1], levels[i - 1]);
  }
  for (const double b : params.backlight)
    if (!std::isfinite(b)) fail(Errc::InvalidArgument, "panel response: the backlight's coefficients must be finite");
  if (params.backlight[0] != 1)
    fail(Errc::InvalidArgument, "panel response: the backlight is {} at the panel's centre, not 1",
         params.backlight[0]);
}

PanelResponse::PanelResponse(PanelResponseParams params, const DisplayInfo& info)
    : params_(std::move(params)), info_(info) {
  validate(params_);
  const std::vector<double>& levels = params_.levels;
  const std::size_t curves = params_.light.size();
  const int sub = info.subpixelsPerPixel();
  if (curves != 1 && sub != 3)
    fail(Errc::InvalidArgument, "panel response: {} curves for a panel of {} subpixel per pixel: one curve", curves,
         sub);
  for (std::size_t c = 0; c < curves; ++c) {
    const std::vector<double>& light = params_.light[c];
    std::array<double, 256> table{};
    std::size_t k = 0;
    for (int v = 0; v < 256; ++v) {
      while (k + 2 < levels.size() && v > levels[k + 1]) ++k;
      const double t = (v - levels[k]) / (levels[k + 1] - levels[k]);
      table[static_cast<std::size_t>(v)] = light[k] + t * (light[k + 1] - light[k]);
    }
    lightOfLevel_.push_back(table);
  }
  // Subpixel positions to curves: red, green, blue in the panel's order.
  if (curves == 3) {
    const bool bgr = info.subpixels == SubpixelLayout::BgrStripe;
    for (int k = 0; k < 3; ++k) curveOf_[k] = bgr ? 2 - k : k;
  }
  leastBacklight_ = 1;
  constexpr int kGrid = 65;
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) {
      const int col = static_cast<int>(std::lround(i * (info.panelWidth_px - 1) / (kGrid - 1.0)));
      const int row = static_cast<int>(std::lround(j * (info.panelHeight_px - 1) / (kGrid - 1.0)));
      leastBacklight_ = std::min(leastBacklight_, backlight(col, row));
    }
  if (!(leastBacklight_ > 0))
    fail(Errc::InvalidArgument, "panel response: the backlight falls to {:.3g} on the panel; it must stay positive",
         leastBacklight_);
}

double PanelResponse::light(double level, int curve) const {
  const auto& table = lightOfLevel_.at(static_cast<std::size_t>(curve));
  const double v = std::clamp(level, 0.0, 255.0);
  const auto i = std::min(static_cast<std::size_t>(v), std::size_t{254});
  const double t = v - static_cast<double>(i);
  return table[i] + t * (table[i + 1] - table[i]);
}

double PanelResponse::backlight(int col, int row) const {
  const double x = (col - (info_.panelWidth_px - 1) / 2.0) * info_.pixelPitch_mm;
  const double y = ((info_.panelHeight_px - 1) / 2.0 - row) * info_.pixelPitch_mm;
  const auto& b = params_.backlight;
  return b[0] + x * (b[1] + b[3] * x + b[4] * y) + y * (b[2] + b[5] * y);
}

std::uint8_t PanelResponse::driveLevel(double light, int col, int row, int subpixel) const {
  const double wanted = std::clamp(light, 0.0, 1.0) * leastBacklight_ / backlight(col, row);
  const auto& table = lightOfLevel_[static_cast<std::size_t>(curveOf_[subpixel])];
  // The first level whose light reaches it, or the one below when that is nearer.
  const auto it = std::lower_bound(table.begin(), table.end(), wanted);
  if (it == table.end()) return 255;
  const auto level = static_cast<std::size_t>(it - table.begin());
  if (level > 0 && wanted - table[level - 1] < *it - wanted) return static_cast<std::uint8_t>(level - 1);
  return static_cast<std::uint8_t>(level);
}

cv::Mat PanelResponse::drive(const cv::Mat& light) const {
  const int sub = info_.subpixelsPerPixel();
  if (light.cols != info_.panelWidth_px || light.rows != info_.panelHeight_px ||
      (light.type() != CV_32FC1 && light.type() != CV_MAKETYPE(CV_32F, sub)))
    fail(Errc::InvalidArgument, "panel light: need {} x {} of CV_32FC1 or {} float channels, got {} x {} of type {}",
         info_.panelWidth_px, info_.panelHeight_px, sub, light.cols, light.rows, light.type());
  double lo = 0, hi = 0;
  cv::minMaxLoc(light.reshape(1), &lo, &hi);
  if (!(lo >= 0 && hi <= 1))  // (NaN fails both)
    fail(Errc::InvalidArgument, "panel light: {} .. {} is outside [0, 1]", lo, hi);
  const bool alike = light.channels() == 1;
  cv::Mat panel(info_.panelHeight_px, info_.panelWidth_px, info_.panelType());
  cv::parallel_for_(cv::Range(0, info_.panelHeight_px), [&](const cv::Range& rows) {
    for (int row = rows.start; row < rows.end; ++row) {
      const float* in = light.ptr<float>(row);
      std::uint8_t* out = panel.ptr<std::uint8_t>(row);
      for (int col = 0; col < info_.panelWidth_px; ++col)
        for (int k = 0; k < sub; ++k) out[col * sub + k] = driveLevel(alike ? in[col] : in[col * sub + k], col, row, k);
    }
  });
  return panel;
}

}  // namespace lfi
