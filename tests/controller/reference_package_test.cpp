// SPDX-License-Identifier: Apache-2.0
// The reference package (controller/include/lfi/controller/reference_package.h):
// a round trip of every file, training resumed from a package, the atomic
// folder write, every kind of damage a package can suffer (each named by
// folder and file), a package from another bench, and the part's mask.

#include "lfi/controller/reference_package.h"

#include "lfi/controller/bench_file.h"
#include "lfi/core/exr_io.h"

#include "lfi_test_support.h"
#include "test_folder.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace lfi;
using lfi::testing_support::TestFolder;
using lfi::testing_support::throwsError;

constexpr int kWidth = 24, kHeight = 16;

std::string readAll(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void writeAll(const fs::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary) << bytes;
}

// Every file of a folder by name, with its bytes.
std::map<std::string, std::string> filesOf(const fs::path& folder) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::directory_iterator(folder))
    files[entry.path().filename().string()] = readAll(entry.path());
  return files;
}

std::vector<std::string> namesIn(const fs::path& folder) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

LightField lightField(int seed) {
  LightFieldGeometry g;
  g.spatialX = 4;
  g.spatialY = 3;
  g.angular = 5;
  g.pixelPitch_mm = 0.05;
  g.distance_mm = 30;
  cv::Mat lenslet(g.height(), g.width(), CV_32FC1);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(lenslet, cv::RNG::UNIFORM, 0.0, 2.0);
  return LightField(g, lenslet);
}

// Frames of one intact part of the given type: a level of `level` DN with a
// gradient across the image and Gaussian noise of `noise` DN, clipped to the type's range.
std::vector<cv::Mat> frames(int count, int type, int seed, double level = 2000, double noise = 20,
                            cv::Size size = {kWidth, kHeight}) {
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  std::vector<cv::Mat> out;
  for (int i = 0; i < count; ++i) {
    cv::Mat f(size, CV_64FC1);
    rng.fill(f, cv::RNG::NORMAL, 0.0, noise);
    for (int row = 0; row < f.rows; ++row)
      for (int col = 0; col < f.cols; ++col) f.at<double>(row, col) += level * (0.5 + 0.5 * col / f.cols);
    cv::Mat typed;
    f.convertTo(typed, type);  // (rounds and saturates to 8 or 16 bits)
    out.push_back(typed);
  }
  return out;
}

GoldenModelTrainer trained(const std::vector<cv::Mat>& images) {
  GoldenModelTrainer t;
  for (const cv::Mat& image : images) t.add(image);
  return t;
}

ReferenceInfo info(const std::string& hash) {
  ReferenceInfo i;
  i.benchFile = "/srv/benches/line 3.toml";
  i.benchHash = hash;
  i.created_utc = "2024-05-06T07:08:09Z";
  i.updated_utc = "2024-05-07T10:11:12Z";
  i.camera = "Aravis \"Fake\" GV01 (aravis:Aravis-Fake-GV01)";
  i.display = "LFI-0001 (usb:1209:4c46/LFI-0001) µ";
  i.capture = "sim:/srv/scenes/bench.toml?spp=8";
  i.exposure_us = 12345.678;
  i.gain = 1.5;
  i.pixelFormat = "Mono12";
  i.white = 0.1 + 0.2;  // (not a short decimal: the JSON must keep every bit)
  return i;
}

ReferencePackage package(const std::vector<cv::Mat>& images, int seed, const std::string& hash = "0123456789abcdef",
                         double maskRadius_px = 7) {
  ReferencePackage p;
  p.info = info(hash);
  p.lightField = lightField(seed);
  p.trainer = trained(images);
  p.mask = partMask(p.trainer.mean(), (kWidth - 1) / 2.0, (kHeight - 1) / 2.0, maskRadius_px, 0.25);
  return p;
}

// How far a stored-and-recomputed sample deviation may be from the original:
// half a float ulp for each of the two float roundings (the stored spread and
// the recomputed one), and the double rounding of (Σx² - n μ²) / (n - 1),
// whose terms are about n μ² and lose up to a few units of DBL_EPSILON of
// that; a variance off by δ moves the deviation by at most 2 δ / (s + √δ).
double spreadTolerance(double s, double mu, int n) {
  const double delta = 8 * DBL_EPSILON * n * mu * mu / std::max(n - 1, 1);
  return s * FLT_EPSILON + 2 * delta / (s + std::sqrt(delta));
}

void expectEqualLightFields(const LightField& a, const LightField& b) {
  EXPECT_EQ(a.geometry(), b.geometry());
  ASSERT_EQ(a.lensletImage().size(), b.lensletImage().size());
  EXPECT_EQ(cv::countNonZero(a.lensletImage() != b.lensletImage()), 0);
}

void expectEqualInfo(const ReferenceInfo& a, const ReferenceInfo& b) {
  EXPECT_EQ(a.benchFile, b.benchFile);
  EXPECT_EQ(a.benchHash, b.benchHash);
  EXPECT_EQ(a.created_utc, b.created_utc);
  EXPECT_EQ(a.updated_utc, b.updated_utc);
  EXPECT_EQ(a.camera, b.camera);
  EXPECT_EQ(a.display, b.display);
  EXPECT_EQ(a.capture, b.capture);
  EXPECT_EQ(a.exposure_us, b.exposure_us);
  EXPECT_EQ(a.gain, b.gain);
  EXPECT_EQ(a.pixelFormat, b.pixelFormat);
  EXPECT_EQ(a.white, b.white);
}

class ReferencePackageTest : public testing::Test {
 protected:
  ReferencePackageTest()
      : folder_("lfi-reference-package-" + std::string(testing::UnitTest::GetInstance()->current_test_info()->name())) {
  }

  // reference.json of `folder`, edited by `edit` and written back.
  static void editJson(const fs::path& folder, const std::function<void(nlohmann::ordered_json&)>& edit) {
    nlohmann::ordered_json j = nlohmann::ordered_json::parse(readAll(folder / "reference.json"));
    edit(j);
    writeAll(folder / "reference.json", j.dump(2));
  }

  TestFolder folder_;
};

// ---------------------------------------------------------------------------
// Round trip and training on

class ReferencePackageRoundTrip : public ReferencePackageTest, public testing::WithParamInterface<int> {};

TEST_P(ReferencePackageRoundTrip, EveryFileReadsBackAsWritten) {
  const int type = GetParam();
  const double level = type == CV_8UC1 ? 150 : 2000, noise = type == CV_8UC1 ? 4 : 20;
  const std::vector<cv::Mat> images = frames(7, type, 1, level, noise);
  const ReferencePackage written = package(images, 1);
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, written, Overwrite::Refuse);
  EXPECT_EQ(namesIn(folder),
            (std::vector<std::string>{"ideal.exr", "lightfield.exr", "mask.exr", "reference.json", "spread.exr"}));

  const ReferencePackage read = readReferencePackage(folder, nullptr);
  expectEqualInfo(read.info, written.info);
  expectEqualLightFields(read.lightField, written.lightField);
  EXPECT_EQ(read.trainer.count(), 7);
  EXPECT_EQ(read.trainer.imageType(), type);
  // The mean is stored as the float it is; n μ and its n-th part are exact in double.
  const cv::Mat mean = written.trainer.mean(), readMean = read.trainer.mean();
  ASSERT_EQ(readMean.size(), mean.size());
  EXPECT_EQ(cv::countNonZero(readMean != mean), 0);
  const cv::Mat spread = written.trainer.spread(), readSpread = read.trainer.spread();
  ASSERT_EQ(readSpread.size(), spread.size());
  for (int row = 0; row < spread.rows; ++row)
    for (int col = 0; col < spread.cols; ++col) {
      const double s = spread.at<float>(row, col), mu = mean.at<float>(row, col);
      ASSERT_GT(s, 0) << "the test's frames vary at every pixel";
      ASSERT_NEAR(readSpread.at<float>(row, col), s, spreadTolerance(s, mu, 7)) << "pixel " << col << ", " << row;
    }
  ASSERT_EQ(read.mask.type(), CV_8UC1);
  ASSERT_EQ(read.mask.size(), written.mask.size());
  EXPECT_EQ(cv::countNonZero(read.mask != written.mask), 0);
  const int inMask = cv::countNonZero(written.mask);
  EXPECT_GT(inMask, 0);
  EXPECT_LT(inMask, kWidth * kHeight);
}

INSTANTIATE_TEST_SUITE_P(ImageTypes, ReferencePackageRoundTrip, testing::Values(CV_8UC1, CV_16UC1, CV_32FC1),
                         [](const testing::TestParamInfo<int>& p) {
                           return std::string(p.param == CV_8UC1 ? "Mono8" : p.param == CV_16UC1 ? "Mono16" : "Float");
                         });

TEST_F(ReferencePackageTest, TrainingGoesOnFromAPackageAsIfAllImagesWereSeen) {
  const int n = 8;  // the images in the package; one more is added after reading it
  const std::vector<cv::Mat> images = frames(n + 1, CV_16UC1, 2);
  const std::vector<cv::Mat> first(images.begin(), images.end() - 1);
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package(first, 2), Overwrite::Refuse);
  ReferencePackage resumed = readReferencePackage(folder, nullptr);
  resumed.trainer.add(images.back());
  ASSERT_EQ(resumed.trainer.count(), n + 1);

  const GoldenModelTrainer stored = trained(first), all = trained(images);
  const cv::Mat storedMean = stored.mean(), storedSpread = stored.spread();
  const CameraNoise noise{.read_dn = 0.98, .gain_dnPerElectron = 0.39};
  const GoldenModel a = resumed.trainer.model(noise), b = all.model(noise);
  EXPECT_EQ(a.images, n + 1);
  const double halfUlp = std::ldexp(1.0, -24);  // a float's relative rounding
  for (int row = 0; row < kHeight; ++row)
    for (int col = 0; col < kWidth; ++col) {
      const double mu = b.ideal.at<float>(row, col), sigma = b.variation.at<float>(row, col);
      const double x = images.back().at<std::uint16_t>(row, col);
      const double mu8 = storedMean.at<float>(row, col), s8 = storedSpread.at<float>(row, col);
      // The stored mean is off by δμ <= |μ₈| 2⁻²⁴, the new mean by n/(n+1) of that; both new means are rounded
      // to float: within one float ulp of each other.
      ASSERT_NEAR(a.ideal.at<float>(row, col), mu, std::abs(mu) * FLT_EPSILON) << "pixel " << col << ", " << row;
      // The variance: the stored spread moves it by (n - 1)/n · 2 s₈² 2⁻²⁴, the stored mean by
      // 2 δμ |μ₈ - x| / (n + 1) (to first order; its n μ² terms cancel). That moves σ by δ / (2σ); each σ is
      // rounded to float (one ulp apart at most), and (Σx² - n μ²) loses a few DBL_EPSILON of n μ² (spreadTolerance).
      const double dVariance =
          (n - 1.0) / n * 2 * s8 * s8 * halfUlp + 2 * std::abs(mu8) * halfUlp * std::abs(mu8 - x) / (n + 1);
      const double tolerance = 2 * dVariance / (2 * sigma) + spreadTolerance(sigma, mu, n + 1);
      ASSERT_NEAR(a.variation.at<float>(row, col), sigma, tolerance) << "pixel " << col << ", " << row;
    }
}

TEST_F(ReferencePackageTest, PackageOfOneImageTrainsOnWithTheSampleDeviation) {
  // One image: a spread of 0, which training on turns into the deviation of the two.
  const std::vector<cv::Mat> images = frames(2, CV_16UC1, 3);
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package({images[0]}, 3), Overwrite::Refuse);
  ReferencePackage p = readReferencePackage(folder, nullptr);
  ASSERT_EQ(p.trainer.count(), 1);
  EXPECT_EQ(cv::countNonZero(p.trainer.spread()), 0);
  p.trainer.add(images[1]);
  const cv::Mat spread = p.trainer.spread();
  for (int row = 0; row < kHeight; ++row)
    for (int col = 0; col < kWidth; ++col) {
      // Two images: s = |x₁ - x₀| / √2 from these integers, up to the rounding to float and of the sums.
      const double x0 = images[0].at<std::uint16_t>(row, col), x1 = images[1].at<std::uint16_t>(row, col);
      const double s = std::abs(x1 - x0) / std::numbers::sqrt2;
      ASSERT_NEAR(spread.at<float>(row, col), s, spreadTolerance(s, (x0 + x1) / 2, 2)) << col << ", " << row;
    }
}

// ---------------------------------------------------------------------------
// Writing over a package

TEST_F(ReferencePackageTest, ExistingPackageIsNotReplacedWithoutAllow) {
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package(frames(3, CV_16UC1, 4), 4, "aaaaaaaaaaaaaaaa"), Overwrite::Refuse);
  const auto before = filesOf(folder);
  EXPECT_TRUE(throwsError(
      [&] { writeReferencePackage(folder, package(frames(5, CV_16UC1, 5), 5, "bbbbbbbbbbbbbbbb"), Overwrite::Refuse); },
      Errc::Exists, {folder.string()}));
  EXPECT_EQ(filesOf(folder), before);
  EXPECT_EQ(namesIn(folder_.path()), std::vector<std::string>{"reference"});
}

TEST_F(ReferencePackageTest, AllowReplacesThePackageAndLeavesNoTemporary) {
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package(frames(3, CV_16UC1, 4), 4, "aaaaaaaaaaaaaaaa"), Overwrite::Refuse);
  const ReferencePackage second = package(frames(5, CV_16UC1, 5), 5, "bbbbbbbbbbbbbbbb", 5);
  writeReferencePackage(folder, second, Overwrite::Allow);
  EXPECT_EQ(namesIn(folder_.path()), std::vector<std::string>{"reference"});  // (no ".reference.tmp-*")
  const ReferencePackage read = readReferencePackage(folder, nullptr);
  EXPECT_EQ(read.info.benchHash, "bbbbbbbbbbbbbbbb");
  EXPECT_EQ(read.trainer.count(), 5);
  expectEqualLightFields(read.lightField, second.lightField);
  EXPECT_EQ(cv::countNonZero(read.trainer.mean() != second.trainer.mean()), 0);
  EXPECT_EQ(cv::countNonZero(read.mask != second.mask), 0);
  // The same package written afresh elsewhere has the same files.
  writeReferencePackage(folder_ / "fresh", second, Overwrite::Refuse);
  EXPECT_EQ(filesOf(folder), filesOf(folder_ / "fresh"));
}

TEST_F(ReferencePackageTest, MaskOfAnotherSizeIsRefused) {
  ReferencePackage p = package(frames(2, CV_16UC1, 6), 6);
  p.mask = cv::Mat(kHeight + 1, kWidth, CV_8UC1, cv::Scalar(255));
  const fs::path folder = folder_ / "reference";
  EXPECT_TRUE(throwsError([&] { writeReferencePackage(folder, p, Overwrite::Refuse); }, Errc::InvalidArgument,
                          {fmt::format("{} x {}", kWidth, kHeight + 1), fmt::format("{} x {}", kWidth, kHeight)}));
  EXPECT_FALSE(fs::exists(folder));
  EXPECT_TRUE(namesIn(folder_.path()).empty());
}

// ---------------------------------------------------------------------------
// The bench a package was taken on

TEST_F(ReferencePackageTest, PackageFromAnotherBenchIsRefusedNamingBothHashes) {
  const std::string benchText = readAll(fs::path(LFI_SOURCE_DIR) / "data" / "benches" / "inspection_sim.toml");
  const fs::path benchFile = folder_.write("bench.toml", benchText);
  const BenchFile bench = readBenchFile(benchFile);
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package(frames(3, CV_16UC1, 7), 7, bench.referenceHash()), Overwrite::Refuse);
  EXPECT_EQ(readReferencePackage(folder, &bench).info.benchHash, bench.referenceHash());

  const size_t at = benchText.find("exposure_us = 10000");
  ASSERT_NE(at, std::string::npos);
  const fs::path otherFile =
      folder_.write("other.toml", benchText.substr(0, at) + "exposure_us = 20000" + benchText.substr(at + 19));
  const BenchFile other = readBenchFile(otherFile);
  ASSERT_NE(other.referenceHash(), bench.referenceHash());
  EXPECT_TRUE(
      throwsError([&] { readReferencePackage(folder, &other); }, Errc::Config,
                  {folder.string(), bench.referenceHash(), other.referenceHash(), otherFile.string(), "lfi capture"}));
}

// ---------------------------------------------------------------------------
// Damaged packages

TEST_F(ReferencePackageTest, MissingFolderIsNotFound) {
  const fs::path folder = folder_ / "none";
  EXPECT_TRUE(
      throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::NotFound, {folder.string(), "lfi capture"}));
}

TEST_F(ReferencePackageTest, MissingOrMalformedReferenceJsonIsInvalidFile) {
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package(frames(2, CV_16UC1, 8), 8), Overwrite::Refuse);
  const std::string json = readAll(folder / "reference.json");

  fs::remove(folder / "reference.json");
  EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile,
                          {folder.string(), "reference.json", "missing"}));
  writeAll(folder / "reference.json", json.substr(0, json.size() / 2));
  EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile,
                          {folder.string(), "reference.json is not JSON"}));
  writeAll(folder / "reference.json", "");
  EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile,
                          {folder.string(), "reference.json is not JSON"}));
  writeAll(folder / "reference.json", json);
  EXPECT_NO_THROW(readReferencePackage(folder, nullptr));
}

TEST_F(ReferencePackageTest, ReferenceJsonLackingAFieldIsInvalidFileNamingIt) {
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package(frames(2, CV_16UC1, 9), 9), Overwrite::Refuse);
  const std::string json = readAll(folder / "reference.json");
  for (const std::string pointer : {"/format",
                                    "/version",
                                    "/bench/file",
                                    "/bench/reference_hash",
                                    "/created_utc",
                                    "/updated_utc",
                                    "/devices/camera",
                                    "/devices/display",
                                    "/devices/capture",
                                    "/camera_settings/exposure_us",
                                    "/camera_settings/gain",
                                    "/camera_settings/pixel_format",
                                    "/white",
                                    "/image/width_px",
                                    "/image/height_px",
                                    "/image/type",
                                    "/image/images_trained",
                                    "/files/ideal.exr/pixel_crc32",
                                    "/files/spread.exr/pixel_crc32",
                                    "/files/mask.exr/pixel_crc32",
                                    "/files/ideal.exr",
                                    "/image"}) {
    SCOPED_TRACE(pointer);
    writeAll(folder / "reference.json", json);
    const nlohmann::ordered_json::json_pointer p(pointer);
    editJson(folder, [&](nlohmann::ordered_json& j) { j[p.parent_pointer()].erase(p.back()); });
    EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile,
                            {folder.string(), "reference.json", fmt::format("'{}'", p.back())}));
  }
}

TEST_F(ReferencePackageTest, ReferenceJsonWithAWrongValueIsInvalidFile) {
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package(frames(2, CV_16UC1, 10), 10), Overwrite::Refuse);
  const std::string json = readAll(folder / "reference.json");
  struct Case {
    std::string pointer;
    nlohmann::ordered_json value;
    std::string message;
  };
  for (const Case& c : std::vector<Case>{
           {"/format", "lfi-inspection-bench", "not format 'lfi-reference' version 1"},
           {"/version", 2, "not format 'lfi-reference' version 1"},
           {"/image/width_px", "24", "width_px is \"24\", not an integer in range"},
           {"/white", nullptr, "wrong type"},
           {"/files/ideal.exr/pixel_crc32", "12345678", "not an integer in range"},
           // Numbers that would convert with undefined behaviour (1e21 as a width found by fuzzing).
           {"/image/width_px", 1e21, "width_px is 1e+21, not an integer in range"},
           {"/image/height_px", 2.5, "height_px is 2.5, not an integer in range"},
           {"/image/images_trained", 4294967296LL, "not an integer in range"},
           {"/files/ideal.exr/pixel_crc32", -1, "not an integer in range"},
           {"/files/mask.exr/pixel_crc32", 8589934592LL, "not an integer in range"},
           {"/image/width_px", 0, "is not valid"},
           {"/image/height_px", -16, "is not valid"},
           {"/image/images_trained", 0, "is not valid"},
           {"/image/type", "int7", "is not valid"},
       }) {
    SCOPED_TRACE(c.pointer + " = " + c.value.dump());
    writeAll(folder / "reference.json", json);
    editJson(folder, [&](nlohmann::ordered_json& j) { j[nlohmann::ordered_json::json_pointer(c.pointer)] = c.value; });
    EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile,
                            {folder.string(), "reference.json", c.message}));
  }
}

TEST_F(ReferencePackageTest, MissingImageIsInvalidFileNamingIt) {
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package(frames(2, CV_16UC1, 11), 11), Overwrite::Refuse);
  for (const char* name : {"ideal.exr", "spread.exr", "mask.exr", "lightfield.exr"}) {
    SCOPED_TRACE(name);
    const std::string bytes = readAll(folder / name);
    fs::remove(folder / name);
    // The folder is a package (reference.json is there), one of its files is not: a damaged package,
    // as a missing reference.json is, not a missing one.
    EXPECT_TRUE(
        throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile, {folder.string(), name}));
    writeAll(folder / name, bytes);
  }
  EXPECT_NO_THROW(readReferencePackage(folder, nullptr));
}

TEST_F(ReferencePackageTest, TruncatedOrCorruptImageIsInvalidFile) {
  const fs::path folder = folder_ / "reference";
  writeReferencePackage(folder, package(frames(2, CV_16UC1, 12), 12), Overwrite::Refuse);
  for (const char* name : {"ideal.exr", "spread.exr", "mask.exr", "lightfield.exr"}) {
    SCOPED_TRACE(name);
    const std::string bytes = readAll(folder / name);
    writeAll(folder / name, bytes.substr(0, bytes.size() / 2));
    EXPECT_TRUE(
        throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile, {(folder / name).string()}));
    writeAll(folder / name, "not an OpenEXR file\n");
    EXPECT_TRUE(
        throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile, {(folder / name).string()}));
    writeAll(folder / name, bytes);
  }
  EXPECT_NO_THROW(readReferencePackage(folder, nullptr));
}

TEST_F(ReferencePackageTest, ImageFromAnotherPackageIsAChecksumError) {
  const fs::path folder = folder_ / "reference", other = folder_ / "other";
  writeReferencePackage(folder, package(frames(3, CV_16UC1, 13), 13), Overwrite::Refuse);
  // The same size and type, other frames and another mask: every image differs.
  writeReferencePackage(other, package(frames(3, CV_16UC1, 14), 14, "0123456789abcdef", 5), Overwrite::Refuse);
  for (const char* name : {"ideal.exr", "spread.exr", "mask.exr"}) {
    SCOPED_TRACE(name);
    const std::string bytes = readAll(folder / name);
    ASSERT_NE(readAll(other / name), bytes);
    fs::copy_file(other / name, folder / name, fs::copy_options::overwrite_existing);
    EXPECT_NO_THROW(readRadianceExr(folder / name));  // (a valid EXR file)
    EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::Checksum,
                            {folder.string(), name, "another package"}));
    writeAll(folder / name, bytes);
  }
  EXPECT_NO_THROW(readReferencePackage(folder, nullptr));
}

TEST_F(ReferencePackageTest, APanelReferenceReadsBackAndIsChecked) {
  // A reference measured through the display keeps its panel image (drive levels) besides the light field.
  ReferencePackage written = package(frames(3, CV_16UC1, 16), 16);
  written.panel.create(30, 40, CV_32FC1);
  cv::RNG(16).fill(written.panel, cv::RNG::UNIFORM, 0.0, 1.0);
  const fs::path folder = folder_ / "reference", other = folder_ / "other";
  writeReferencePackage(folder, written, Overwrite::Refuse);
  EXPECT_EQ(namesIn(folder), (std::vector<std::string>{"ideal.exr", "lightfield.exr", "mask.exr", "panel.exr",
                                                       "reference.json", "spread.exr"}));
  const ReferencePackage read = readReferencePackage(folder, nullptr);
  ASSERT_EQ(read.panel.size(), written.panel.size());
  EXPECT_EQ(cv::countNonZero(read.panel != written.panel), 0);
  EXPECT_TRUE(package(frames(3, CV_16UC1, 16), 16).panel.empty()) << "a light field reference has none";
  // Another package's panel, and a missing one.
  written.panel.setTo(0.5);
  writeReferencePackage(other, written, Overwrite::Refuse);
  fs::copy_file(other / "panel.exr", folder / "panel.exr", fs::copy_options::overwrite_existing);
  EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::Checksum,
                          {folder.string(), "panel.exr", "another package"}));
  fs::remove(folder / "panel.exr");
  EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile,
                          {folder.string(), "panel.exr", "missing"}));
  // Drive levels past full drive: refused when written, and when read (with a checksum that matches them).
  written.panel.at<float>(3, 4) = 1.5f;
  EXPECT_TRUE(throwsError([&] { writeReferencePackage(folder_ / "third", written, Overwrite::Refuse); },
                          Errc::InvalidArgument, {"drive levels", "1.5"}));
  writeRadianceExr(folder / "panel.exr", written.panel, {0, "panel", "drive level"}, Overwrite::Allow);
  editJson(folder,
           [&](nlohmann::ordered_json& j) { j["files"]["panel.exr"]["pixel_crc32"] = pixelChecksum(written.panel); });
  EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile,
                          {folder.string(), "panel.exr", "1.5"}));
}

TEST_F(ReferencePackageTest, ImageOfAnotherSizeIsInvalidFileNamingBothSizes) {
  const fs::path folder = folder_ / "reference", other = folder_ / "other";
  writeReferencePackage(folder, package(frames(2, CV_16UC1, 15), 15), Overwrite::Refuse);
  ReferencePackage small;
  small.info = info("0123456789abcdef");
  small.lightField = lightField(16);
  small.trainer = trained(frames(2, CV_16UC1, 16, 2000, 20, {20, 12}));
  small.mask = cv::Mat(12, 20, CV_8UC1, cv::Scalar(255));
  writeReferencePackage(other, small, Overwrite::Refuse);
  fs::copy_file(other / "ideal.exr", folder / "ideal.exr", fs::copy_options::overwrite_existing);
  EXPECT_TRUE(throwsError([&] { readReferencePackage(folder, nullptr); }, Errc::InvalidFile,
                          {folder.string(), "ideal.exr is 20 x 12", fmt::format("{} x {}", kWidth, kHeight)}));
}

// ---------------------------------------------------------------------------
// The part's mask

TEST(PartMask, DiscOfTheRadiusAroundTheCentre) {
  const cv::Mat ideal(60, 80, CV_32FC1, cv::Scalar(1000));
  for (const double radius : {3.0, 10.5, 20.0, 27.3}) {
    const double cx = 39.25, cy = 30.5;
    const cv::Mat mask = partMask(ideal, cx, cy, radius, 0.25);
    ASSERT_EQ(mask.type(), CV_8UC1);
    ASSERT_EQ(mask.size(), ideal.size());
    int inside = 0, perimeter = 0;
    for (int row = 0; row < mask.rows; ++row)
      for (int col = 0; col < mask.cols; ++col) {
        const double r = std::hypot(col - cx, row - cy);
        const uchar expected = r <= radius ? 255 : 0;
        ASSERT_EQ(mask.at<uchar>(row, col), expected) << "r = " << radius << ", pixel " << col << ", " << row;
        inside += expected != 0;
        perimeter += std::abs(r - radius) < std::numbers::sqrt2 / 2;  // pixels the circle passes through
      }
    // The pixel count is the disc's area up to the pixels along its edge.
    EXPECT_NEAR(inside, std::numbers::pi * radius * radius, perimeter) << "r = " << radius;
    EXPECT_LT(perimeter, 2 * std::numbers::pi * radius * std::numbers::sqrt2 + 8) << "r = " << radius;
  }
}

TEST(PartMask, NegativeRadiusIsTheWholeImage) {
  const cv::Mat ideal(20, 30, CV_16UC1, cv::Scalar(3000));
  const cv::Mat mask = partMask(ideal, 14.5, 9.5, -1, 0.25);
  EXPECT_EQ(cv::countNonZero(mask), 20 * 30);
  EXPECT_EQ(cv::countNonZero(mask != 255), 0);
}

TEST(PartMask, DiscOutsideTheImageIsEmpty) {
  const cv::Mat ideal(20, 30, CV_32FC1, cv::Scalar(100));
  EXPECT_EQ(cv::countNonZero(partMask(ideal, 100, 100, 5, 0.25)), 0);
}

TEST(PartMask, PixelsTheDisplayCannotLightAreLeftOut) {
  // Inside a disc of radius 20: 1000 DN, a gradient of 0..999 DN across a band, a few (< 1 %) hot pixels of
  // 10⁶ DN that must not set the threshold, and outside it a far brighter background that is not the part.
  cv::Mat ideal(60, 80, CV_32FC1, cv::Scalar(1e7));
  const double cx = 40, cy = 30, radius = 20;
  int insideCount = 0;
  for (int row = 0; row < ideal.rows; ++row)
    for (int col = 0; col < ideal.cols; ++col)
      if (std::hypot(col - cx, row - cy) <= radius) {
        ++insideCount;
        ideal.at<float>(row, col) = 1000;
      }
  for (int col = 25; col <= 55; ++col) ideal.at<float>(30, col) = static_cast<float>((col - 25) * 25);  // 0 .. 750
  const std::vector<cv::Point> hot{{40, 15}, {41, 15}, {42, 15}};
  ASSERT_LT(static_cast<int>(hot.size()), insideCount / 100);
  for (const cv::Point& p : hot) ideal.at<float>(p) = 1e6f;

  for (const double fraction : {0.0, 0.25, 0.5}) {
    const cv::Mat mask = partMask(ideal, cx, cy, radius, fraction);
    // The 99th percentile inside is 1000 DN: the threshold is fraction · 1000 (exact in float), and a pixel at it is
    // lit.
    const double threshold = fraction * 1000;
    for (int row = 0; row < ideal.rows; ++row)
      for (int col = 0; col < ideal.cols; ++col) {
        const bool inside = std::hypot(col - cx, row - cy) <= radius;
        const bool lit = ideal.at<float>(row, col) >= threshold;
        ASSERT_EQ(mask.at<uchar>(row, col) != 0, inside && lit)
            << "fraction " << fraction << ", pixel " << col << ", " << row << " = " << ideal.at<float>(row, col);
      }
    for (const cv::Point& p : hot) EXPECT_EQ(mask.at<uchar>(p), 255);
  }
  // A fraction of 0.25 leaves out the band below 250 DN (columns 25..34) and keeps 250 DN (column 35) on.
  const cv::Mat quarter = partMask(ideal, cx, cy, radius, 0.25);
  EXPECT_EQ(cv::countNonZero(quarter.row(30).colRange(25, 35)), 0);
  EXPECT_EQ(cv::countNonZero(quarter.row(30).colRange(35, 56)), 21);
}

}  // namespace
