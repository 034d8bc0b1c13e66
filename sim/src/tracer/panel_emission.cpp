// SPDX-License-Identifier: Apache-2.0
// The physical light field display emitter (PanelOptics, PanelEmission in scene.h).

#include "lfi/core/error.h"
#include "lfi/sim/scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

namespace lfi::sim {

bool PanelOptics::subpixelOfRay(const Vec2& q, const Vec3& d, int& column, int& row) const {
  const std::optional<PanelSample> s = optics_.sourceOfRay(q, d);
  if (!s) return false;
  column = s->col * optics_.grid().subpixels() + s->subpixel;
  row = s->row;
  return true;
}

double PanelEmission::radiance(const Vec2& q, const Vec3& d) const {
  int column = 0, row = 0;
  if (!optics || !levels || levels->empty() || !optics->subpixelOfRay(q, d, column, row)) return 0.0;
  return brightness * levels->ptr<float>(row)[column];
}

double PanelLight::at(double level) const {
  const double v = std::clamp(level, 0.0, 1.0);
  if (table.empty()) return gamma == 1 ? v : std::pow(v, gamma);
  const double x = v * static_cast<double>(table.size() - 1);
  const auto i = std::min(static_cast<std::size_t>(x), table.size() - 2);
  const double t = x - static_cast<double>(i);
  return table[i] + t * (table[i + 1] - table[i]);
}

namespace {

// The relative radiance of `panel` (viewed as one channel: subpixels side by
// side) through `light`: 8-bit levels through a table of the 256, float ones
// through the curve (above 1: R(1) times the level).
cv::Mat lightOfPanel(const DisplayInfo& info, const PanelLight& light, const cv::Mat& flat) {
  std::array<float, 256> lut{};
  for (int i = 0; i < 256; ++i) lut[static_cast<std::size_t>(i)] = static_cast<float>(light.at(i / 255.0));
  const int sub = info.subpixelsPerPixel();
  const double cx = (info.panelWidth_px - 1) / 2.0, cy = (info.panelHeight_px - 1) / 2.0;
  const double corner2 = std::max(cx * cx + cy * cy, 1e-30), f = light.backlightFalloff / corner2;
  std::vector<float> columnLoss(static_cast<std::size_t>(flat.cols));
  for (int c = 0; c < flat.cols; ++c) {
    const double x = c / sub - cx;
    columnLoss[static_cast<std::size_t>(c)] = static_cast<float>(f * x * x);
  }
  cv::Mat levels(flat.size(), CV_32FC1);
  for (int r = 0; r < flat.rows; ++r) {
    auto* out = levels.ptr<float>(r);
    const double y = r - cy;
    const float rowLoss = static_cast<float>(f * y * y);
    for (int c = 0; c < flat.cols; ++c) {
      float radiance = 0;
      if (flat.depth() == CV_8U) {
        radiance = lut[flat.ptr<std::uint8_t>(r)[c]];
      } else {
        const float v = std::max(flat.ptr<float>(r)[c], 0.0f);  // (NaN: 0)
        radiance = v <= 1 ? static_cast<float>(light.at(v)) : v * lut[255];
      }
      out[c] = radiance * (1 - rowLoss - columnLoss[static_cast<std::size_t>(c)]);
    }
  }
  return levels;
}

}  // namespace

cv::Mat panelLevels(const DisplayInfo& info, const cv::Mat& panel, const PanelLight& light) {
  const int sub = info.subpixelsPerPixel();
  if (panel.empty()) return {};  // dark: no level image (a 16384² panel's would take 3.2 GB)
  if (panel.cols != info.panelWidth_px || panel.rows != info.panelHeight_px || panel.channels() != sub ||
      (panel.depth() != CV_8U && panel.depth() != CV_32F))
    fail(Errc::InvalidArgument,
         "display panel image: need {} x {} with {} channel(s) of 8-bit or float levels, got {} x {} with {} "
         "channel(s) of depth {}",
         info.panelWidth_px, info.panelHeight_px, sub, panel.cols, panel.rows, panel.channels(), panel.depth());
  // Interleaved channels are already the subpixels left to right: view as one channel.
  const cv::Mat flat = panel.reshape(1, panel.rows);
  if (!light.linear()) return lightOfPanel(info, light, flat);
  cv::Mat levels;  // allocated by the conversion: not zero-filled first
  if (panel.depth() == CV_8U)
    flat.convertTo(levels, CV_32F, 1.0 / 255.0);
  else
    cv::max(flat, 0.0, levels);
  return levels;
}

PanelEmission makePanelEmission(std::shared_ptr<const PanelOptics> optics, const cv::Mat& panel, double brightness) {
  if (!optics) fail(Errc::InvalidArgument, "makePanelEmission: no optics");
  if (!(brightness >= 0) || !std::isfinite(brightness))
    fail(Errc::InvalidArgument, "makePanelEmission: brightness = {} must be finite and >= 0", brightness);
  auto levels = std::make_shared<const cv::Mat>(panelLevels(optics->info(), panel));
  return PanelEmission{std::move(optics), std::move(levels), brightness};
}

}  // namespace lfi::sim
