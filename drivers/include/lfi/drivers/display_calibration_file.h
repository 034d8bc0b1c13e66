#pragma once
// A bench's own measurement of a display's optics, overriding the calibration
// the display keeps in its memory (commercial lenticular displays ship one per
// unit; a bench may measure better). TOML, every key optional except the
// header; an unknown key is an error naming file and line:
//
//   format = "lfi-display-calibration"
//   version = 1
//   [optics]
//   optics = "lenslet"        # lenslet | barrier
//   lens_pitch_px = 7.22      # lens (or slit) pitch along a panel row, panel pixels
//   slant_rad = 0.1826        # lens axis angle from the panel vertical
//   offset_px = 0.30          # lens 0's axis on the centre row, from the panel centre
//   gap_mm = 0.7333           # panel pixel plane to lens/barrier plane
//   focal_length_mm = 0.7333  # lenslet only
//   slit_width_mm = 0.13      # barrier only
//
// Units: mm, rad, panel pixels.

#include "lfi/drivers/display.h"

#include <filesystem>

namespace lfi {

// The keys present in the file replace those of `base`; throws Errc::NotFound
// or Errc::Config (file, line, key).
DisplayOpticsParams readDisplayOpticsFile(const std::filesystem::path& path, const DisplayOpticsParams& base);

}  // namespace lfi
