// SPDX-License-Identifier: Apache-2.0
// The lfi.checksum of EXR files: CRC-32 of the canonical lfi attributes, then the pixels;
// a changed pixel or attribute fails it, and version 1 files carry the pixels' CRC alone.

#include "exr_io_fixture.h"

#include "lfi/core/error.h"
#include "lfi_test_support.h"

#include <OpenEXR/ImfDoubleAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace lfi::exr_test {
namespace {

using lfi::testing_support::throwsError;

// Writes `pixels` under `header` as it is (its recorded checksum included).
void rewrite(const fs::path& path, const Imf::Header& header, const cv::Mat& pixels) {
  Imf::OutputFile out(path.c_str(), header);
  Imf::FrameBuffer frame;
  frame.insert("Y", Imf::Slice(Imf::FLOAT, const_cast<char*>(pixels.ptr<char>()), sizeof(float), pixels.step));
  out.setFrameBuffer(frame);
  out.writePixels(pixels.rows);
}

TEST_F(ExrIo, ModifiedPixelFailsChecksum) {
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 13);
  const fs::path valid = file("valid.exr");
  lfi::writeLightFieldExr(valid, LightField(g, pixels));
  ASSERT_NO_THROW(lfi::readLightFieldExr(valid));
  // Keep lfi's header (with its checksum) as it is; change one pixel by one ulp.
  const Imf::Header header = Imf::InputFile(valid.c_str()).header();
  cv::Mat tampered = pixels.clone();
  tampered.at<float>(5, 9) = std::nextafter(tampered.at<float>(5, 9), std::numeric_limits<float>::max());
  const fs::path path = file("tampered.exr");
  rewrite(path, header, tampered);
  const std::string recorded = header.typedAttribute<Imf::StringAttribute>("lfi.checksum").value();
  EXPECT_EQ(recorded, checksumText(lfi::fileChecksum(canonicalText(header), pixels)));
  EXPECT_TRUE(throwsError(
      [&] { lfi::readLightFieldExr(path); }, Errc::Checksum,
      {path.string(), "lfi.checksum", recorded, checksumText(lfi::fileChecksum(canonicalText(header), tampered))}));
}

TEST_F(ExrIo, ModifiedAttributeFailsChecksum) {
  // One changed byte of a double can move the display distance from 30 to 3 mm,
  // which a checksum over the pixels alone would not notice. Each lfi attribute
  // is covered: every edit below leaves the pixels intact.
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 14);
  const fs::path lightField = file("lf.exr"), radiance = file("r.exr");
  lfi::writeLightFieldExr(lightField, LightField(g, pixels));
  lfi::writeRadianceExr(radiance, pixels, {0.00345, "parallel illumination"});
  const std::vector<std::pair<fs::path, std::function<void(Imf::Header&)>>> edits = {
      {lightField, [](Imf::Header& h) { h.typedAttribute<Imf::DoubleAttribute>("lfi.distance_mm").value() /= 10; }},
      {lightField, [](Imf::Header& h) { h.typedAttribute<Imf::DoubleAttribute>("lfi.pixelPitch_mm").value() *= 2; }},
      {lightField, [](Imf::Header& h) { h.typedAttribute<Imf::StringAttribute>("lfi.frame").value() += " "; }},
      {lightField, [](Imf::Header& h) { h.insert("lfi.note", Imf::StringAttribute("added")); }},
      {radiance, [](Imf::Header& h) { h.typedAttribute<Imf::DoubleAttribute>("lfi.objectPixel_mm").value() = 0.01; }},
      {radiance, [](Imf::Header& h) { h.typedAttribute<Imf::StringAttribute>("lfi.description").value() = "area"; }},
  };
  int n = 0;
  for (const auto& [source, edit] : edits) {
    const fs::path& original = source;  // (clang 14 cannot capture a structured binding)
    Imf::Header header = Imf::InputFile(original.c_str()).header();
    edit(header);
    const fs::path path = file(fmt::format("edited-{}.exr", n++));
    rewrite(path, header, pixels);
    const auto read = [&] {
      if (original == lightField)
        lfi::readLightFieldExr(path);
      else
        lfi::readRadianceExr(path);
    };
    EXPECT_TRUE(throwsError(read, Errc::Checksum, {path.string(), "lfi attributes or pixel data"})) << path;
  }
}

TEST_F(ExrIo, ChecksumIsCrc32OfTheCanonicalAttributesThenThePixels) {
  // The canonical text of docs/file-formats.md, spelled out for a small header.
  Imf::Header header(1, 1);
  header.insert("lfi.kind", Imf::StringAttribute("light-field"));
  header.insert("lfi.formatVersion", Imf::IntAttribute(2));
  header.insert("lfi.checksum", Imf::StringAttribute("crc32:00000000"));
  header.insert("lfi.distance_mm", Imf::DoubleAttribute(17.25));
  header.insert("lfi.pixelPitch_mm", Imf::DoubleAttribute(0.1));
  header.insert("other", Imf::StringAttribute("not lfi's"));
  EXPECT_EQ(canonicalText(header),
            "lfi.distance_mm double 17.25\nlfi.formatVersion int 2\nlfi.kind string 11:light-field\n"
            "lfi.pixelPitch_mm double 0.1\n");
  // CRC-32 of "123456789" is 0xcbf43926; the pixels go on from the text's CRC.
  const cv::Mat pixels = randomFloats(3, 4, 15);
  EXPECT_EQ(lfi::fileChecksum("123456789", cv::Mat()), 0xcbf43926ul);
  EXPECT_EQ(lfi::fileChecksum("", pixels), lfi::pixelChecksum(pixels));
  EXPECT_EQ(lfi::fileChecksum("123456789", pixels), lfi::pixelChecksum(pixels, 0xcbf43926ul));
  // And lfi's reader agrees with this test's canonical text (RawWriterProducesReadableFiles
  // reads a file sealed by it); lfi's writer records the same checksum.
  const LightFieldGeometry g = geometry();
  lfi::writeLightFieldExr(file("lf.exr"), LightField(g, randomFloats(g.height(), g.width(), 16)));
  const Imf::Header written = Imf::InputFile(file("lf.exr").c_str()).header();
  EXPECT_EQ(
      written.typedAttribute<Imf::StringAttribute>("lfi.checksum").value(),
      checksumText(lfi::fileChecksum(canonicalText(written), lfi::readLightFieldExr(file("lf.exr")).lensletImage())));
}

TEST_F(ExrIo, VersionOneFilesStillReadAndLaterVersionsAreRefused) {
  // Format version 1 files record the CRC of the pixels only.
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 17);
  writeRawExr(file("v1.exr"), pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(1));
    h.insert("lfi.checksum", Imf::StringAttribute(checksumText(pixels)));
    h.insert("lfi.spatialX", Imf::IntAttribute(g.spatialX));
    h.insert("lfi.spatialY", Imf::IntAttribute(g.spatialY));
    h.insert("lfi.angular", Imf::IntAttribute(g.angular));
    h.insert("lfi.pixelPitch_mm", Imf::DoubleAttribute(g.pixelPitch_mm));
    h.insert("lfi.distance_mm", Imf::DoubleAttribute(g.distance_mm));
    insertConventions(h);  // (in the same words in version 1)
  });
  const LightField loaded = lfi::readLightFieldExr(file("v1.exr"));
  EXPECT_TRUE(loaded.geometry() == g);
  EXPECT_TRUE(bitIdentical(loaded.lensletImage(), pixels));
  writeRawExr(file("v3.exr"), pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(3));
  });
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("v3.exr")); }, Errc::InvalidFile,
                          {file("v3.exr").string(), "lfi.formatVersion", "is 3", "versions 1 to 2"}));
}

TEST(PixelChecksum, IsCrc32OfPixelBytesRowByRow) {
  // CRC-32 (zlib polynomial) of the ASCII bytes "123456789" is 0xcbf43926.
  cv::Mat bytes(1, 9, CV_8UC1);
  std::memcpy(bytes.data, "123456789", 9);
  EXPECT_EQ(lfi::pixelChecksum(bytes), 0xcbf43926ul);
  // Row padding of a region is not part of the checksum.
  const cv::Mat big = randomFloats(6, 10, 16);
  const cv::Mat roi = big(cv::Rect(1, 1, 5, 4));
  EXPECT_EQ(lfi::pixelChecksum(roi), lfi::pixelChecksum(roi.clone()));
  cv::Mat changed = roi.clone();
  changed.at<float>(3, 4) = -changed.at<float>(3, 4);
  EXPECT_NE(lfi::pixelChecksum(changed), lfi::pixelChecksum(roi));
}

}  // namespace
}  // namespace lfi::exr_test
