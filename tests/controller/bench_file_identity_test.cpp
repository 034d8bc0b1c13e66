// SPDX-License-Identifier: Apache-2.0
// The inspection bench file's derived values: what the reference hash depends
// on (and what it does not), the detection settings in camera pixels and the
// part's frame. No device is opened.

#include "bench_file_fixture.h"

#include "lfi/drivers/backend_registry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace {

using namespace lfi;
using namespace lfi::bench_file_test;

TEST(BenchFileHash, Fnv1aOfTheTestIsTheStandardOne) {
  // The published FNV-1a 64-bit test vectors.
  EXPECT_EQ(fnv1a64(""), "cbf29ce484222325");
  EXPECT_EQ(fnv1a64("a"), "af63dc4c8601ec8c");
  EXPECT_EQ(fnv1a64("foobar"), "85944171f73967e8");
}

TEST_F(BenchFileTest, ReferenceHashIsFnv1aOfTheIdentity) {
  const BenchFile b = read(kBench);
  const std::string identity = b.referenceIdentity();
  EXPECT_EQ(b.referenceHash(), fnv1a64(identity));
  EXPECT_EQ(b.referenceHash().size(), 16u);
  // One "key = value" line per setting; paths relative to the bench file as it gives them.
  EXPECT_NE(identity.find("camera.uri = aravis:Fake-GV01\n"), std::string::npos) << identity;
  EXPECT_NE(identity.find("capture.uri = sim:../scenes/bench.toml?spp=8\n"), std::string::npos) << identity;
  EXPECT_NE(identity.find("geometry.distance_mm = 30\n"), std::string::npos) << identity;
  EXPECT_EQ(std::count(identity.begin(), identity.end(), '\n'), 14);
}

TEST_F(BenchFileTest, ABenchMovedWithItsFilesKeepsItsReferenceHash) {
  const BenchFile here = read(kBench);
  fs::create_directories(folder_ / "elsewhere" / "deeper" / "benches");
  const BenchFile moved = readBenchFile(folder_.write("elsewhere/deeper/benches/bench.toml", kBench));
  EXPECT_NE(moved.captureUri, here.captureUri) << "the scene is found beside the moved bench";
  EXPECT_EQ(moved.referenceHash(), here.referenceHash());
}

TEST_F(BenchFileTest, ReferenceHashIgnoresWhatTheReferenceDoesNotDependOn) {
  const std::string base = read(kBench).referenceHash();
  struct Edit {
    std::string from, to;
  };
  for (const Edit& e : std::vector<Edit>{
           {"# A bench for the tests.", "# Another comment.\n# And one more."},
           {"exposure_us = 10000", "exposure_us = 10000  # µs"},
           {"exposure_us = 10000", "exposure_us = 10_000.0"},
           {"exposure_us = 10000", "exposure_us = 1e4"},
           {"pixel_format = \"Mono12\"\n", ""},  // the default written out or not
           {"trigger = \"software\"", "trigger = \"free_run\""},
           {"trigger = \"software\"", "grab_timeout_ms = 100\nretries = 9"},
           {"read_noise_dn = 0.98", "read_noise_dn = 2"},  // the model's floor, applied when used
           {"mask_lit_fraction = 0.25", "mask_lit_fraction = 0.25\nframes = 64"},
           {"relative = 6", "relative = 4\nabsolute_dn = 30\nframes = 3"},
           {"smallest_defect_mm = 1.0", "smallest_defect_mm = 2.0\nmin_defect_area_mm2 = 1"},
           {"closing_mm = 0.5", "closing_mm = 1.5\nmax_defects = 3\nmax_defect_area_mm2 = 2\nmax_total_area_mm2 = 4"},
           {"[inspection]\nrelative = 6\nsmallest_defect_mm = 1.0\nclosing_mm = 0.5\n", ""},
           {"folder = \"../inspections\"", "folder = \"elsewhere\"\nsave_images = \"none\""},
           {"folder = \"../inspections\"", "folder = \"o\"\n[run]\non_device_loss = \"wait\"\nwait_limit_s = 5"},
       }) {
    SCOPED_TRACE(e.to);
    EXPECT_EQ(read(replaced(kBench, e.from, e.to)).referenceHash(), base);
  }
}

TEST_F(BenchFileTest, ReferenceHashChangesWithWhatTheReferenceDependsOn) {
  const std::string base = read(kBench).referenceHash();
  struct Edit {
    std::string from, to;
  };
  for (const Edit& e : std::vector<Edit>{
           {"exposure_us = 10000", "exposure_us = 10001"},
           {"exposure_us = 10000", "exposure_us = 10000.000000001"},  // 17 digits: any other double
           {"exposure_us = 10000", "exposure_us = 10000\ngain = 1"},
           {"pixel_format = \"Mono12\"", "pixel_format = \"Mono16\""},
           {"pixel_format = \"Mono12\"", "pixel_format = \"Mono8\""},
           {"trigger = \"software\"", "binning = 2"},
           {"object_pixel_mm = 0.5", "object_pixel_mm = 0.25"},
           {"uri = \"aravis:Fake-GV01\"", "uri = \"aravis:Fake-GV02\""},
           {"uri = \"usb:1209:4c46/LFI-0001\"", "uri = \"usb:1209:4c46/LFI-0002\""},
           {"uri = \"usb:1209:4c46/LFI-0001\"", "uri = \"usb:1209:4c46/LFI-0001\"\nwhite = 2"},
           {"?spp=8", "?spp=9"},
           {"uri = \"sim:../scenes/bench.toml?spp=8\"", "uri = \"sim:../scenes/other.toml?spp=8\""},
           {"uri = \"sim:../scenes/bench.toml?spp=8\"", "light_field = \"lf.exr\""},
           {"distance_mm = 30", "distance_mm = 30.5"},
           {"part_centre_px = [27.5, 27.5]", "part_centre_px = [27.5, 28]"},
           {"part_centre_px = [27.5, 27.5]\n", ""},  // the image's centre instead
           {"mask_radius_mm = 12.2", "mask_radius_mm = 12"},
           {"mask_radius_mm = 12.2\n", ""},
           {"mask_lit_fraction = 0.25", "mask_lit_fraction = 0.3"},
           {"exposure_us = 10000", "exposure_us = 10000\ndark_frame = \"dark.exr\""},
           {"exposure_us = 10000", "exposure_us = 10000\ndark_frame = \"dark.exr\"\nflat_frame = \"flat.exr\""},
           {"\n[capture]", "\n[display.response]\nlevels = [0, 128, 255]\nlight = [0, 0.2, 1]\n\n[capture]"},
       }) {
    SCOPED_TRACE(e.to);
    EXPECT_NE(read(replaced(kBench, e.from, e.to)).referenceHash(), base);
  }
}

// ---------------------------------------------------------------------------
// Settings in camera pixels and the part's frame

BenchFile benchOf(double objectPixel_mm) {
  BenchFile b;
  b.objectPixel_mm = objectPixel_mm;
  return b;
}

TEST(BenchFileDetection, SmoothingIsAQuarterOfTheSmallestDefectInPixels) {
  for (const double pixel : {0.5, 0.3, 0.0125}) {
    BenchFile b = benchOf(pixel);
    b.smallestDefect_mm = 1.3;
    b.absolute_dn = 7;
    b.relative = 4.5;
    const DetectionSettings d = b.detection();
    // (d / 4 and 4 · pixel are exact in binary: both sides are one rounding of the same quotient.)
    EXPECT_DOUBLE_EQ(d.smoothing_px, 1.3 / (4 * pixel)) << pixel;
    EXPECT_EQ(d.absolute_dn, 7);
    EXPECT_EQ(d.relative, 4.5);
  }
}

TEST(BenchFileDetection, ClosingIsRoundedToWholePixels) {
  BenchFile b = benchOf(0.5);
  for (const auto& [closing_mm, pixels] :
       std::vector<std::pair<double, int>>{{0, 0}, {0.24, 0}, {0.26, 1}, {0.74, 1}, {0.75, 2}, {0.76, 2}, {5, 10}}) {
    b.closing_mm = closing_mm;
    EXPECT_EQ(b.detection().closing_px, pixels) << closing_mm << " mm";
  }
}

TEST(BenchFileDetection, MinimumAreaIsTheWholePixelsThatCoverItAndAtLeastOne) {
  BenchFile b = benchOf(0.5);  // 0.25 mm² a pixel
  for (const auto& [area_mm2, pixels] :
       std::vector<std::pair<double, int>>{{0, 1}, {0.1, 1}, {0.25, 1}, {0.26, 2}, {1.0, 4}, {1.01, 5}, {100, 400}}) {
    b.minDefectArea_mm2 = area_mm2;
    EXPECT_EQ(b.detection().minArea_px, pixels) << area_mm2 << " mm²";
  }
  // 0.3 mm pixels: 0.09 / 0.3² and 0.18 / 0.3² are 1 and 2 pixels, though not exactly in double.
  BenchFile c = benchOf(0.3);
  for (const auto& [area_mm2, pixels] :
       std::vector<std::pair<double, int>>{{0.09, 1}, {0.18, 2}, {0.27, 3}, {0.1, 2}}) {
    c.minDefectArea_mm2 = area_mm2;
    EXPECT_EQ(c.detection().minArea_px, pixels) << area_mm2 << " mm²";
  }
}

TEST(BenchFilePartFrame, OriginIsTheImageCentreUnlessGiven) {
  BenchFile b = benchOf(0.5);
  const PartFrame even = b.partFrame(56, 40);
  EXPECT_EQ(even.perPixel_mm, cv::Matx22d(0.5, 0, 0, -0.5));
  EXPECT_EQ(even.origin_px.x, 27.5);
  EXPECT_EQ(even.origin_px.y, 19.5);
  const PartFrame odd = b.partFrame(5, 3);
  EXPECT_EQ(odd.origin_px.x, 2);
  EXPECT_EQ(odd.origin_px.y, 1);
  b.partCentre_px = Vec2(10, 31.25);
  const PartFrame given = b.partFrame(56, 40);
  EXPECT_EQ(given.origin_px.x, 10);
  EXPECT_EQ(given.origin_px.y, 31.25);
}

TEST(BenchFilePartFrame, PartFrameHasYUpAndMillimetres) {
  BenchFile b = benchOf(0.5);
  const PartFrame f = b.partFrame(56, 56);
  const Vec2 origin = f.toPart(Vec2(27.5, 27.5));
  EXPECT_EQ(origin.x, 0);
  EXPECT_EQ(origin.y, 0);
  // 4 pixels right and 6 pixels up the image (smaller row): +x and +y on the part.
  const Vec2 upRight = f.toPart(Vec2(31.5, 21.5));
  EXPECT_EQ(upRight.x, 2.0);
  EXPECT_EQ(upRight.y, 3.0);
  const Vec2 downLeft = f.toPart(Vec2(25.5, 28.5));
  EXPECT_EQ(downLeft.x, -1.0);
  EXPECT_EQ(downLeft.y, -0.5);
  EXPECT_EQ(f.area_mm2(8), 2.0);
}

}  // namespace
