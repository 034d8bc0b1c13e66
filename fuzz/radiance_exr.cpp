// SPDX-License-Identifier: Apache-2.0
// The radiance image EXR reader (core/exr_io.h) on any bytes.
#include "fuzz_input.h"

#include "lfi/core/exr_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = lfi::fuzz::writeInput("input.exr", data, size);
  lfi::fuzz::expectCleanRefusal([&] {
    lfi::RadianceImageInfo info;
    lfi::readRadianceExr(path, &info);
  });
  return 0;
}
