// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/display.h"
#include "lfi/drivers/panel_response.h"

#include "lfi/core/error.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace lfi {

const char* toString(SubpixelLayout layout) {
  switch (layout) {
    case SubpixelLayout::Mono:
      return "mono";
    case SubpixelLayout::RgbStripe:
      return "RGB stripe";
    case SubpixelLayout::BgrStripe:
      return "BGR stripe";
  }
  return "unknown";
}

const char* toString(OpticsType type) {
  switch (type) {
    case OpticsType::Lenticular:
      return "lenticular";
    case OpticsType::LineBarrier:
      return "line_barrier";
    case OpticsType::LensletArray:
      return "lenslet_array";
    case OpticsType::PinholeArray:
      return "pinhole_array";
  }
  return "unknown";
}

const char* toString(LensPacking packing) {
  switch (packing) {
    case LensPacking::Square:
      return "square";
    case LensPacking::Hexagonal:
      return "hexagonal";
  }
  return "unknown";
}

const char* toString(PresentStatus status) {
  switch (status) {
    case PresentStatus::Presented:
      return "Presented";
    case PresentStatus::Rejected:
      return "Rejected";
    case PresentStatus::Timeout:
      return "Timeout";
  }
  return "unknown";
}

const char* toString(Display::State state) {
  switch (state) {
    case Display::State::Closed:
      return "Closed";
    case Display::State::Open:
      return "Open";
    case Display::State::Showing:
      return "Showing";
  }
  return "unknown";
}

int DisplayInfo::panelType() const {
  return subpixels == SubpixelLayout::Mono ? CV_8UC1 : CV_8UC3;
}

void DisplayInfo::validate() const {
  auto check = [](bool ok, const char* field, double value, const char* range) {
    if (!ok) fail(Errc::InvalidArgument, "display info {} = {} is outside {}", field, value, range);
  };
  auto finite = [](double v) { return std::isfinite(v); };
  if (!opticsStated)
    fail(Errc::InvalidArgument,
         "the display does not state the optics in front of its panel (a monitor cannot): "
         "give them in the bench file's [display.optics] or a display calibration file");
  check(panelWidth_px >= 1 && panelWidth_px <= 16384, "panelWidth_px", panelWidth_px, "[1, 16384]");
  check(panelHeight_px >= 1 && panelHeight_px <= 16384, "panelHeight_px", panelHeight_px, "[1, 16384]");
  check(finite(pixelPitch_mm) && pixelPitch_mm > 0 && pixelPitch_mm <= 10, "pixelPitch_mm", pixelPitch_mm, "(0, 10]");
  const OpticsType type = optics.type;
  if (type == OpticsType::Lenticular || type == OpticsType::LineBarrier) {
    check(finite(optics.lensPitch_px) && optics.lensPitch_px >= 1 && optics.lensPitch_px <= 1000, "lensPitch_px",
          optics.lensPitch_px, "[1, 1000]");
    check(finite(optics.slant_rad) && std::abs(optics.slant_rad) < std::numbers::pi / 4, "slant_rad", optics.slant_rad,
          "(-pi/4, pi/4)");
    check(finite(optics.offset_px) && std::abs(optics.offset_px) <= 1e6, "offset_px", optics.offset_px, "[-1e6, 1e6]");
  } else if (type == OpticsType::LensletArray || type == OpticsType::PinholeArray) {
    // At least one panel pixel under each lens, or the display has no directions to give.
    check(finite(optics.arrayPitch_mm) && optics.arrayPitch_mm >= pixelPitch_mm && optics.arrayPitch_mm <= 100,
          "arrayPitch_mm", optics.arrayPitch_mm, "[pixelPitch_mm, 100]");
    check(finite(optics.rotation_rad) && std::abs(optics.rotation_rad) <= std::numbers::pi / 4, "rotation_rad",
          optics.rotation_rad, "[-pi/4, pi/4]");
    check(finite(optics.arrayOffsetX_mm) && std::abs(optics.arrayOffsetX_mm) <= 1e4, "arrayOffsetX_mm",
          optics.arrayOffsetX_mm, "[-1e4, 1e4]");
    check(finite(optics.arrayOffsetY_mm) && std::abs(optics.arrayOffsetY_mm) <= 1e4, "arrayOffsetY_mm",
          optics.arrayOffsetY_mm, "[-1e4, 1e4]");
    if (optics.packing != LensPacking::Square && optics.packing != LensPacking::Hexagonal)
      fail(Errc::InvalidArgument, "display info packing = {} is neither square nor hexagonal",
           static_cast<int>(optics.packing));
    if (type == OpticsType::LensletArray)
      check(finite(optics.fillFactor) && optics.fillFactor > 0 && optics.fillFactor <= 1, "fillFactor",
            optics.fillFactor, "(0, 1]");
    else
      check(finite(optics.pinholeDiameter_mm) && optics.pinholeDiameter_mm > 0 &&
                optics.pinholeDiameter_mm <= optics.arrayPitch_mm,
            "pinholeDiameter_mm", optics.pinholeDiameter_mm, "(0, arrayPitch_mm]");
  } else {
    fail(Errc::InvalidArgument, "display info optics type = {} is not a known class", static_cast<int>(type));
  }
  // (A gap below a micrometre is no display; it would also put the rays' slopes
  // past what double precision maps onto the light field's disc.)
  check(finite(optics.gap_mm) && optics.gap_mm >= 1e-3 && optics.gap_mm <= 100, "gap_mm", optics.gap_mm,
        "[0.001, 100]");
  if (type == OpticsType::Lenticular || type == OpticsType::LensletArray)
    check(finite(optics.focalLength_mm) && optics.focalLength_mm > 0, "focalLength_mm", optics.focalLength_mm,
          "(0, inf) for a lens display");
  if (type == OpticsType::LineBarrier)
    check(finite(optics.slitWidth_mm) && optics.slitWidth_mm > 0, "slitWidth_mm", optics.slitWidth_mm,
          "(0, inf) for a barrier display");
  check(viewCount >= 1, "viewCount", viewCount, "[1, inf)");
  check(brightnessMax >= brightnessMin, "brightnessMax", brightnessMax, "[brightnessMin, inf)");
}

void requireDisplayState(Display::State current, std::initializer_list<Display::State> allowed, const char* method,
                         const std::string& device) {
  if (std::find(allowed.begin(), allowed.end(), current) != allowed.end()) return;
  std::vector<std::string> names;
  for (Display::State s : allowed) names.emplace_back(toString(s));
  fail(Errc::InvalidArgument, "{}: {} is not allowed in state {} (allowed: {})", device, method, toString(current),
       fmt::join(names, ", "));
}

void requirePanelImage(const DisplayInfo& info, const cv::Mat& panel, const std::string& device) {
  if (panel.empty() || panel.type() != info.panelType() || panel.cols != info.panelWidth_px ||
      panel.rows != info.panelHeight_px)
    fail(Errc::InvalidArgument, "{}: show needs a {}x{} {} panel image, got {}x{} of type {}", device,
         info.panelWidth_px, info.panelHeight_px, info.panelType() == CV_8UC1 ? "CV_8UC1" : "CV_8UC3", panel.cols,
         panel.rows, panel.type());
}

cv::Mat panelFromLevels(const cv::Mat& levels, const DisplayInfo& info, const PanelResponse* response) {
  if (levels.type() != CV_8UC1 && levels.type() != CV_32FC1 && levels.type() != info.panelType())
    fail(Errc::InvalidArgument, "panel levels: {} is not CV_8UC1, CV_32FC1 or the panel's {}",
         cv::typeToString(levels.type()), cv::typeToString(info.panelType()));
  if (levels.cols != info.panelWidth_px || levels.rows != info.panelHeight_px)
    fail(Errc::InvalidArgument, "panel levels: {} x {}, the display {} has a {} x {} panel", levels.cols, levels.rows,
         info.deviceId, info.panelWidth_px, info.panelHeight_px);
  if (levels.type() == info.panelType()) return levels;
  if (levels.type() == CV_32FC1 && response) return response->drive(levels);
  cv::Mat mono;
  if (levels.type() == CV_8UC1) {
    mono = levels;
  } else {
    double lo = 0, hi = 0;
    cv::minMaxLoc(levels, &lo, &hi);
    if (!(lo >= 0 && hi <= 1))  // (NaN fails both)
      fail(Errc::InvalidArgument, "panel levels: drive levels {} .. {} are outside [0, 1]", lo, hi);
    levels.convertTo(mono, CV_8U, 255.0);
  }
  if (info.subpixelsPerPixel() == 1) return mono;
  cv::Mat panel;
  cv::merge(std::vector<cv::Mat>(static_cast<size_t>(info.subpixelsPerPixel()), mono), panel);
  return panel;
}

}  // namespace lfi
