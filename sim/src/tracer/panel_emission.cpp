// SPDX-License-Identifier: Apache-2.0
// The physical light field display emitter (PanelOptics, PanelEmission in scene.h).

#include "lfi/core/error.h"
#include "lfi/sim/scene.h"

#include <algorithm>
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

cv::Mat panelLevels(const DisplayInfo& info, const cv::Mat& panel) {
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
