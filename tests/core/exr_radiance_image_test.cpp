// SPDX-License-Identifier: Apache-2.0
// Radiance image EXR files: bit-exact round trips with their info, the kind that tells them
// from light field files, and files in another convention.

#include "exr_io_fixture.h"

#include "lfi/core/error.h"
#include "lfi_test_support.h"

#include <OpenEXR/ImfDoubleAttribute.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <gtest/gtest.h>

#include <string>

namespace lfi::exr_test {
namespace {

using lfi::testing_support::throwsError;

TEST_F(ExrIo, RadianceRoundTripKeepsPixelsAndInfo) {
  const cv::Mat big = specialFloats(40, 60, 3);
  const cv::Mat image = big(cv::Rect(5, 2, 33, 31));  // odd size, not continuous
  lfi::RadianceImageInfo info;
  info.objectPixel_mm = 0.00345;
  info.description = "lens N-BK7, parallel illumination, 64 spp";
  lfi::writeRadianceExr(file("r.exr"), image, info);
  lfi::RadianceImageInfo loadedInfo;
  const cv::Mat loaded = lfi::readRadianceExr(file("r.exr"), &loadedInfo);
  EXPECT_TRUE(bitIdentical(loaded, image));
  EXPECT_EQ(loadedInfo.objectPixel_mm, info.objectPixel_mm);
  EXPECT_EQ(loadedInfo.description, info.description);
  EXPECT_EQ(loadedInfo.pixelUnit, "linear relative radiance");  // the default
  // The info is optional.
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(file("r.exr")), image));
  // A camera frame says its pixels are digital numbers, in lfi.units.
  info.pixelUnit = "camera digital numbers (DN)";
  lfi::writeRadianceExr(file("dn.exr"), image, info);
  lfi::readRadianceExr(file("dn.exr"), &loadedInfo);
  EXPECT_EQ(loadedInfo.pixelUnit, info.pixelUnit);
  EXPECT_EQ(Imf::InputFile(file("dn.exr").c_str()).header().typedAttribute<Imf::StringAttribute>("lfi.units").value(),
            "lengths mm, angles rad, pixels camera digital numbers (DN)");
  // How it was taken travels as lfi.settings.* strings, under the checksum.
  info.settings = {{"exposure_us", "10000"}, {"pixel_format", "Mono12"}};
  lfi::writeRadianceExr(file("settings.exr"), image, info);
  lfi::readRadianceExr(file("settings.exr"), &loadedInfo);
  EXPECT_EQ(loadedInfo.settings, info.settings);
  lfi::readRadianceExr(file("dn.exr"), &loadedInfo);
  EXPECT_TRUE(loadedInfo.settings.empty()) << "none written, none read";
  {
    Imf::InputFile in(file("settings.exr").c_str());
    EXPECT_EQ(in.header().typedAttribute<Imf::StringAttribute>("lfi.settings.pixel_format").value(), "Mono12");
  }
  info.settings = {{"Exposure us", "1"}};
  EXPECT_TRUE(throwsError([&] { lfi::writeRadianceExr(file("key.exr"), image, info); }, Errc::InvalidArgument,
                          {"key.exr", "'Exposure us'", "a-z"}));
  info.settings.clear();
  info.pixelUnit.clear();
  EXPECT_TRUE(throwsError([&] { lfi::writeRadianceExr(file("none.exr"), image, info); }, Errc::InvalidArgument,
                          {"none.exr", "unit"}));
}

TEST_F(ExrIo, KindsAreNotInterchangeable) {
  const LightFieldGeometry g = geometry();
  lfi::writeLightFieldExr(file("lf.exr"), LightField(g, randomFloats(g.height(), g.width(), 4)));
  lfi::writeRadianceExr(file("r.exr"), randomFloats(8, 8, 5), {});
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("lf.exr")); }, Errc::InvalidFile,
                          {file("lf.exr").string(), "lfi.kind", "light-field"}));
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("r.exr")); }, Errc::InvalidFile,
                          {file("r.exr").string(), "lfi.kind", "radiance-image"}));
}

// The same for a radiance image: its frame in lfi's words, and units with a pixel unit after lfi's prefix.
TEST_F(ExrIo, ARadianceImageInAnotherConventionIsRefused) {
  const cv::Mat pixels = randomFloats(6, 5, 41);
  auto write = [&](const std::string& name, const std::string& frame, const std::string& units) {
    writeRawExr(file(name), pixels, [&](Imf::Header& h) {
      h.insert("lfi.kind", Imf::StringAttribute("radiance-image"));
      h.insert("lfi.formatVersion", Imf::IntAttribute(lfi::kExrFormatVersion));
      h.insert("lfi.objectPixel_mm", Imf::DoubleAttribute(0.1));
      h.insert("lfi.frame", Imf::StringAttribute(frame));
      h.insert("lfi.units", Imf::StringAttribute(units));
    });
  };
  const std::string frame = "camera image: row 0 at world +y, columns along world +x";
  write("good.exr", frame, "lengths mm, angles rad, pixels camera digital numbers (DN)");
  lfi::RadianceImageInfo info;
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(file("good.exr"), &info), pixels));
  EXPECT_EQ(info.pixelUnit, "camera digital numbers (DN)");
  write("flipped.exr", "camera image: row 0 at world -y", "lengths mm, angles rad, pixels linear relative radiance");
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("flipped.exr")); }, Errc::InvalidFile,
                          {file("flipped.exr").string(), "'lfi.frame'", "not lfi's convention"}));
  write("inches.exr", frame, "lengths in, pixels linear relative radiance");
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("inches.exr")); }, Errc::InvalidFile,
                          {file("inches.exr").string(), "'lfi.units'"}));
  write("no-unit.exr", frame, "lengths mm, angles rad, pixels ");
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("no-unit.exr")); }, Errc::InvalidFile,
                          {file("no-unit.exr").string(), "'lfi.units'"}));
}

}  // namespace
}  // namespace lfi::exr_test
