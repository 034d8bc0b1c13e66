// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/reference_package.h"

#include "lfi/controller/bench_file.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <limits>
#include <type_traits>
#include <vector>

namespace lfi {

namespace fs = std::filesystem;
using nlohmann::ordered_json;

namespace {

constexpr const char* kFormat = "lfi-reference";
constexpr int kVersion = 1;

const char* typeName(int type) {
  return type == CV_8UC1 ? "uint8" : type == CV_16UC1 ? "uint16" : type == CV_32FC1 ? "float32" : "?";
}

int typeFromName(const std::string& name) {
  return name == "uint8" ? CV_8UC1 : name == "uint16" ? CV_16UC1 : name == "float32" ? CV_32FC1 : -1;
}

void writeImage(const fs::path& file, const cv::Mat& image, const std::string& description, const char* unit) {
  writeRadianceExr(file, image, {0, description, unit}, Overwrite::Refuse);
}

// A file of the package that must be there: Errc::InvalidFile (the package is
// damaged), not NotFound (no package), when it is not.
fs::path packageFile(const fs::path& folder, const char* name) {
  const fs::path file = folder / name;
  std::error_code ec;
  if (!fs::exists(file, ec)) fail(Errc::InvalidFile, "reference package '{}': {} is missing", folder.string(), name);
  return file;
}

// An integer field of reference.json: a JSON integer within T's range. (A float, or an integer out of range,
// would convert with undefined behaviour: 1e21 as a width did, found by fuzzing.)
template <typename T>
T integerField(const fs::path& folder, const ordered_json& value, const char* field) {
  if (value.is_number_unsigned() &&
      value.get<std::uint64_t>() <= static_cast<std::uint64_t>(std::numeric_limits<T>::max()))
    return static_cast<T>(value.get<std::uint64_t>());
  if constexpr (std::is_signed_v<T>)
    if (value.is_number_integer() && value.get<std::int64_t>() >= std::numeric_limits<T>::min() &&
        value.get<std::int64_t>() <= std::numeric_limits<T>::max())
      return static_cast<T>(value.get<std::int64_t>());
  fail(Errc::InvalidFile, "reference package '{}': reference.json's {} is {}, not an integer in range", folder.string(),
       field, value.dump());
}

void checkPixels(const fs::path& folder, const char* name, const ordered_json& files, const cv::Mat& pixels) {
  std::uint32_t recorded = 0;
  try {
    recorded = integerField<std::uint32_t>(folder, files.at(name).at("pixel_crc32"), "pixel_crc32");
  } catch (const nlohmann::json::exception& e) {
    fail(Errc::InvalidFile, "reference package '{}': reference.json has no pixel CRC-32 for {}: {}", folder.string(),
         name, e.what());
  }
  if (pixelChecksum(pixels) != recorded)
    fail(Errc::Checksum,
         "reference package '{}': {} is not the image the package recorded (pixel CRC-32 {:08x}, "
         "recorded {:08x}): a file from another package?",
         folder.string(), name, pixelChecksum(pixels), recorded);
}

cv::Mat readImage(const fs::path& folder, const char* name, const ordered_json& files, const cv::Size& size) {
  cv::Mat image = readRadianceExr(packageFile(folder, name));
  if (image.size() != size)
    fail(Errc::InvalidFile, "reference package '{}': {} is {} x {}, not the package's {} x {}", folder.string(), name,
         image.cols, image.rows, size.width, size.height);
  checkPixels(folder, name, files, image);
  return image;
}

}  // namespace

cv::Mat partMask(const cv::Mat& ideal, double centre_x, double centre_y, double radius_px, double litFraction) {
  cv::Mat values;
  ideal.convertTo(values, CV_32F);
  cv::Mat mask(ideal.size(), CV_8UC1, cv::Scalar(0));
  std::vector<float> inside;
  for (int row = 0; row < mask.rows; ++row)
    for (int col = 0; col < mask.cols; ++col)
      if (radius_px < 0 ||
          (col - centre_x) * (col - centre_x) + (row - centre_y) * (row - centre_y) <= radius_px * radius_px) {
        mask.at<uchar>(row, col) = 255;
        inside.push_back(values.at<float>(row, col));
      }
  if (inside.empty()) return mask;
  const auto k = inside.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(inside.size() - 1));
  std::nth_element(inside.begin(), k, inside.end());
  mask.setTo(0, values < litFraction * *k);
  return mask;
}

void writeReferencePackage(const fs::path& folder, const ReferencePackage& p, Overwrite overwrite) {
  const cv::Mat mean = p.trainer.mean(), spread = p.trainer.spread();
  if (p.mask.size() != mean.size() || p.mask.type() != CV_8UC1)
    fail(Errc::InvalidArgument, "reference package: the mask ({} x {}) is not an 8-bit image of the trained {} x {}",
         p.mask.cols, p.mask.rows, mean.cols, mean.rows);
  cv::Mat mask01;
  p.mask.convertTo(mask01, CV_32F, 1.0 / 255);
  cv::threshold(mask01, mask01, 0.5, 1.0, cv::THRESH_BINARY);
  const ReferenceInfo& i = p.info;
  ordered_json j;
  j["format"] = kFormat;
  j["version"] = kVersion;
  j["bench"] = {{"file", i.benchFile}, {"reference_hash", i.benchHash}};
  j["created_utc"] = i.created_utc;
  j["updated_utc"] = i.updated_utc;
  j["devices"] = {{"camera", i.camera}, {"display", i.display}, {"capture", i.capture}};
  j["camera_settings"] = {{"exposure_us", i.exposure_us}, {"gain", i.gain}, {"pixel_format", i.pixelFormat}};
  j["white"] = i.white;
  j["image"] = {{"width_px", mean.cols},
                {"height_px", mean.rows},
                {"type", typeName(p.trainer.imageType())},
                {"images_trained", p.trainer.count()}};
  j["files"] = {
      {"lightfield.exr",
       {{"content", "the reference light field the display shows"},
        {"pixel_crc32", pixelChecksum(p.lightField.lensletImage())}}},
      {"ideal.exr",
       {{"content", "golden model: mean of the trained images (DN)"}, {"pixel_crc32", pixelChecksum(mean)}}},
      {"spread.exr",
       {{"content", "sample standard deviation of the trained images (DN), no noise floor"},
        {"pixel_crc32", pixelChecksum(spread)}}},
      {"mask.exr", {{"content", "the part: 1 where defects are looked for"}, {"pixel_crc32", pixelChecksum(mask01)}}}};
  if (!p.panel.empty()) {
    double lo = 0, hi = 0;
    if (p.panel.type() == CV_32FC1) cv::minMaxLoc(p.panel, &lo, &hi);
    if (p.panel.type() != CV_32FC1 || !(lo >= 0 && hi <= 1))
      fail(Errc::InvalidArgument,
           "reference package: the panel image ({}, drive levels {} .. {}) is not CV_32FC1 "
           "drive levels in 0 .. 1",
           cv::typeToString(p.panel.type()), lo, hi);
    j["files"]["panel.exr"] = {{"content", "the reference panel image the display shows: drive levels 0 .. 1"},
                               {"pixel_crc32", pixelChecksum(p.panel)}};
  }
  j["units"] = "lengths mm, times µs; images in camera pixels, row 0 at the top";
  writeFolderAtomically(folder, overwrite, [&](const fs::path& tmp) {
    writeLightFieldExr(tmp / "lightfield.exr", p.lightField);
    writeImage(tmp / "ideal.exr", mean, "golden model ideal: mean of the trained images", kCameraDigitalNumbers);
    writeImage(tmp / "spread.exr", spread, "golden model: sample standard deviation of the trained images",
               kCameraDigitalNumbers);
    writeImage(tmp / "mask.exr", mask01, "the part's mask: 1 where defects are looked for", "mask (0 or 1)");
    if (!p.panel.empty())
      writeImage(tmp / "panel.exr", p.panel,
                 "the reference panel image: column x right, row y down, as the "
                 "display's panel",
                 "drive level (0 .. 1 of full)");
    std::ofstream out(tmp / "reference.json");
    out << j.dump(2, ' ', false, ordered_json::error_handler_t::replace) << "\n";  // (non-UTF-8 names: U+FFFD)
    out.close();
    if (!out) fail(Errc::Io, "cannot write '{}'", (folder / "reference.json").string());
  });
}

ReferencePackage readReferencePackage(const fs::path& folder, const BenchFile* bench) {
  const fs::path metaFile = folder / "reference.json";
  std::error_code ec;
  if (!fs::is_directory(folder, ec))
    fail(Errc::NotFound, "no reference package at '{}' (take one with `lfi capture`)", folder.string());
  std::ifstream in(metaFile);
  if (!in) fail(Errc::InvalidFile, "reference package '{}': reference.json is missing or unreadable", folder.string());
  ordered_json j;
  try {
    j = ordered_json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    fail(Errc::InvalidFile, "reference package '{}': reference.json is not JSON: {}", folder.string(), e.what());
  }
  ReferencePackage p;
  int width = 0, height = 0, type = -1, images = 0;
  try {
    if (j.at("format") != kFormat || j.at("version") != kVersion)
      fail(Errc::InvalidFile, "reference package '{}': reference.json is not format '{}' version {}", folder.string(),
           kFormat, kVersion);
    ReferenceInfo& i = p.info;
    i.benchFile = j.at("bench").at("file");
    i.benchHash = j.at("bench").at("reference_hash");
    i.created_utc = j.at("created_utc");
    i.updated_utc = j.at("updated_utc");
    i.camera = j.at("devices").at("camera");
    i.display = j.at("devices").at("display");
    i.capture = j.at("devices").at("capture");
    i.exposure_us = j.at("camera_settings").at("exposure_us");
    i.gain = j.at("camera_settings").at("gain");
    i.pixelFormat = j.at("camera_settings").at("pixel_format");
    i.white = j.at("white");
    width = integerField<int>(folder, j.at("image").at("width_px"), "width_px");
    height = integerField<int>(folder, j.at("image").at("height_px"), "height_px");
    type = typeFromName(j.at("image").at("type"));
    images = integerField<int>(folder, j.at("image").at("images_trained"), "images_trained");
    for (const char* name : {"lightfield.exr", "ideal.exr", "spread.exr", "mask.exr"})
      integerField<std::uint32_t>(folder, j.at("files").at(name).at("pixel_crc32"), "pixel_crc32");
  } catch (const nlohmann::json::exception& e) {
    fail(Errc::InvalidFile, "reference package '{}': reference.json lacks a field or has one of the wrong type: {}",
         folder.string(), e.what());
  }
  if (width < 1 || height < 1 || type < 0 || images < 1)
    fail(Errc::InvalidFile, "reference package '{}': reference.json's image ({} x {}, {} images) is not valid",
         folder.string(), width, height, images);
  if (bench && bench->referenceHash() != p.info.benchHash)
    fail(Errc::Config,
         "reference package '{}' was taken on another bench (reference hash {}, from '{}'); bench file "
         "'{}' has {}: take a new reference with `lfi capture {} --force`",
         folder.string(), p.info.benchHash, p.info.benchFile, bench->file.string(), bench->referenceHash(),
         bench->file.string());
  const cv::Size size(width, height);
  const cv::Mat mean = readImage(folder, "ideal.exr", j["files"], size);
  const cv::Mat spread = readImage(folder, "spread.exr", j["files"], size);
  const cv::Mat mask01 = readImage(folder, "mask.exr", j["files"], size);
  p.lightField = readLightFieldExr(packageFile(folder, "lightfield.exr"));
  checkPixels(folder, "lightfield.exr", j["files"], p.lightField.lensletImage());
  if (j["files"].contains("panel.exr")) {
    p.panel = readRadianceExr(packageFile(folder, "panel.exr"));
    checkPixels(folder, "panel.exr", j["files"], p.panel);
    double lo = 0, hi = 0;
    cv::minMaxLoc(p.panel, &lo, &hi);
    if (!(lo >= 0 && hi <= 1))
      fail(Errc::InvalidFile, "reference package '{}': panel.exr's drive levels {} .. {} are outside 0 .. 1",
           folder.string(), lo, hi);
  }
  try {
    p.trainer = GoldenModelTrainer::resume(mean, spread, images, type);
  } catch (const Error& e) {
    fail(Errc::InvalidFile, "reference package '{}': {}", folder.string(), e.what());
  }
  p.mask = mask01 > 0.5f;
  return p;
}

}  // namespace lfi
