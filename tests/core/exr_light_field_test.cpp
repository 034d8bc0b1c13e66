// SPDX-License-Identifier: Apache-2.0
// Light field EXR files: bit-exact round trips, and files whose attributes are missing,
// mistyped, out of range, in another parametrisation or at odds with the image.

#include "exr_io_fixture.h"

#include "lfi/core/error.h"
#include "lfi_test_support.h"

#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfVecAttribute.h>

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace lfi::exr_test {
namespace {

using lfi::testing_support::throwsError;

// The attributes of a light field file as lfi writes them, each optional.
struct RawLightFieldAttributes {
  LightFieldGeometry geometry = exr_test::geometry();
  bool withAngular = true;
  std::string checksum;  // empty: the correct one
  std::function<void(Imf::Header&)> conventions = [](Imf::Header& h) { insertConventions(h); };  // lfi.frame, ...
};

void writeRawLightField(const fs::path& path, const cv::Mat& pixels, const RawLightFieldAttributes& a) {
  writeRawExr(path, pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(lfi::kExrFormatVersion));
    if (!a.checksum.empty()) h.insert("lfi.checksum", Imf::StringAttribute(a.checksum));
    h.insert("lfi.spatialX", Imf::IntAttribute(a.geometry.spatialX));
    h.insert("lfi.spatialY", Imf::IntAttribute(a.geometry.spatialY));
    if (a.withAngular) h.insert("lfi.angular", Imf::IntAttribute(a.geometry.angular));
    h.insert("lfi.pixelPitch_mm", Imf::DoubleAttribute(a.geometry.pixelPitch_mm));
    h.insert("lfi.distance_mm", Imf::DoubleAttribute(a.geometry.distance_mm));
    a.conventions(h);
  });
}

TEST_F(ExrIo, LightFieldRoundTripIsBitExact) {
  const LightFieldGeometry g = geometry();
  const LightField original(g, specialFloats(g.height(), g.width(), 1, false));
  const fs::path path = file("lf.exr");
  lfi::writeLightFieldExr(path, original);
  const LightField loaded = lfi::readLightFieldExr(path);
  EXPECT_EQ(loaded.geometry().spatialX, g.spatialX);
  EXPECT_EQ(loaded.geometry().spatialY, g.spatialY);
  EXPECT_EQ(loaded.geometry().angular, g.angular);
  EXPECT_EQ(loaded.geometry().pixelPitch_mm, g.pixelPitch_mm);  // exact: stored as double
  EXPECT_EQ(loaded.geometry().distance_mm, g.distance_mm);
  EXPECT_TRUE(loaded.geometry() == g);
  EXPECT_TRUE(bitIdentical(loaded.lensletImage(), original.lensletImage()));
  // Negative zero and denormals survive (a value comparison would not notice a lost sign of zero).
  EXPECT_TRUE(std::signbit(loaded.lensletImage().at<float>(0, 1)));
  EXPECT_EQ(loaded.lensletImage().at<float>(0, 2), std::numeric_limits<float>::denorm_min());
}

TEST_F(ExrIo, LightFieldRoundTripWithNonContinuousImageAndOneByOneElements) {
  LightFieldGeometry g = geometry();
  g.spatialX = 7;
  g.spatialY = 1;
  g.angular = 1;
  g.distance_mm = 0;
  // A region of a larger image: rows are not contiguous in memory.
  const cv::Mat big = randomFloats(9, 20, 2);
  const LightField original(g, big(cv::Rect(3, 4, 7, 1)));
  ASSERT_FALSE(big(cv::Rect(3, 4, 7, 2)).isContinuous());
  lfi::writeLightFieldExr(file("roi.exr"), original);
  const LightField loaded = lfi::readLightFieldExr(file("roi.exr"));
  EXPECT_TRUE(loaded.geometry() == g);
  EXPECT_TRUE(bitIdentical(loaded.lensletImage(), original.lensletImage()));
}

TEST_F(ExrIo, RawWriterProducesReadableFiles) {
  // Control for the failure tests below: the hand-written file is accepted when nothing is wrong.
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 6);
  writeRawLightField(file("raw.exr"), pixels, {});
  const LightField loaded = lfi::readLightFieldExr(file("raw.exr"));
  EXPECT_TRUE(loaded.geometry() == g);
  EXPECT_TRUE(bitIdentical(loaded.lensletImage(), pixels));
}

// A file that states another convention, or none, is refused: lfi would read
// it in its own and get every ray wrong.
TEST_F(ExrIo, ALightFieldInAnotherParametrisationIsRefused) {
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 40);
  struct Case {
    std::string name, attribute;
    std::optional<std::string> value;  // none: left out
    std::string says;
  };
  const std::vector<Case> cases = {
      {"no-frame", "lfi.frame", std::nullopt, "missing"},
      {"z-away", "lfi.frame", "plane frame: +z away from the part", "not lfi's convention"},
      {"no-parametrisation", "lfi.parametrisation", std::nullopt, "missing"},
      {"two-plane", "lfi.parametrisation", "two-plane (u,v,s,t)", "not lfi's convention"},
      {"inches", "lfi.units", "lengths in, angles deg, pixels linear relative radiance", "not lfi's convention"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    RawLightFieldAttributes a;
    a.conventions = [&](Imf::Header& h) {
      insertConventions(h, c.attribute);
      if (c.value) h.insert(c.attribute, Imf::StringAttribute(*c.value));
    };
    writeRawLightField(file(c.name + ".exr"), pixels, a);  // (with the checksum of what it says)
    EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file(c.name + ".exr")); }, Errc::InvalidFile,
                            {file(c.name + ".exr").string(), "'" + c.attribute + "'", c.says}));
  }
}

TEST_F(ExrIo, MissingAttributeIsNamed) {
  const LightFieldGeometry g = geometry();
  RawLightFieldAttributes a;
  a.withAngular = false;
  writeRawLightField(file("no-angular.exr"), randomFloats(g.height(), g.width(), 8), a);
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("no-angular.exr")); }, Errc::InvalidFile,
                          {file("no-angular.exr").string(), "lfi.angular", "missing"}));
}

TEST_F(ExrIo, MistypedAttributeIsNamed) {
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 9);
  // pixelPitch_mm as a string instead of a double.
  writeRawExr(file("typed.exr"), pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(lfi::kExrFormatVersion));
    h.insert("lfi.spatialX", Imf::IntAttribute(g.spatialX));
    h.insert("lfi.spatialY", Imf::IntAttribute(g.spatialY));
    h.insert("lfi.angular", Imf::IntAttribute(g.angular));
    h.insert("lfi.pixelPitch_mm", Imf::StringAttribute("0.0375"));
    h.insert("lfi.distance_mm", Imf::DoubleAttribute(g.distance_mm));
  });
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("typed.exr")); }, Errc::InvalidFile,
                          {"lfi.pixelPitch_mm", "string", "double"}));
}

TEST_F(ExrIo, OutOfRangeAttributeIsInvalidFile) {
  RawLightFieldAttributes a;
  a.geometry.angular = 0;
  a.geometry.spatialX = 20;  // keeps width() = 0 != 20 out of the way: validation comes first
  writeRawLightField(file("zero.exr"), randomFloats(12, 20, 10), a);
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("zero.exr")); }, Errc::InvalidFile,
                          {file("zero.exr").string(), "angular"}));
}

TEST_F(ExrIo, SizeThatDoesNotMatchAttributesIsNamed) {
  const LightFieldGeometry g = geometry();                             // needs 20x12
  const cv::Mat pixels = randomFloats(g.height(), g.width() + 4, 11);  // 24x12
  writeRawLightField(file("size.exr"), pixels, {});
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("size.exr")); }, Errc::InvalidFile,
                          {file("size.exr").string(), "24x12", "20x12"}));
}

TEST_F(ExrIo, NonFinitePixelIsNamed) {
  const LightFieldGeometry g = geometry();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<std::pair<std::string, float>> cases = {
      {"nan", std::numeric_limits<float>::quiet_NaN()}, {"inf", inf}, {"minus-inf", -inf}};
  for (const auto& [name, bad] : cases) {
    cv::Mat pixels = randomFloats(g.height(), g.width(), 12);
    pixels.at<float>(7, 13) = bad;  // row 7, column 13
    const fs::path path = file(name + ".exr");
    writeRawLightField(path, pixels, {});  // with the correct checksum of these pixels
    EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(path); }, Errc::InvalidFile,
                            {path.string(), "pixel (13, 7)", "finite"}))
        << name;
  }
  // Negative radiance: refused by the reader, and by the writer and the light field before it.
  cv::Mat pixels = randomFloats(g.height(), g.width(), 13);
  pixels.at<float>(3, 5) = -0.25f;
  writeRawLightField(file("negative.exr"), pixels, {});
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("negative.exr")); }, Errc::InvalidFile,
                          {file("negative.exr").string(), "pixel (5, 3) is -0.25", "cannot be negative"}));
  EXPECT_TRUE(throwsError([&] { LightField(g, pixels); }, Errc::InvalidArgument, {"(5, 3)", "cannot be negative"}));
  LightField field(g, randomFloats(g.height(), g.width(), 14));
  field.lensletImage().at<float>(3, 5) = -1;  // changed after the check
  EXPECT_TRUE(throwsError([&] { lfi::writeLightFieldExr(file("negative-out.exr"), field); }, Errc::InvalidArgument,
                          {"negative-out.exr", "(5, 3)", "cannot be negative"}));
  EXPECT_FALSE(fs::exists(file("negative-out.exr")));
}

TEST_F(ExrIo, LfiAttributeOfAnotherTypeIsNamed) {
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 18);
  writeRawExr(file("v2f.exr"), pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(lfi::kExrFormatVersion));
    h.insert("lfi.checksum", Imf::StringAttribute("crc32:00000000"));
    h.insert("lfi.offset", Imf::V2fAttribute(Imath::V2f(1, 2)));
  });
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("v2f.exr")); }, Errc::InvalidFile,
                          {file("v2f.exr").string(), "'lfi.offset'", "'v2f'"}));
}

}  // namespace
}  // namespace lfi::exr_test
