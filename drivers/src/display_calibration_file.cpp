// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/display_calibration_file.h"

#include "lfi/core/config.h"
#include "lfi/core/error.h"

#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

namespace lfi {

namespace {

constexpr std::array kClasses = {OpticsType::Lenticular, OpticsType::LineBarrier, OpticsType::LensletArray,
                                 OpticsType::PinholeArray};

// The keys each class takes (beside "optics", "gap_mm").
std::vector<std::string> keysOf(OpticsType type) {
  switch (type) {
    case OpticsType::Lenticular:
      return {"lens_pitch_px", "slant_rad", "offset_px", "focal_length_mm"};
    case OpticsType::LineBarrier:
      return {"lens_pitch_px", "slant_rad", "offset_px", "slit_width_mm"};
    case OpticsType::LensletArray:
      return {"packing", "array_pitch_mm", "rotation_rad", "array_offset_mm", "fill_factor", "focal_length_mm"};
    case OpticsType::PinholeArray:
      return {"packing", "array_pitch_mm", "rotation_rad", "array_offset_mm", "pinhole_diameter_mm"};
  }
  return {};
}

}  // namespace

std::vector<std::pair<std::string, std::size_t>> opticsNumberKeys(OpticsType type) {
  std::vector<std::pair<std::string, std::size_t>> keys{{"gap_mm", 1}};
  for (const std::string& key : keysOf(type))
    if (key != "packing") keys.emplace_back(key, key == "array_offset_mm" ? 2 : 1);
  return keys;
}

OpticsType readOpticsClass(ConfigTable& t, OpticsType fallback) {
  std::vector<std::string> names;
  for (OpticsType c : kClasses) names.emplace_back(toString(c));
  const std::string name = t.string("optics", toString(fallback), names);
  return kClasses[static_cast<size_t>(std::find(names.begin(), names.end(), name) - names.begin())];
}

DisplayOpticsParams readDisplayOpticsTable(ConfigTable& t, const DisplayOpticsParams& base) {
  DisplayOpticsParams p = base;
  p.type = readOpticsClass(t, base.type);
  const std::vector<std::string> own = keysOf(p.type);
  for (OpticsType c : kClasses)
    for (const std::string& key : keysOf(c))
      if (t.has(key) && std::find(own.begin(), own.end(), key) == own.end())
        fail(Errc::Config, "{} is not a parameter of {} optics (those take: gap_mm, {})", t.where(key),
             toString(p.type), fmt::join(own, ", "));
  auto number = [&](const char* key, double& field, double min, double max) {
    if (t.has(key)) field = t.number(key, std::nullopt, min, max);
  };
  auto has = [&](const char* key) { return std::find(own.begin(), own.end(), key) != own.end(); };
  // The ranges DisplayInfo::validate() accepts, so that a bad value is named here, in its file and line.
  number("gap_mm", p.gap_mm, 1e-3, 100);
  if (has("lens_pitch_px")) {
    number("lens_pitch_px", p.lensPitch_px, 1, 1000);
    number("slant_rad", p.slant_rad, -0.785, 0.785);
    number("offset_px", p.offset_px, -1e6, 1e6);
  }
  if (has("array_pitch_mm")) {
    if (t.has("packing"))
      p.packing = t.string("packing", std::nullopt, {"square", "hexagonal"}) == "square" ? LensPacking::Square
                                                                                         : LensPacking::Hexagonal;
    number("array_pitch_mm", p.arrayPitch_mm, 1e-3, 100);
    number("rotation_rad", p.rotation_rad, -0.785, 0.785);
    if (t.has("array_offset_mm")) {
      const std::vector<double> o = t.numbers("array_offset_mm", 2, std::nullopt, -1e4, 1e4);
      p.arrayOffsetX_mm = o[0];
      p.arrayOffsetY_mm = o[1];
    }
  }
  if (has("fill_factor")) number("fill_factor", p.fillFactor, 1e-3, 1);
  if (has("pinhole_diameter_mm")) number("pinhole_diameter_mm", p.pinholeDiameter_mm, 1e-4, 100);
  if (has("slit_width_mm")) number("slit_width_mm", p.slitWidth_mm, 1e-5, 100);
  if (has("focal_length_mm")) {
    if (t.has("focal_length_mm"))
      p.focalLength_mm = t.number("focal_length_mm", std::nullopt, 1e-4, 1000);
    else if (t.has("gap_mm"))
      p.focalLength_mm = p.gap_mm;  // focused on the panel unless said otherwise
  }
  // What the chosen class needs, given here or by `base`.
  auto require = [&](const char* key, double value) {
    if (has(key) && !(value > 0))
      fail(Errc::Config, "{}: {} optics need {} > 0 (none given, and the device or defaults give {})", t.where(key),
           toString(p.type), key, value);
  };
  require("lens_pitch_px", p.lensPitch_px);
  require("array_pitch_mm", p.arrayPitch_mm);
  require("slit_width_mm", p.slitWidth_mm);
  require("focal_length_mm", p.focalLength_mm);
  require("pinhole_diameter_mm", p.pinholeDiameter_mm);
  if (!(p.gap_mm > 0))
    fail(Errc::Config, "{}: the optics need gap_mm > 0 (the device or defaults give {})", t.where("gap_mm"), p.gap_mm);
  if (p.type == OpticsType::PinholeArray && p.pinholeDiameter_mm > p.arrayPitch_mm)
    fail(Errc::Config, "{}: pinhole_diameter_mm = {} is larger than the array pitch {} mm",
         t.where(t.has("pinhole_diameter_mm") ? "pinhole_diameter_mm" : "array_pitch_mm"), p.pinholeDiameter_mm,
         p.arrayPitch_mm);
  return p;
}

DisplayOpticsParams readDisplayOpticsFile(const std::filesystem::path& path, const DisplayOpticsParams& base) {
  ConfigTable root = ConfigTable::parseFile(path);
  root.string("format", std::nullopt, {"lfi-display-calibration"});
  root.integer("version", std::nullopt, 1, 1);
  ConfigTable t = root.table("optics");
  const DisplayOpticsParams p = readDisplayOpticsTable(t, base);
  t.finish();
  root.finish();
  return p;
}

}  // namespace lfi
