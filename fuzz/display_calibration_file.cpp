// SPDX-License-Identifier: Apache-2.0
// The display calibration file reader (drivers/display_calibration_file.h) on any text, over a display of each
// optics class.
#include "fuzz_input.h"

#include "lfi/drivers/display_calibration_file.h"
#include "lfi/drivers/display_optics.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const auto path = lfi::fuzz::writeInput("display.toml", data + 1, size - 1);
  const lfi::OpticsType classes[] = {lfi::OpticsType::LensletArray, lfi::OpticsType::PinholeArray,
                                     lfi::OpticsType::Lenticular, lfi::OpticsType::LineBarrier};
  const lfi::DisplayOpticsParams base = lfi::defaultDisplay(classes[data[0] % 4]).optics;
  lfi::fuzz::expectCleanRefusal([&] { lfi::readDisplayOpticsFile(path, base); });
  return 0;
}
