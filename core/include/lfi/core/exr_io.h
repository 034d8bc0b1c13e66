// SPDX-License-Identifier: Apache-2.0
#pragma once
// OpenEXR files for light fields and HDR (linear radiance) images, written with
// the OpenEXR library so that the parametrisation travels in the header as
// typed attributes. One FLOAT channel "Y", ZIP compression (lossless, so a
// round trip is bit-exact). docs/file-formats.md lists every attribute.
//
// Loading validates everything and throws lfi::Error naming the file and the
// attribute: Errc::InvalidFile for a missing/mistyped/out-of-range attribute,
// a size that does not match, NaN/Inf pixels or a truncated file;
// Errc::Checksum when the lfi attributes or the pixels do not match the
// recorded CRC-32 (version 1 files, read still, recorded it of the pixels only).

#include "lfi/core/atomic_file.h"
#include "lfi/core/light_field.h"

#include <opencv2/core.hpp>

#include <filesystem>
#include <map>
#include <string>
#include <string_view>

namespace lfi {

inline constexpr int kExrFormatVersion = 2;

// The largest image an lfi EXR file holds, a side and in all (a 60 MB file
// could otherwise ask for 64 GiB). Images made to be written (renders) keep
// to it too, so that the work is refused before it is done.
inline constexpr long kMaxExrSide = 1L << 17, kMaxExrPixels = 1L << 30;

void writeLightFieldExr(const std::filesystem::path& path, const LightField& lightField,
                        Overwrite overwrite = Overwrite::Refuse);
LightField readLightFieldExr(const std::filesystem::path& path);

// Metadata of a radiance image. objectPixel_mm is the pixel size projected into
// object space (0 = unknown); description is free text shown by tools.
// RadianceImageInfo::pixelUnit of a camera frame.
inline constexpr const char* kCameraDigitalNumbers = "camera digital numbers (DN)";

struct RadianceImageInfo {
  double objectPixel_mm = 0;
  std::string description;
  std::string pixelUnit = "linear relative radiance";  // lfi.units: "lengths mm, angles rad, pixels <pixelUnit>"
  // How the image was taken (a camera's frame: its device and settings), as
  // string attributes lfi.settings.<key>; keys of a-z, 0-9 and '_'.
  std::map<std::string, std::string> settings;
};

void writeRadianceExr(const std::filesystem::path& path, const cv::Mat& image, const RadianceImageInfo& info,
                      Overwrite overwrite = Overwrite::Refuse);
cv::Mat readRadianceExr(const std::filesystem::path& path, RadianceImageInfo* info = nullptr);

// CRC-32 (zlib polynomial) of an image's pixel bytes, row by row, going on
// from `crc` (0: from the start).
unsigned long pixelChecksum(const cv::Mat& image, unsigned long crc = 0);

// What lfi.checksum records (format version 2): the CRC-32 of `attributes`,
// the canonical text of the file's lfi.* attributes (docs/file-formats.md),
// followed by the pixel bytes.
unsigned long fileChecksum(std::string_view attributes, const cv::Mat& pixels);

// The threads OpenEXR compresses and decompresses a file's lines on, for the
// whole process: `threads`, or with 0 one per CPU the process may run on (its
// affinity mask, which a container's cpuset or taskset narrows), which is
// also the default. For a program's --threads; not while a file is being
// read or written. Throws Errc::InvalidArgument for a negative count.
void setExrThreads(int threads);

}  // namespace lfi
