// SPDX-License-Identifier: Apache-2.0
// The inspection bench file (controller/include/lfi/controller/bench_file.h):
// the shipped simulated bench, every kind of mistake a hand edit makes (named
// by file, line and key), relative paths and the defaults. No device is opened.

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

// ---------------------------------------------------------------------------
// The shipped bench

TEST_F(BenchFileTest, ShippedSimulatedBenchReadsAsWritten) {
  const fs::path source = LFI_SOURCE_DIR;
  const fs::path file = source / "data" / "benches" / "inspection_sim.toml";
  const BenchFile b = readBenchFile(file);
  EXPECT_EQ(b.file, file);
  // sim: scene paths are relative to the bench file, made absolute.
  const fs::path scene = (source / "data" / "scenes" / "inspection_bench.toml").lexically_normal();
  const DeviceUri sceneUri{.scheme = "sim", .path = scene.string()};
  EXPECT_EQ(b.cameraUri, sceneUri);
  EXPECT_EQ(b.displayUri, sceneUri);
  EXPECT_EQ(b.captureUri, sceneUri);
  EXPECT_TRUE(b.lightFieldFile.empty());
  EXPECT_TRUE(fs::is_regular_file(b.captureUri->path)) << b.captureUri->path;
  // [camera]
  EXPECT_EQ(b.camera.exposure_us, 10000);
  EXPECT_EQ(b.camera.gain, 0);
  EXPECT_EQ(b.camera.pixelFormat, PixelFormat::Mono12);
  EXPECT_EQ(b.camera.trigger, TriggerMode::Software);
  EXPECT_EQ(b.camera.binning, 1);
  EXPECT_EQ(b.objectPixel_mm, 0.5);
  EXPECT_EQ(b.noise.gain_dnPerElectron, 0.39);
  EXPECT_EQ(b.noise.read_dn, 0.98);
  EXPECT_EQ(b.grabTimeout_ms, 5000);
  EXPECT_EQ(b.retries, 3);
  // [display]
  EXPECT_EQ(b.settle_ms, 0);
  EXPECT_EQ(b.white, 0);
  // [geometry]: the centre written is the 56 x 56 image's centre
  EXPECT_EQ(b.distance_mm, 30);
  ASSERT_TRUE(b.partCentre_px.has_value());
  EXPECT_EQ(b.partCentre_px->x, 27.5);
  EXPECT_EQ(b.partCentre_px->y, 27.5);
  EXPECT_EQ(b.partFrame(56, 56).origin_px.x, b.partCentre_px->x);
  // [reference]
  EXPECT_EQ(b.referenceFolder, (source / "out" / "bench" / "reference").lexically_normal());
  EXPECT_EQ(b.referenceFrames, 16);
  ASSERT_TRUE(b.maskRadius_mm.has_value());
  EXPECT_EQ(*b.maskRadius_mm, 12.2);
  EXPECT_EQ(b.maskLitFraction, 0.25);
  // [inspection]
  EXPECT_EQ(b.inspectionFrames, 1);
  EXPECT_EQ(b.absolute_dn, 0);
  EXPECT_EQ(b.relative, 6);
  EXPECT_EQ(b.smallestDefect_mm, 1.0);
  EXPECT_EQ(b.closing_mm, 0.5);
  EXPECT_EQ(b.minDefectArea_mm2, 0);
  EXPECT_EQ(b.rules.maxDefects, 0);
  EXPECT_FALSE(b.rules.maxDefectArea_mm2.has_value());
  EXPECT_FALSE(b.rules.maxTotalArea_mm2.has_value());
  // [output] and [run]
  EXPECT_EQ(b.outputFolder, (source / "out" / "bench" / "inspections").lexically_normal());
  EXPECT_EQ(b.saveImages, SaveImages::Failed);
  EXPECT_EQ(b.onDeviceLoss, OnDeviceLoss::Stop);
  EXPECT_EQ(b.waitLimit_s, 60);
  // In camera pixels of 0.5 mm: σ = 1 mm / 4 / 0.5 mm, closing 0.5 mm = 1 pixel, every region counts.
  const DetectionSettings d = b.detection();
  EXPECT_DOUBLE_EQ(d.smoothing_px, 0.5);
  EXPECT_EQ(d.closing_px, 1);
  EXPECT_EQ(d.minArea_px, 1);
  EXPECT_EQ(d.relative, 6);
  EXPECT_EQ(d.absolute_dn, 0);
}

TEST_F(BenchFileTest, MissingFileIsNotFound) {
  const fs::path file = folder_ / "benches" / "absent.toml";
  EXPECT_TRUE(throwsError([&] { readBenchFile(file); }, Errc::NotFound, {file.string()}));
}

// ---------------------------------------------------------------------------
// Paths and URIs

TEST_F(BenchFileTest, RelativePathsAreRelativeToTheBenchFile) {
  const fs::path dir = folder_.path() / "benches";
  const BenchFile b = read(kBench);
  EXPECT_EQ(b.referenceFolder, dir / "reference");
  EXPECT_EQ(b.outputFolder, folder_.path() / "inspections");
  // A device URI of another scheme is kept as written; a sim: scene path becomes absolute, its query kept.
  EXPECT_EQ(b.cameraUri.text(), "aravis:Fake-GV01");
  EXPECT_EQ(b.displayUri.text(), "usb:1209:4c46/LFI-0001");
  EXPECT_EQ(b.captureUri, (DeviceUri{.scheme = "sim",
                                     .path = (folder_.path() / "scenes" / "bench.toml").string(),
                                     .query = {{"spp", "8"}}}));
  // A light field file instead of a capture device, likewise relative to the file.
  const BenchFile f =
      read(replaced(kBench, "uri = \"sim:../scenes/bench.toml?spp=8\"", "light_field = \"../light fields/lf.exr\""));
  EXPECT_FALSE(f.captureUri.has_value());
  EXPECT_EQ(f.lightFieldFile, folder_.path() / "light fields" / "lf.exr");
}

TEST_F(BenchFileTest, CalibratedValuesCarryTheirUncertaintiesAsKeysAtTheFilesCoverageFactor) {
  std::string text = replaced(kBench, "version = 1\n", "version = 1\ncoverage_factor = 3\n");
  text = replaced(text, "object_pixel_mm = 0.5", "object_pixel_mm = 0.5\nobject_pixel_mm_u = 0.002");
  text = replaced(text, "distance_mm = 30", "distance_mm = 30\ndistance_mm_u = 0.4");
  text =
      replaced(text, "part_centre_px = [27.5, 27.5]", "part_centre_px = [27.5, 27.5]\npart_centre_px_u = [0.1, 0.2]");
  const BenchFile b = read(text);
  EXPECT_EQ(b.coverageFactor, 3);
  EXPECT_EQ(b.uncertainty.at("camera.object_pixel_mm"), std::vector<double>{0.002});
  EXPECT_EQ(b.uncertainty.at("geometry.distance_mm"), std::vector<double>{0.4});
  EXPECT_EQ(b.uncertainty.at("geometry.part_centre_px"), (std::vector<double>{0.1, 0.2}));
  EXPECT_EQ(read(kBench).coverageFactor, 2) << "the default";
  EXPECT_TRUE(read(kBench).uncertainty.empty());
  // Read and checked like every key: the value's shape, >= 0, beside its value.
  const std::string two = replaced(kBench, "distance_mm = 30", "distance_mm = 30\ndistance_mm_u = [0.4, 0.1]");
  EXPECT_TRUE(refusedAt(two, lineOf(two, "distance_mm_u"), "key 'geometry.distance_mm_u'"));
  const std::string negative =
      replaced(kBench, "object_pixel_mm = 0.5", "object_pixel_mm = 0.5\nobject_pixel_mm_u = -1");
  EXPECT_TRUE(refusedAt(negative, lineOf(negative, "object_pixel_mm_u"), "key 'camera.object_pixel_mm_u' = -1"));
  const std::string alone =
      replaced(kBench, "distance_mm = 30", "distance_mm = 30\ndisplay_per_pixel_mm_u = [0, 0, 0, 0]");
  EXPECT_TRUE(refusedAt(alone, lineOf(alone, "display_per_pixel_mm_u"),
                        "key 'geometry.display_per_pixel_mm_u' is the uncertainty of display_per_pixel_mm"));
  const std::string k = replaced(kBench, "version = 1\n", "version = 1\ncoverage_factor = 0.5\n");
  EXPECT_TRUE(refusedAt(k, lineOf(k, "coverage_factor"), "key 'coverage_factor' = 0.5 is outside"));
  // [display.optics]: the numbers of its class take a U; another class's key does not.
  const std::string optics =
      replaced(kBench, "\n[capture]",
               "\n[display.optics]\noptics = \"lenslet_array\"\narray_pitch_mm = 1.0\narray_pitch_mm_u = 0.0004\n"
               "array_offset_mm = [0, 0]\narray_offset_mm_u = [0.003, 0.004]\ngap_mm = 1.37\n\n[capture]");
  const BenchFile o = read(optics);
  EXPECT_EQ(o.uncertainty.at("display.optics.array_pitch_mm"), std::vector<double>{0.0004});
  EXPECT_EQ(o.uncertainty.at("display.optics.array_offset_mm"), (std::vector<double>{0.003, 0.004}));
  const std::string slant = replaced(optics, "gap_mm = 1.37\n", "gap_mm = 1.37\nslant_rad_u = 0.001\n");
  EXPECT_TRUE(refusedAt(slant, lineOf(slant, "slant_rad_u"), "unknown key 'display.optics.slant_rad_u'"));
}

TEST_F(BenchFileTest, ThePartsModelIsRelativeToTheBenchFileAndTheDefectDepthNeedsIt) {
  const std::string model = replaced(kBench, "distance_mm = 30",
                                     "distance_mm = 30\npart_model = \"../scenes/lens.toml\"\ndefect_depth_mm = -1.5");
  const BenchFile b = read(model);
  EXPECT_EQ(b.partModel, folder_.path() / "scenes" / "lens.toml");
  EXPECT_EQ(b.defectDepth_mm, -1.5);
  EXPECT_TRUE(read(kBench).partModel.empty());
  const std::string depth = replaced(kBench, "distance_mm = 30", "distance_mm = 30\ndefect_depth_mm = 1");
  EXPECT_TRUE(refusedAt(depth, lineOf(depth, "defect_depth_mm"), "key 'geometry.defect_depth_mm' places defects"));
}

TEST_F(BenchFileTest, TheCamerasDarkAndFlatFramesAreRelativeToTheBenchFileAndTheFlatNeedsTheDark) {
  const std::string dark = replaced(kBench, "exposure_us = 10000", "exposure_us = 10000\ndark_frame = \"c/dark.exr\"");
  const BenchFile b = read(replaced(dark, "dark.exr\"", "dark.exr\"\nflat_frame = \"c/flat.exr\""));
  EXPECT_EQ(b.darkFrame, folder_.path() / "benches" / "c" / "dark.exr");
  EXPECT_EQ(b.flatFrame, folder_.path() / "benches" / "c" / "flat.exr");
  EXPECT_TRUE(read(kBench).darkFrame.empty());
  const std::string flatOnly = replaced(kBench, "exposure_us = 10000", "exposure_us = 10000\nflat_frame = \"f.exr\"");
  EXPECT_TRUE(refusedAt(flatOnly, lineOf(flatOnly, "flat_frame"), "key 'camera.flat_frame' needs a dark_frame"));
}

TEST_F(BenchFileTest, AbsolutePathsAndUrisAreKept) {
  const std::string text =
      replaced(replaced(replaced(kBench, "folder = \"reference\"", "folder = \"/srv/lfi/reference\""),
                        "folder = \"../inspections\"", "folder = \"/srv/lfi/inspections\""),
               "uri = \"sim:../scenes/bench.toml?spp=8\"", "uri = \"sim:/srv/scenes/bench.toml\"");
  const BenchFile b = read(text);
  EXPECT_EQ(b.referenceFolder, fs::path("/srv/lfi/reference"));
  EXPECT_EQ(b.outputFolder, fs::path("/srv/lfi/inspections"));
  EXPECT_EQ(b.captureUri->text(), "sim:/srv/scenes/bench.toml");
}

TEST_F(BenchFileTest, SimUriPathIsPercentDecodedAndEncodedAgain) {
  // "my scene?.toml" written percent-encoded: the URI made absolute still parses back to the same file.
  const BenchFile b =
      read(replaced(kBench, "uri = \"sim:../scenes/bench.toml?spp=8\"", "uri = \"sim:my%20scene%3F.toml?spp=8\""));
  const DeviceUri& uri = *b.captureUri;
  EXPECT_EQ(fs::path(uri.path), folder_.path() / "benches" / "my scene?.toml");
  ASSERT_EQ(uri.query.size(), 1u);
  EXPECT_EQ(uri.query.at("spp"), "8");
  EXPECT_EQ(DeviceUri::parse(uri.text(), "capture", "sim:x"), uri);
}

// The display's optics have one place too: [display.optics], or a calibration file the usb: URI names.
TEST_F(BenchFileTest, DisplayOpticsStatedTwiceAreRefused) {
  const std::string optics =
      "\n[display.optics]\noptics = \"pinhole_array\"\narray_pitch_mm = 1\npinhole_diameter_mm = 0.1\ngap_mm = 3\n";
  const std::string text = replaced(kBench, "uri = \"usb:1209:4c46/LFI-0001\"",
                                    "uri = \"usb:1209:4c46/LFI-0001?calibration=display.toml\"" + optics);
  EXPECT_TRUE(throwsError([&] { read(text); }, Errc::Config,
                          {"key 'display.uri'", "stated twice", "[display.optics]", "display.toml"}));
  EXPECT_NO_THROW(
      read(replaced(kBench, "uri = \"usb:1209:4c46/LFI-0001\"", "uri = \"usb:1209:4c46/LFI-0001\"" + optics)));
}

// Δ has one place in a bench file, [geometry] distance_mm: a capture URI that
// still carries it is refused, saying where Δ lives now.
TEST_F(BenchFileTest, ACaptureUriThatCarriesTheDistanceIsRefused) {
  const std::string text =
      replaced(kBench, "uri = \"sim:../scenes/bench.toml?spp=8\"", "uri = \"coded:?distance_mm=30&rounds=2\"");
  EXPECT_TRUE(refusedAt(text, lineOf(text, "coded:?distance_mm"), "key 'capture.uri'"));
  EXPECT_TRUE(throwsError([&] { read(text); }, Errc::Config,
                          {"[geometry] distance_mm", "delete 'distance_mm=30'", "docs/inspection.md"}));
}

TEST_F(BenchFileTest, EmptyPathIsRefused) {
  EXPECT_TRUE(refusedAt(replaced(kBench, "folder = \"reference\"", "folder = \"\""),
                        lineOf(kBench, "folder = \"reference\""), "key 'reference.folder' is empty"));
}

TEST_F(BenchFileTest, MalformedDeviceUriNamesFileLineAndKey) {
  EXPECT_TRUE(refusedAt(replaced(kBench, "uri = \"aravis:Fake-GV01\"", "uri = \"Fake-GV01\""),
                        lineOf(kBench, "uri = \"aravis:Fake-GV01\""), "key 'camera.uri': "));
}

// ---------------------------------------------------------------------------
// Defaults

TEST_F(BenchFileTest, OptionalKeysAndTablesTakeTheirDefaults) {
  const std::string minimal = R"(format = "lfi-inspection-bench"
version = 1
[camera]
uri = "aravis:Fake-GV01"
exposure_us = 2000
object_pixel_mm = 0.25
read_noise_dn = 1
dn_per_electron = 0.5
[display]
uri = "usb:1209:4c46"
[capture]
light_field = "lf.exr"
[geometry]
distance_mm = 12
[reference]
folder = "ref"
[output]
folder = "out"
)";
  const BenchFile b = read(minimal);
  EXPECT_EQ(b.camera.exposure_us, 2000);
  EXPECT_EQ(b.camera.gain, 0);
  EXPECT_EQ(b.camera.pixelFormat, PixelFormat::Mono12);
  EXPECT_EQ(b.camera.trigger, TriggerMode::Software);
  EXPECT_EQ(b.camera.triggerLine, "Line0");
  EXPECT_EQ(b.camera.frameRate_hz, 0);
  EXPECT_EQ(b.camera.binning, 1);
  EXPECT_EQ(b.grabTimeout_ms, 5000);
  EXPECT_EQ(b.retries, 3);
  EXPECT_EQ(b.settle_ms, 0);
  EXPECT_EQ(b.white, 0);
  EXPECT_FALSE(b.partCentre_px.has_value());
  EXPECT_EQ(b.referenceFrames, 16);
  EXPECT_FALSE(b.maskRadius_mm.has_value());
  EXPECT_EQ(b.maskLitFraction, 0.25);
  EXPECT_EQ(b.inspectionFrames, 1);
  EXPECT_EQ(b.absolute_dn, 0);
  EXPECT_EQ(b.relative, 6);
  EXPECT_EQ(b.smallestDefect_mm, 0);
  EXPECT_EQ(b.closing_mm, 0);
  EXPECT_EQ(b.minDefectArea_mm2, 0);
  EXPECT_EQ(b.rules.maxDefects, 0);
  EXPECT_FALSE(b.rules.maxDefectArea_mm2.has_value());
  EXPECT_FALSE(b.rules.maxTotalArea_mm2.has_value());
  EXPECT_EQ(b.saveImages, SaveImages::Failed);
  EXPECT_EQ(b.onDeviceLoss, OnDeviceLoss::Stop);
  EXPECT_EQ(b.waitLimit_s, 60);
  const DetectionSettings d = b.detection();
  EXPECT_EQ(d.smoothing_px, 0);
  EXPECT_EQ(d.closing_px, 0);
  EXPECT_EQ(d.minArea_px, 1);
}

TEST_F(BenchFileTest, EveryOptionalKeyIsRead) {
  const std::string text =
      replaced(replaced(replaced(kBench, "trigger = \"software\"",
                                 "trigger = \"line\"\ntrigger_line = \"Line2\"\ngain = 3.5\nbinning = 2\n"
                                 "grab_timeout_ms = 900\nretries = 0"),
                        "[output]",
                        "frames = 4\nabsolute_dn = 12\nmin_defect_area_mm2 = 2\nmax_defects = 2\n"
                        "max_defect_area_mm2 = 3\nmax_total_area_mm2 = 5\n\n[output]\nsave_images = \"all\""),
               "uri = \"usb:1209:4c46/LFI-0001\"", "uri = \"usb:1209:4c46/LFI-0001\"\nsettle_ms = 40\nwhite = 0.75") +
      "\n[run]\non_device_loss = \"wait\"\nwait_limit_s = 300\n";
  const BenchFile b = read(replaced(text, "mask_lit_fraction = 0.25", "mask_lit_fraction = 0.5\nframes = 32"));
  EXPECT_EQ(b.camera.trigger, TriggerMode::Line);
  EXPECT_EQ(b.camera.triggerLine, "Line2");
  EXPECT_EQ(b.camera.gain, 3.5);
  EXPECT_EQ(b.camera.binning, 2);
  EXPECT_EQ(b.grabTimeout_ms, 900);
  EXPECT_EQ(b.retries, 0);
  EXPECT_EQ(b.settle_ms, 40);
  EXPECT_EQ(b.white, 0.75);
  EXPECT_EQ(b.referenceFrames, 32);
  EXPECT_EQ(b.maskLitFraction, 0.5);
  EXPECT_EQ(b.inspectionFrames, 4);
  EXPECT_EQ(b.absolute_dn, 12);
  EXPECT_EQ(b.minDefectArea_mm2, 2);
  EXPECT_EQ(b.rules.maxDefects, 2);
  EXPECT_EQ(b.rules.maxDefectArea_mm2, 3.0);
  EXPECT_EQ(b.rules.maxTotalArea_mm2, 5.0);
  EXPECT_EQ(b.saveImages, SaveImages::All);
  EXPECT_EQ(b.onDeviceLoss, OnDeviceLoss::Wait);
  EXPECT_EQ(b.waitLimit_s, 300);

  const BenchFile freeRun =
      read(replaced(kBench, "trigger = \"software\"", "trigger = \"free_run\"\nframe_rate_hz = 25"));
  EXPECT_EQ(freeRun.camera.trigger, TriggerMode::FreeRun);
  EXPECT_EQ(freeRun.camera.frameRate_hz, 25);
}

// ---------------------------------------------------------------------------
// Mistakes, each named by file, line and key

TEST_F(BenchFileTest, MisspeltTableNamesFileLineAndKey) {
  const std::string text = replaced(kBench, "[camera]", "[camra]");
  EXPECT_TRUE(refusedAt(text, lineOf(text, "[camra]"), "unknown key 'camra'"));
}

TEST_F(BenchFileTest, MisspeltTopLevelKeyNamesFileLineAndKey) {
  const std::string text = replaced(kBench, "version = 1", "version = 1\nformt = \"x\"");
  EXPECT_TRUE(refusedAt(text, lineOf(text, "formt"), "unknown key 'formt'"));
}

TEST_F(BenchFileTest, MisspeltKeyInATableNamesFileLineAndKey) {
  // Named as a misspelling, not as the missing exposure_us.
  const std::string text = replaced(kBench, "exposure_us = 10000", "exposur_us = 10000");
  EXPECT_TRUE(refusedAt(text, lineOf(text, "exposur_us"), "unknown key 'camera.exposur_us'"));
  const std::string output = kBench + "save_image = \"all\"\n";
  EXPECT_TRUE(refusedAt(output, lineOf(output, "save_image ="), "unknown key 'output.save_image'"));
  const std::string run = kBench + "[run]\non_device_los = \"wait\"\n";
  EXPECT_TRUE(refusedAt(run, lineOf(run, "on_device_los"), "unknown key 'run.on_device_los'"));
}

TEST_F(BenchFileTest, MissingRequiredKeyNamesFileTableLineAndKey) {
  struct Case {
    std::string line, key, table;
  };
  for (const Case& c : std::vector<Case>{{"object_pixel_mm = 0.5\n", "camera.object_pixel_mm", "[camera]"},
                                         {"exposure_us = 10000\n", "camera.exposure_us", "[camera]"},
                                         {"read_noise_dn = 0.98\n", "camera.read_noise_dn", "[camera]"},
                                         {"uri = \"usb:1209:4c46/LFI-0001\"\n", "display.uri", "[display]"},
                                         {"distance_mm = 30\n", "geometry.distance_mm", "[geometry]"},
                                         {"folder = \"reference\"\n", "reference.folder", "[reference]"},
                                         {"folder = \"../inspections\"\n", "output.folder", "[output]"}}) {
    SCOPED_TRACE(c.key);
    const std::string text = replaced(kBench, c.line, "");
    EXPECT_TRUE(refusedAt(text, lineOf(text, c.table), fmt::format("key '{}' is missing", c.key)));
  }
  const std::string noFormat = replaced(kBench, "format = \"lfi-inspection-bench\"\n", "");
  EXPECT_TRUE(refusedAt(noFormat, 1, "key 'format' is missing"));
}

TEST_F(BenchFileTest, MissingRequiredTableNamesFileAndTable) {
  const std::string text = replaced(kBench, "[geometry]\ndistance_mm = 30\npart_centre_px = [27.5, 27.5]\n", "");
  const fs::path file = write(text);
  EXPECT_TRUE(throwsError([&] { readBenchFile(file); }, Errc::Config, {file.string(), "[geometry]", "missing"}));
}

TEST_F(BenchFileTest, ValueOutOfRangeOrOfTheWrongKindNamesFileLineAndKey) {
  struct Case {
    std::string from, to, message;
  };
  for (const Case& c : std::vector<Case>{
           {"exposure_us = 10000", "exposure_us = 0", "key 'camera.exposure_us' = 0 is outside"},
           {"exposure_us = 10000", "exposure_us = nan", "key 'camera.exposure_us' = nan is outside"},
           {"exposure_us = 10000", "exposure_us = \"fast\"", "key 'camera.exposure_us' must be a number"},
           {"object_pixel_mm = 0.5", "object_pixel_mm = 0", "key 'camera.object_pixel_mm' = 0 is outside"},
           {"object_pixel_mm = 0.5", "object_pixel_mm = -0.5", "key 'camera.object_pixel_mm' = -0.5 is outside"},
           {"pixel_format = \"Mono12\"", "pixel_format = \"Mono10\"",
            "key 'camera.pixel_format' = 'Mono10' is not one of: Mono8, Mono12, Mono16"},
           {"trigger = \"software\"", "trigger = \"hardware\"", "key 'camera.trigger' = 'hardware' is not one of"},
           {"trigger = \"software\"", "binning = 17", "key 'camera.binning' = 17 is outside [1, 16]"},
           {"trigger = \"software\"", "binning = 1.5", "key 'camera.binning' must be an integer"},
           {"read_noise_dn = 0.98", "read_noise_dn = -1", "key 'camera.read_noise_dn' = -1 is outside"},
           {"distance_mm = 30", "distance_mm = -5", "key 'geometry.distance_mm' = -5 is outside"},
           {"part_centre_px = [27.5, 27.5]", "part_centre_px = [27.5, 27.5, 0]",
            "key 'geometry.part_centre_px' must be an array of 2 numbers"},
           {"mask_radius_mm = 12.2", "mask_radius_mm = -1", "key 'reference.mask_radius_mm' = -1 is outside"},
           {"mask_lit_fraction = 0.25", "mask_lit_fraction = 1.5",
            "key 'reference.mask_lit_fraction' = 1.5 is outside [0, 1]"},
           {"mask_lit_fraction = 0.25", "frames = 0", "key 'reference.frames' = 0 is outside"},
           {"relative = 6", "relative = -1", "key 'inspection.relative' = -1 is outside"},
           {"closing_mm = 0.5", "closing_mm = -0.5", "key 'inspection.closing_mm' = -0.5 is outside"},
           {"folder = \"../inspections\"", "folder = \"../inspections\"\nsave_images = \"some\"",
            "key 'output.save_images' = 'some' is not one of"},
       }) {
    SCOPED_TRACE(c.to);
    const std::string text = replaced(kBench, c.from, c.to);
    // (The line of the key edited: the last line of `to`.)
    EXPECT_TRUE(refusedAt(text, lineOf(text, c.to.substr(c.to.rfind('\n') + 1)), c.message));
  }
  const std::string run = kBench + "[run]\nwait_limit_s = -1\n";
  EXPECT_TRUE(refusedAt(run, lineOf(run, "wait_limit_s"), "key 'run.wait_limit_s' = -1 is outside"));
}

TEST_F(BenchFileTest, CaptureNeedsExactlyOneOfUriAndLightField) {
  const std::string uriLine = "uri = \"sim:../scenes/bench.toml?spp=8\"";
  const std::string both = replaced(kBench, uriLine, uriLine + "\nlight_field = \"lf.exr\"");
  EXPECT_TRUE(refusedAt(both, lineOf(both, uriLine), "key 'capture.uri': [capture] needs exactly one of"));
  const std::string neither = replaced(kBench, uriLine + "\n", "");
  EXPECT_TRUE(
      refusedAt(neither, lineOf(neither, "[capture]"), "key 'capture.light_field': [capture] needs exactly one of"));
}

TEST_F(BenchFileTest, TriggerLineOnlyWithLineTrigger) {
  const std::string text =
      replaced(kBench, "trigger = \"software\"", "trigger = \"software\"\ntrigger_line = \"Line1\"");
  EXPECT_TRUE(
      refusedAt(text, lineOf(text, "trigger_line"), "key 'camera.trigger_line' is only for trigger = \"line\""));
  // Without `trigger` (the default: software) too.
  const std::string implicit = replaced(kBench, "trigger = \"software\"", "trigger_line = \"Line1\"");
  EXPECT_TRUE(refusedAt(implicit, lineOf(implicit, "trigger_line"), "key 'camera.trigger_line' is only for"));
  const std::string rate = replaced(kBench, "trigger = \"software\"", "trigger = \"line\"\nframe_rate_hz = 30");
  EXPECT_TRUE(
      refusedAt(rate, lineOf(rate, "frame_rate_hz"), "key 'camera.frame_rate_hz' is only for trigger = \"free_run\""));
}

TEST_F(BenchFileTest, WrongFormatOrVersionIsRefused) {
  const std::string format = replaced(kBench, "format = \"lfi-inspection-bench\"", "format = \"lfi-scene\"");
  EXPECT_TRUE(refusedAt(format, 2, "key 'format' = 'lfi-scene' is not one of: lfi-inspection-bench"));
  const std::string version = replaced(kBench, "version = 1", "version = 2");
  EXPECT_TRUE(refusedAt(version, 3, "key 'version' = 2 is outside [1, 1]"));
  const std::string text = replaced(kBench, "version = 1", "version = \"1\"");
  EXPECT_TRUE(refusedAt(text, 3, "key 'version' must be an integer"));
}

TEST_F(BenchFileTest, TomlSyntaxErrorNamesFileAndLine) {
  const std::string text = replaced(kBench, "distance_mm = 30", "distance_mm = = 30");
  const fs::path file = write(text);
  EXPECT_TRUE(throwsError([&] { readBenchFile(file); }, Errc::Config,
                          {fmt::format("{}:{}:", file.string(), lineOf(text, "distance_mm = ="))}));
}

TEST_F(BenchFileTest, SmoothingOrClosingBeyondTheFinderIsRefused) {
  // 201 mm at 0.5 mm pixels: σ = 100.5 pixels, beyond the 100 findDefects takes.
  const std::string text = replaced(kBench, "smallest_defect_mm = 1.0", "smallest_defect_mm = 201");
  const fs::path file = write(text);
  EXPECT_TRUE(throwsError([&] { readBenchFile(file); }, Errc::Config, {file.string(), "smallest_defect_mm = 201"}));
  EXPECT_NO_THROW(read(replaced(kBench, "smallest_defect_mm = 1.0", "smallest_defect_mm = 200")));
  const std::string closing = replaced(kBench, "closing_mm = 0.5", "closing_mm = 50.5");  // 101 pixels
  const fs::path closingFile = write(closing, "closing.toml");
  EXPECT_TRUE(
      throwsError([&] { readBenchFile(closingFile); }, Errc::Config, {closingFile.string(), "closing_mm = 50.5"}));
}

// ---------------------------------------------------------------------------
// The reference hash

}  // namespace
