// The physical light field display emitter (PanelOptics, PanelEmission in scene.h).

#include "lfi/core/error.h"
#include "lfi/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lfi::sim {

PanelOptics::PanelOptics(const DisplayInfo& info) : info_(info) {
  info_.validate();
  const DisplayOpticsParams& o = info_.optics;
  const double s = o.slant_rad;
  axis_ = {std::sin(s), std::cos(s)};
  normal_ = {std::cos(s), -std::sin(s)};
  pitch_ = o.lensPitch_px * info_.pixelPitch_mm * std::cos(s);
  w0_ = o.offset_px * info_.pixelPitch_mm * std::cos(s);
  gap_ = o.gap_mm;
  if (o.type == OpticsType::Lenslet) {
    defocus_ = 1 - o.gap_mm / o.focalLength_mm;
    halfSlit_ = std::numeric_limits<double>::infinity();
  } else {
    defocus_ = 1;
    halfSlit_ = 0.5 * o.slitWidth_mm;
  }
  invPitch_ = 1 / info_.pixelPitch_mm;
  halfWidth_ = 0.5 * info_.panelWidth_px;
  halfHeight_ = 0.5 * info_.panelHeight_px;
  subpixels_ = info_.subpixelsPerPixel();
}

bool PanelOptics::subpixelOfRay(const Vec2& q, const Vec3& d, int& column, int& row) const {
  if (!(d.z > 0)) return false;
  const double w = q.x * normal_.x + q.y * normal_.y;
  const double u = q.x * axis_.x + q.y * axis_.y;
  const double wm = w0_ + std::round((w - w0_) / pitch_) * pitch_;
  const double h = w - wm;
  if (!(std::abs(h) <= halfSlit_)) return false;
  const double invZ = 1 / d.z;
  const double tAcross = (d.x * normal_.x + d.y * normal_.y) * invZ;
  const double tAlong = (d.x * axis_.x + d.y * axis_.y) * invZ;
  const double wp = wm + h * defocus_ - gap_ * tAcross;
  const double up = u - gap_ * tAlong;
  // Back from (u, w) to panel x, y, then to fractional column and row.
  const double x = up * axis_.x + wp * normal_.x, y = up * axis_.y + wp * normal_.y;
  const double colF = x * invPitch_ + halfWidth_;
  const double rowF = halfHeight_ - y * invPitch_;
  if (!(colF >= 0 && colF < 2 * halfWidth_ && rowF >= 0 && rowF < 2 * halfHeight_)) return false;
  // Subpixel stripes split each pixel into `subpixels_` equal columns.
  column = std::min(static_cast<int>(colF * subpixels_), info_.panelWidth_px * subpixels_ - 1);
  row = static_cast<int>(rowF);
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
