// SPDX-License-Identifier: Apache-2.0
#pragma once
// The [display.optics] table the calibrations write (bench_file.h): every key
// of a lens or pinhole array's class, each with the comment given; a
// calibration then sets the values it measured again, with their own comments.

#include "lfi/controller/bench_file_edit.h"
#include "lfi/drivers/display.h"

#include <fmt/format.h>

#include <string>

namespace lfi::detail {

// Enough digits that a value's rounding stays far below its uncertainty.
inline std::string tomlNumber(double value) {
  return fmt::format("{:.9g}", value);
}

inline void setOpticsTable(BenchFileEdit& edit, const DisplayOpticsParams& o, const std::string& comment) {
  edit.set("display.optics", "optics", fmt::format("\"{}\"", toString(o.type)), comment);
  edit.set("display.optics", "packing", fmt::format("\"{}\"", toString(o.packing)), comment);
  edit.set("display.optics", "array_pitch_mm", tomlNumber(o.arrayPitch_mm), comment);
  edit.set("display.optics", "rotation_rad", tomlNumber(o.rotation_rad), comment);
  edit.set("display.optics", "array_offset_mm",
           fmt::format("[{}, {}]", tomlNumber(o.arrayOffsetX_mm), tomlNumber(o.arrayOffsetY_mm)), comment);
  edit.set("display.optics", "gap_mm", tomlNumber(o.gap_mm), comment);
  if (o.type == OpticsType::LensletArray) {
    edit.set("display.optics", "focal_length_mm", tomlNumber(o.focalLength_mm), comment);
    edit.set("display.optics", "fill_factor", tomlNumber(o.fillFactor), comment);
  } else {
    edit.set("display.optics", "pinhole_diameter_mm", tomlNumber(o.pinholeDiameter_mm), comment);
  }
}

}  // namespace lfi::detail
