// SPDX-License-Identifier: Apache-2.0
#pragma once
// The reference package: what `lfi capture` takes once per bench and every
// inspection compares against, one folder written atomically
// (writeFolderAtomically: a reader sees the old package or the new one).
//
//   file             content
//   reference.json   format "lfi-reference", version 1; the bench file and its
//                    reference hash (bench_file.h), the devices, the camera's
//                    settings, the date, the image size and type, the images
//                    trained, and the CRC-32 of each file's pixels
//   lightfield.exr   the reference light field the display shows (exr_io.h)
//   ideal.exr        the golden model's ideal image: the trained images' mean (DN)
//   spread.exr       their sample standard deviation (DN; 0 from one image),
//                    without the camera-noise floor the model adds (golden_model.h)
//   mask.exr         the part: 1 where defects are looked for, 0 elsewhere
//   panel.exr        with a capture through the bench (coded:) only: the panel
//                    image the display shows (drive levels 0 .. 1, the panel's
//                    columns and rows); lightfield.exr is then its light field
//
// Images are the camera's (row 0 at the top); EXR files carry their own
// parametrisation and checksums (docs/file-formats.md).

#include "lfi/core/atomic_file.h"
#include "lfi/core/light_field.h"
#include "lfi/inspection/golden_model.h"

#include <opencv2/core.hpp>

#include <filesystem>
#include <string>

namespace lfi {

struct BenchFile;

struct ReferenceInfo {
  std::string benchFile;    // the bench file's path when captured
  std::string benchHash;    // BenchFile::referenceHash()
  std::string created_utc;  // ISO 8601, when captured
  std::string updated_utc;  // ISO 8601, when last trained
  std::string camera;       // "<vendor> <model> <serial> (<uri>)"
  std::string display;      // the display's id and URI
  std::string capture;      // the capture's description
  double exposure_us = 0;
  double gain = 0;
  std::string pixelFormat;
  double white = 0;  // radiance at full drive level the light field was shown with
};

struct ReferencePackage {
  ReferenceInfo info;
  LightField lightField;
  cv::Mat panel;               // CV_32FC1 drive levels in [0, 1], or empty: the display shows lightField
  GoldenModelTrainer trainer;  // the golden model's statistics; trainer.count() images trained
  cv::Mat mask;                // CV_8UC1, the images' size, 255 = the part
};

// The part's mask from the ideal image: the disc of `radius_px` around
// `centre_px` (negative radius: the whole image), less the pixels darker than
// `litFraction` of the ideal image's 99th percentile there (a pixel the
// display cannot light shows no dark defect).
cv::Mat partMask(const cv::Mat& ideal, double centre_x, double centre_y, double radius_px, double litFraction);

// Writes the package; Errc::Exists when `folder` exists and `overwrite` is Refuse.
void writeReferencePackage(const std::filesystem::path& folder, const ReferencePackage& package, Overwrite overwrite);

// Reads and checks a package: every file present and valid, the images of one
// size and matching their recorded checksums, and, with a bench, the package
// taken on it (the reference hash). Errors name the folder and file:
// Errc::NotFound (no package), Errc::InvalidFile (a file missing or damaged),
// Errc::Checksum (a file from another package), and
// Errc::Config for a package from another bench (both hashes and what to do).
ReferencePackage readReferencePackage(const std::filesystem::path& folder, const BenchFile* bench);

}  // namespace lfi
