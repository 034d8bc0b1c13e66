// SPDX-License-Identifier: Apache-2.0
// 12-bit packed wire formats against hand-packed bytes (pixel_unpack.h table).

#include "lfi/drivers/pixel_unpack.h"
#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <vector>

namespace lfi {
namespace {

using testing_support::throwsError;

// Packs pixels as the layout table in pixel_unpack.h says.
std::vector<std::uint8_t> pack(const std::vector<std::uint16_t>& pixels, Mono12Packing packing) {
  std::vector<std::uint8_t> bytes(mono12PackedSize(static_cast<int>(pixels.size()), 1), 0);
  for (std::size_t i = 0; i < pixels.size(); i += 2) {
    const std::uint16_t p0 = pixels[i];
    const std::uint16_t p1 = i + 1 < pixels.size() ? pixels[i + 1] : 0;
    std::uint8_t* t = bytes.data() + i / 2 * 3;
    if (packing == Mono12Packing::Pfnc) {
      t[0] = static_cast<std::uint8_t>(p0 & 0xff);
      t[1] = static_cast<std::uint8_t>(((p1 & 0x0f) << 4) | (p0 >> 8));
    } else {
      t[0] = static_cast<std::uint8_t>(p0 >> 4);
      t[1] = static_cast<std::uint8_t>(((p1 & 0x0f) << 4) | (p0 & 0x0f));
    }
    if (i + 1 < pixels.size()) t[2] = static_cast<std::uint8_t>(p1 >> 4);
  }
  return bytes;
}

TEST(Mono12, KnownBytes) {
  // p0 = 0xABC, p1 = 0x123.
  const std::uint8_t gev[3] = {0xAB, 0x3C, 0x12};
  const std::uint8_t pfnc[3] = {0xBC, 0x3A, 0x12};
  cv::Mat out;
  unpackMono12(gev, 3, 2, 1, Mono12Packing::GigEVisionPacked, out);
  ASSERT_EQ(out.type(), CV_16UC1);
  EXPECT_EQ(out.at<std::uint16_t>(0, 0), 0xABC);
  EXPECT_EQ(out.at<std::uint16_t>(0, 1), 0x123);
  unpackMono12(pfnc, 3, 2, 1, Mono12Packing::Pfnc, out);
  EXPECT_EQ(out.at<std::uint16_t>(0, 0), 0xABC);
  EXPECT_EQ(out.at<std::uint16_t>(0, 1), 0x123);
}

TEST(Mono12, RoundTripOddWidthPacksAcrossLines) {
  const int width = 5, height = 3;  // 15 pixels: a pixel pair straddles each line end
  std::vector<std::uint16_t> pixels;
  for (int i = 0; i < width * height; ++i) pixels.push_back(static_cast<std::uint16_t>((i * 273 + 4095) % 4096));
  for (Mono12Packing packing : {Mono12Packing::GigEVisionPacked, Mono12Packing::Pfnc}) {
    const auto bytes = pack(pixels, packing);
    ASSERT_EQ(bytes.size(), 23u);
    cv::Mat out;
    unpackMono12(bytes.data(), bytes.size(), width, height, packing, out);
    for (int i = 0; i < width * height; ++i) EXPECT_EQ(out.at<std::uint16_t>(i / width, i % width), pixels[i]) << i;
  }
}

TEST(Mono12, ReusesOutputAndRejectsShortBuffers) {
  const std::vector<std::uint8_t> bytes(6, 0xff);
  cv::Mat out(2, 2, CV_16UC1);
  const std::uint8_t* before = out.data;
  unpackMono12(bytes.data(), bytes.size(), 2, 2, Mono12Packing::Pfnc, out);
  EXPECT_EQ(out.data, before);
  EXPECT_EQ(out.at<std::uint16_t>(1, 1), 0xfff);
  EXPECT_TRUE(throwsError([&] { unpackMono12(bytes.data(), 5, 2, 2, Mono12Packing::Pfnc, out); }, Errc::InvalidArgument,
                          {"need 6 bytes", "has 5"}));
  // A view whose rows are not one sequence (columns of a larger image) is not written through.
  cv::Mat big(4, 4, CV_16UC1, cv::Scalar(7));
  cv::Mat view = big(cv::Rect(0, 0, 2, 2));
  unpackMono12(bytes.data(), bytes.size(), 2, 2, Mono12Packing::Pfnc, view);
  EXPECT_TRUE(view.isContinuous());
  EXPECT_EQ(cv::countNonZero(view != 0xfff), 0);
  EXPECT_EQ(cv::countNonZero(big != 7), 0);
}

}  // namespace
}  // namespace lfi
