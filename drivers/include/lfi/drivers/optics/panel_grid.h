// SPDX-License-Identifier: Apache-2.0
#pragma once
// The panel's pixel grid in the display frame (display.h): where each subpixel
// sits on the pixel plane z = -gap, and which subpixel holds a point of it.
// Pixels are square (pitch p); a pixel's subpixels are vertical stripes of
// width p / k (k = 1 mono, 3 RGB or BGR stripe), left to right. Subpixel k of
// pixel (col, row) has its centre at
//   x = (col + (k + 0.5) / K - W / 2) p,  y = (H / 2 - row - 0.5) p
// (W x H pixels; row 0 at the top, +y up). Millimetres.

#include "lfi/core/geometry.h"
#include "lfi/drivers/display.h"

#include <optional>

namespace lfi {

// A ray the display emits: origin on the plane z = 0, unit direction with z > 0.
struct DisplayRay {
  Vec3 origin_mm;
  Vec3 direction;
};

struct PanelSample {
  int col = 0;
  int row = 0;
  int subpixel = 0;  // 0..subpixelsPerPixel-1, left to right
  friend bool operator==(const PanelSample&, const PanelSample&) = default;
};

class PanelGrid {
 public:
  explicit PanelGrid(const DisplayInfo& info)
      : pitch_(info.pixelPitch_mm),
        width_(info.panelWidth_px),
        height_(info.panelHeight_px),
        subpixels_(info.subpixelsPerPixel()) {}

  Vec2 subpixelCentre(int col, int row, int subpixel) const {
    return {(col + (subpixel + 0.5) / subpixels_ - 0.5 * width_) * pitch_, (0.5 * height_ - row - 0.5) * pitch_};
  }
  // The subpixel whose area holds `p` (x, y on the pixel plane); empty off the panel.
  std::optional<PanelSample> sampleAt(const Vec2& p) const;

  int width() const { return width_; }
  int height() const { return height_; }
  int subpixels() const { return subpixels_; }
  double pitch_mm() const { return pitch_; }

 private:
  double pitch_;
  int width_, height_, subpixels_;
};

}  // namespace lfi
