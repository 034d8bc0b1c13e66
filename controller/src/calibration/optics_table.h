// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the calibrations write into a bench file (bench_file.h): a measured
// value with its expanded uncertainty beside it as `<key>_u`, at the file's
// coverage factor, which the file states once; and the [display.optics]
// table: every key of the display's class, each with the comment given (a
// calibration then sets the values it measured again).

#include "lfi/controller/bench_file_edit.h"
#include "lfi/drivers/display.h"

#include <fmt/format.h>

#include <string>
#include <vector>

namespace lfi::detail {

// Enough digits that a value's rounding stays far below its uncertainty.
inline std::string tomlNumber(double value) {
  return fmt::format("{:.9g}", value);
}

// The file's coverage factor, stated once at its top.
inline void setCoverageFactor(BenchFileEdit& edit, double k) {
  edit.set("", "coverage_factor", tomlNumber(k), "k of every calibrated value's uncertainty, <key>_u");
}

// `key` of `table` = the values (one: a number, more: an array) with `comment`, and `<key>_u` = k times the
// standard uncertainties; the file's coverage factor set to k.
inline void setMeasured(BenchFileEdit& edit, const std::string& table, const std::string& key,
                        const std::vector<double>& values, const std::vector<double>& sigmas, double k,
                        const std::string& comment) {
  // (An uncertainty to two digits: it is not known better.)
  const auto text = [](const std::vector<double>& v, const char* format) {
    std::string out;
    for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + fmt::format(fmt::runtime(format), v[i]);
    return v.size() == 1 ? out : "[" + out + "]";
  };
  std::vector<double> expanded;
  for (const double s : sigmas) expanded.push_back(k * s);
  edit.set(table, key, text(values, "{:.9g}"), comment);
  edit.set(table, key + "_u", text(expanded, "{:.2g}"));
  setCoverageFactor(edit, k);
}

inline void setOpticsTable(BenchFileEdit& edit, const DisplayOpticsParams& o, const std::string& comment) {
  const auto set = [&](const char* key, const std::string& value) { edit.set("display.optics", key, value, comment); };
  set("optics", fmt::format("\"{}\"", toString(o.type)));
  if (fullParallax(o.type)) {
    set("packing", fmt::format("\"{}\"", toString(o.packing)));
    set("array_pitch_mm", tomlNumber(o.arrayPitch_mm));
    set("rotation_rad", tomlNumber(o.rotation_rad));
    set("array_offset_mm", fmt::format("[{}, {}]", tomlNumber(o.arrayOffsetX_mm), tomlNumber(o.arrayOffsetY_mm)));
  } else {
    set("lens_pitch_px", tomlNumber(o.lensPitch_px));
    set("slant_rad", tomlNumber(o.slant_rad));
    set("offset_px", tomlNumber(o.offset_px));
  }
  set("gap_mm", tomlNumber(o.gap_mm));
  switch (o.type) {
    case OpticsType::LensletArray:
      set("focal_length_mm", tomlNumber(o.focalLength_mm));
      set("fill_factor", tomlNumber(o.fillFactor));
      break;
    case OpticsType::PinholeArray:
      set("pinhole_diameter_mm", tomlNumber(o.pinholeDiameter_mm));
      break;
    case OpticsType::Lenticular:
      set("focal_length_mm", tomlNumber(o.focalLength_mm));
      break;
    case OpticsType::LineBarrier:
      set("slit_width_mm", tomlNumber(o.slitWidth_mm));
      break;
  }
}

}  // namespace lfi::detail
