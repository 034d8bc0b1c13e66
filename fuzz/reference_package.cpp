// SPDX-License-Identifier: Apache-2.0
// The reference package's reader (controller/reference_package.h) on any reference.json beside intact images:
// the record that names the package's files, their checksums, the bench and the devices. (The images' own
// readers have targets of their own: light_field_exr, radiance_exr.)
#include "fuzz_input.h"

#include "lfi/controller/reference_package.h"

#include <opencv2/core.hpp>

namespace {

// A small valid package, written once: 4 x 4 images, a 2 x 2 x 2² light field.
const std::filesystem::path& package() {
  static const std::filesystem::path folder = [] {
    const std::filesystem::path f = lfi::fuzz::folder() / "reference";
    lfi::ReferencePackage p;
    p.info.benchHash = "0123456789abcdef";
    p.info.pixelFormat = "Mono12";
    p.info.white = 1;
    p.lightField =
        lfi::LightField({.spatialX = 2, .spatialY = 2, .angular = 2, .pixelPitch_mm = 0.05, .distance_mm = 30});
    p.trainer.add(cv::Mat(4, 4, CV_32FC1, cv::Scalar(100)));
    p.mask = cv::Mat(4, 4, CV_8UC1, cv::Scalar(255));
    lfi::writeReferencePackage(f, p, lfi::Overwrite::Refuse);
    return f;
  }();
  return folder;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path& folder = package();
  std::ofstream(folder / "reference.json", std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  lfi::fuzz::expectCleanRefusal([&] { lfi::readReferencePackage(folder, nullptr); });
  return 0;
}
