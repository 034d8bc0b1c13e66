#include "lfi/drivers/display_calibration_file.h"

#include "lfi/core/config.h"
#include "lfi/core/error.h"

namespace lfi {

DisplayOpticsParams readDisplayOpticsFile(const std::filesystem::path& path, const DisplayOpticsParams& base) {
  ConfigTable root = ConfigTable::parseFile(path);
  root.string("format", std::nullopt, {"lfi-display-calibration"});
  root.integer("version", std::nullopt, 1, 1);
  DisplayOpticsParams p = base;
  ConfigTable t = root.table("optics");
  if (t.has("optics"))
    p.type = t.string("optics", std::nullopt, {"lenslet", "barrier"}) == "barrier" ? OpticsType::Barrier
                                                                                   : OpticsType::Lenslet;
  auto number = [&](const char* key, double& field, double min, double max) {
    if (t.has(key)) field = t.number(key, std::nullopt, min, max);
  };
  // The ranges DisplayInfo::validate() accepts, so that a bad value is named here, in its file and line.
  number("lens_pitch_px", p.lensPitch_px, 1, 1000);
  number("slant_rad", p.slant_rad, -0.785, 0.785);
  number("offset_px", p.offset_px, -1e6, 1e6);
  number("gap_mm", p.gap_mm, 1e-3, 100);
  number("focal_length_mm", p.focalLength_mm, 1e-4, 1000);
  number("slit_width_mm", p.slitWidth_mm, 1e-5, 100);
  // What the chosen optics need, given here or by the device.
  if (p.type == OpticsType::Barrier && !(p.slitWidth_mm > 0))
    fail(Errc::Config, "{}: barrier optics need a slit width > 0 (the device gives {})", t.where("slit_width_mm"),
         p.slitWidth_mm);
  if (p.type == OpticsType::Lenslet && !(p.focalLength_mm > 0))
    fail(Errc::Config, "{}: lenslet optics need a focal length > 0 (the device gives {})", t.where("focal_length_mm"),
         p.focalLength_mm);
  t.finish();
  root.finish();
  return p;
}

}  // namespace lfi
