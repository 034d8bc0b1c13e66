// SPDX-License-Identifier: Apache-2.0
#pragma once
// The ExrIo fixture (a fresh directory per test) and the helpers the EXR tests share:
// random and special pixels, bit-exact comparison, and EXR files written with the
// OpenEXR API directly, with the lfi attributes a test chooses and their checksum.

#include "lfi/core/exr_io.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfDoubleAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <fmt/format.h>

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <system_error>
#include <utility>

namespace lfi::exr_test {

namespace fs = std::filesystem;

// A fresh directory per test, removed with everything in it at the end.
class ExrIo : public testing::Test {
 protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    dir_ =
        fs::path(testing::TempDir()) / fmt::format("lfi-exr-{}-{}-{}", info->name(), ::getpid(), counter.fetch_add(1));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  fs::path file(const std::string& name) const { return dir_ / name; }

  fs::path dir_;
};

inline LightFieldGeometry geometry() {
  LightFieldGeometry g;
  g.spatialX = 5;
  g.spatialY = 3;
  g.angular = 4;
  g.pixelPitch_mm = 0.0375;
  g.distance_mm = 17.25;
  return g;
}

// Random finite, non-negative floats over the whole bit range (all exponents, denormals, +0).
inline cv::Mat randomFloats(int rows, int cols, unsigned seed) {
  cv::Mat m(rows, cols, CV_32FC1);
  std::mt19937 rng(seed);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      float x;
      do {
        x = std::bit_cast<float>(static_cast<std::uint32_t>(rng()) & 0x7fffffffu);  // (radiance: not negative)
      } while (!std::isfinite(x));
      m.at<float>(r, c) = x;
    }
  return m;
}

inline cv::Mat specialFloats(int rows, int cols, unsigned seed, bool negatives = true) {
  cv::Mat m = randomFloats(rows, cols, seed);
  using L = std::numeric_limits<float>;
  const float specials[] = {0.0f,      -0.0f,        L::denorm_min(), -L::denorm_min(), L::min() / 3,
                            -L::min(), L::min(),     L::max(),        L::lowest(),      1.0f,
                            -1.0f,     L::epsilon(), -123.456f,       1e-30f,           -1e30f};
  int at = 0;
  for (const float x : specials)
    if (negatives || !(x < 0)) m.at<float>(at / cols, at % cols) = x, ++at;  // (-0 is not negative)
  return m;
}

inline bool bitIdentical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int r = 0; r < a.rows; ++r)
    if (std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()) != 0) return false;
  return true;
}

inline std::string checksumText(unsigned long crc) {
  return fmt::format("crc32:{:08x}", crc);
}
inline std::string checksumText(const cv::Mat& pixels) {
  return checksumText(lfi::pixelChecksum(pixels));
}

// The canonical text of a header's lfi attributes, as docs/file-formats.md
// defines it: every lfi.* attribute but lfi.checksum, by name, one line each.
inline std::string canonicalText(const Imf::Header& header) {
  std::string text;
  for (auto it = header.begin(); it != header.end(); ++it) {
    const std::string name = it.name();
    if (!name.starts_with("lfi.") || name == "lfi.checksum") continue;
    if (const auto* i = dynamic_cast<const Imf::IntAttribute*>(&it.attribute()))
      text += fmt::format("{} int {}\n", name, i->value());
    else if (const auto* d = dynamic_cast<const Imf::DoubleAttribute*>(&it.attribute()))
      text += fmt::format("{} double {}\n", name, d->value());
    else if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
      text += fmt::format("{} string {}:{}\n", name, s->value().size(), s->value());
  }
  return text;
}

// Writes an EXR with the OpenEXR API directly: one FLOAT channel "Y" with the given
// pixels and the header as prepared by `edit` (which may add or leave out attributes).
// Unless `edit` records one, lfi.checksum is the correct version 2 checksum.
inline void writeRawExr(const fs::path& path, const cv::Mat& pixels, const std::function<void(Imf::Header&)>& edit) {
  Imf::Header header(pixels.cols, pixels.rows);
  header.compression() = Imf::ZIP_COMPRESSION;
  header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
  edit(header);
  if (!header.findTypedAttribute<Imf::StringAttribute>("lfi.checksum"))
    header.insert("lfi.checksum", Imf::StringAttribute(checksumText(lfi::fileChecksum(canonicalText(header), pixels))));
  Imf::OutputFile out(path.c_str(), header);
  Imf::FrameBuffer frame;
  frame.insert("Y", Imf::Slice(Imf::FLOAT, const_cast<char*>(pixels.ptr<char>()), sizeof(float), pixels.step));
  out.setFrameBuffer(frame);
  out.writePixels(pixels.rows);
}

// The conventions a light field file states in words (docs/file-formats.md).
inline const char* kLightFieldFrame =
    "plane frame: origin at the grid centre, +z the viewing/emitting side; pixel (col,row) = (ex*n+u, ey*n+v), row "
    "increases with +y";
inline const char* kLightFieldParametrisation =
    "lenslet image of SxxSy spatial elements of nxn angular elements; in-element position (px,py) in [-1,1]^2 sees "
    "direction normalise(-px,-py,sqrt(1-px^2-py^2)); px^2+py^2>=1 is 0";
inline const char* kLightFieldUnits = "lengths mm, angles rad, pixels linear relative radiance";

// All but `leftOut`. (Not inserted and erased: OpenEXR 3.1's Header::erase leaks the attribute.)
inline void insertConventions(Imf::Header& h, const std::string& leftOut = {}) {
  for (const auto& [name, text] : {std::pair{"lfi.frame", kLightFieldFrame},
                                   {"lfi.parametrisation", kLightFieldParametrisation},
                                   {"lfi.units", kLightFieldUnits}})
    if (name != leftOut) h.insert(name, Imf::StringAttribute(text));
}

}  // namespace lfi::exr_test
