// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/optics/panel_grid.h"

#include <algorithm>
#include <cmath>

namespace lfi {

std::optional<PanelSample> PanelGrid::sampleAt(const Vec2& p) const {
  const double colF = p.x / pitch_ + 0.5 * width_;
  const double rowF = 0.5 * height_ - p.y / pitch_;
  if (!(colF >= 0 && colF < width_ && rowF >= 0 && rowF < height_)) return std::nullopt;  // (NaN too)
  PanelSample s;
  s.col = static_cast<int>(colF);
  s.row = static_cast<int>(rowF);
  s.subpixel = std::clamp(static_cast<int>((colF - s.col) * subpixels_), 0, subpixels_ - 1);
  return s;
}

}  // namespace lfi
