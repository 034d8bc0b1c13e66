// SPDX-License-Identifier: Apache-2.0
#pragma once
// A bench's own measurement of a display's optics, overriding the calibration
// the display keeps in its memory (commercial displays ship one per unit; a
// bench may measure better). TOML, every key optional except the header; a
// key the chosen class does not use, or an unknown one, is an error naming
// file and line:
//
//   format = "lfi-display-calibration"
//   version = 1
//   [optics]
//   optics = "lenslet_array"   # lenticular | line_barrier | lenslet_array | pinhole_array
//   # lenticular and line_barrier:
//   lens_pitch_px = 7.22       # lens (or slit) pitch along a panel row, panel pixels
//   slant_rad = 0.1826         # lens axis angle from the panel vertical
//   offset_px = 0.30           # lens 0's axis on the centre row, from the panel centre
//   slit_width_mm = 0.13       # line_barrier only
//   # lenslet_array and pinhole_array:
//   packing = "square"         # square | hexagonal
//   array_pitch_mm = 1.0       # centre distance of neighbouring lenses (pinholes)
//   rotation_rad = 0.0         # the lattice rows' angle from the panel rows
//   array_offset_mm = [0, 0]   # centre of lens (0, 0) from the panel centre
//   fill_factor = 1.0          # lenslet_array only: clear aperture / cell, linear
//   pinhole_diameter_mm = 0.1  # pinhole_array only
//   # every class:
//   gap_mm = 1.37              # panel pixel plane to lens/barrier plane
//   focal_length_mm = 1.37     # lenticular and lenslet_array; default: the gap, when gap_mm is given
//
// Units: mm, rad, panel pixels (optics/*.h have each class's model).

#include "lfi/core/config.h"
#include "lfi/drivers/display.h"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace lfi {

// The keys present in the file replace those of `base`; throws Errc::NotFound
// or Errc::Config (file, line, key).
DisplayOpticsParams readDisplayOpticsFile(const std::filesystem::path& path, const DisplayOpticsParams& base);

// The keys of a class's optics that hold numbers (its own but `packing`, and
// gap_mm), each with how many: 2 for array_offset_mm, else 1.
std::vector<std::pair<std::string, std::size_t>> opticsNumberKeys(OpticsType type);

// The class the table's "optics" key names, or `fallback` without the key;
// Errc::Config listing the classes for another name.
OpticsType readOpticsClass(ConfigTable& t, OpticsType fallback);

// The [optics] keys above from any table (the calibration file's [optics], a
// scene file's [display]): the class, then the keys of that class replace those
// of `base`. A key of another class is an error naming it and the class; a class
// whose required values are neither in the table nor in `base` is an error
// naming the key. Does not call t.finish().
DisplayOpticsParams readDisplayOpticsTable(ConfigTable& t, const DisplayOpticsParams& base);

}  // namespace lfi
