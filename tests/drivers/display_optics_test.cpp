// SPDX-License-Identifier: Apache-2.0
// The display optics model against analytic geometry (display_optics.h).

#include "lfi_test_support.h"
#include "toml_mutation.h"

#include "lfi/drivers/display.h"
#include "lfi/drivers/display_calibration_file.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/drivers/usb/usb_display_protocol.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace lfi {
namespace {

using testing_support::throwsError;

const LenticularOptics& lenticular(const DisplayOptics& optics) {
  return *optics.model<LenticularOptics>();
}

DisplayInfo smallLenticular(SubpixelLayout layout, double slant_rad) {
  DisplayInfo info = defaultLenticularDisplay();
  info.panelWidth_px = 96;
  info.panelHeight_px = 64;
  info.subpixels = layout;
  info.optics.slant_rad = slant_rad;
  return info;
}

TEST(DisplayOptics, DefaultsAreALenticularOfTheLookingGlassClass) {
  const DisplayInfo info = defaultLenticularDisplay();
  const DisplayOptics optics(info);
  EXPECT_NEAR(info.optics.lensPitch_px, 7.2, 0.1);                           // ~7 pixels per lens
  EXPECT_NEAR(info.optics.slant_rad * 180 / std::numbers::pi, 10.45, 0.05);  // ~10 degrees
  EXPECT_NEAR(optics.viewCone_rad() * 180 / std::numbers::pi, 40.0, 1e-9);   // 40 degree view cone
  EXPECT_NEAR(lenticular(optics).lensPitchPerp_mm(), 25.4 / 47.58427, 1e-12);
}

TEST(DisplayOptics, PixelRayPixelRoundTrip) {
  for (SubpixelLayout layout : {SubpixelLayout::Mono, SubpixelLayout::RgbStripe}) {
    for (double slant : {0.0, 0.1826, -0.3}) {
      const DisplayOptics optics(smallLenticular(layout, slant));
      const DisplayInfo& info = optics.info();
      int checked = 0;
      for (int row = 0; row < info.panelHeight_px; ++row)
        for (int col = 0; col < info.panelWidth_px; ++col)
          for (int k = 0; k < info.subpixelsPerPixel(); ++k) {
            const DisplayRay ray = optics.rayFromPixel(col, row, k);
            ASSERT_NEAR(ray.direction.length(), 1.0, 1e-12);
            ASSERT_GT(ray.direction.z, 0);
            ASSERT_EQ(ray.origin_mm.z, 0);
            const auto back = optics.pixelFromRay(ray.origin_mm, ray.direction);
            ASSERT_TRUE(back.has_value()) << col << "," << row << "," << k << " slant " << slant;
            ASSERT_EQ(*back, (PanelSample{col, row, k})) << "slant " << slant;
            ++checked;
          }
      EXPECT_EQ(checked, 96 * 64 * optics.info().subpixelsPerPixel());
    }
  }
}

TEST(DisplayOptics, RayGeometryIsTheChiefRayThroughTheLensAxis) {
  const DisplayOptics optics(smallLenticular(SubpixelLayout::Mono, 0.1826));
  const Vec2 n = lenticular(optics).lensNormal();
  const double gap = optics.info().optics.gap_mm;
  for (int col = 10; col < 20; ++col) {
    const DisplayRay ray = optics.rayFromPixel(col, 30, 0);
    const Vec2 p = optics.subpixelCentre(col, 30, 0);
    // The straight line from the pixel (at z = -gap) through the origin continues along the direction.
    const Vec3 fromPixel = Vec3(ray.origin_mm.x - p.x, ray.origin_mm.y - p.y, gap).normalized();
    testing_support::expectNear(fromPixel, ray.direction, 1e-12);
    // The origin moved only across the lens, and by at most half a lens.
    const Vec2 shift(ray.origin_mm.x - p.x, ray.origin_mm.y - p.y);
    EXPECT_NEAR(shift.x * n.y - shift.y * n.x, 0, 1e-12);
    EXPECT_LE(shift.length(), 0.5 * lenticular(optics).lensPitchPerp_mm() + 1e-12);
  }
}

TEST(DisplayOptics, SlantedLenticularSpreadsAPixelColumnOverTheViewCone) {
  // One panel column under slanted lenses: going down the rows, the column crosses
  // the lens by sin(slant) pixels per row, so its pixels take directions across the
  // whole cone; an unslanted lens would give every row the same direction.
  const DisplayInfo info = defaultLenticularDisplay();
  const DisplayOptics optics(info);
  const double halfCone = 0.5 * optics.viewCone_rad();
  const Vec2 n = lenticular(optics).lensNormal();
  double lo = 1, hi = -1;
  for (int row = 0; row < 200; ++row) {
    const Vec3 d = optics.rayFromPixel(1000, row, 1).direction;
    const double angle = std::atan2(d.x * n.x + d.y * n.y, d.z);  // in the fan plane
    EXPECT_LE(std::abs(angle), halfCone + 1e-12);
    lo = std::min(lo, angle);
    hi = std::max(hi, angle);
  }
  // Steps are sin(slant)·pitch ≈ 0.18 px across a 7.1 px lens: the column reaches within
  // one step of both cone edges.
  const double step =
      2 * halfCone * std::sin(info.optics.slant_rad) / (info.optics.lensPitch_px * std::cos(info.optics.slant_rad));
  EXPECT_LT(lo, -halfCone + 1.5 * step);
  EXPECT_GT(hi, halfCone - 1.5 * step);

  DisplayInfo straight = info;
  straight.optics.slant_rad = 0;
  const DisplayOptics unslanted(straight);
  const Vec3 first = unslanted.rayFromPixel(1000, 0, 1).direction;
  for (int row = 1; row < 200; ++row)
    testing_support::expectNear(unslanted.rayFromPixel(1000, row, 1).direction, first, 1e-12);
}

TEST(DisplayOptics, RaysOutsideTheConeOrPanelMapToNothing) {
  const DisplayOptics optics(smallLenticular(SubpixelLayout::Mono, 0.1826));
  EXPECT_FALSE(optics.pixelFromRay({0, 0, 0}, {0, 0, -1}).has_value());
  const Vec2 n = lenticular(optics).lensNormal();
  const double t = std::tan(0.5 * optics.viewCone_rad() + 0.01);
  EXPECT_FALSE(optics.pixelFromRay({0, 0, 0}, Vec3(t * n.x, t * n.y, 1).normalized()).has_value());
  EXPECT_FALSE(optics.pixelFromRay({1000, 0, 0}, {0, 0, 1}).has_value());
  EXPECT_TRUE(optics.pixelFromRay({0, 0, 0}, {0, 0, 1}).has_value());
}

TEST(DisplayOptics, EncodingADirectionOnlyLightFieldGivesTheAnalyticDirectionOfEachPixel) {
  // L(q, d) = 0.5 - 0.4 dx: linear in the disc coordinate (px = -dx), which bilinear
  // angular interpolation reproduces exactly; every element holds the same values.
  const DisplayInfo info = smallLenticular(SubpixelLayout::RgbStripe, 0.1826);
  const DisplayOptics optics(info);
  const double width = info.panelWidth_px * info.pixelPitch_mm, height = info.panelHeight_px * info.pixelPitch_mm;
  LightFieldGeometry g{.spatialX = 8, .spatialY = 6, .angular = 16, .pixelPitch_mm = 0};
  g.pixelPitch_mm = 1.2 * std::max(width / g.spatialX, height / g.spatialY) / g.angular;  // covers the panel
  LightField lf(g);
  for (int ey = 0; ey < g.spatialY; ++ey)
    for (int ex = 0; ex < g.spatialX; ++ex)
      for (int v = 0; v < g.angular; ++v)
        for (int u = 0; u < g.angular; ++u)
          lf.at(ex, ey, u, v) = static_cast<float>(0.5 + 0.4 * lf.angularCentre(u, v).x);
  const cv::Mat panel = encodeLightField(lf, optics);
  ASSERT_EQ(panel.type(), CV_8UC3);
  int maxError = 0;
  for (int row = 0; row < info.panelHeight_px; ++row)
    for (int col = 0; col < info.panelWidth_px; ++col)
      for (int k = 0; k < 3; ++k) {
        const Vec3 d = optics.rayFromPixel(col, row, k).direction;
        const long expected = std::lround(255 * (0.5 - 0.4 * d.x));
        maxError = std::max(maxError, static_cast<int>(std::abs(panel.at<cv::Vec3b>(row, col)[k] - expected)));
      }
  EXPECT_LE(maxError, 1);  // float storage of the light field: at most one rounding step
  // The panel really varies with direction: the cone spans 0.5 ± 0.4 sin(20°).
  double lo = 0, hi = 0;
  cv::minMaxLoc(panel.reshape(1), &lo, &hi);
  EXPECT_GT(hi - lo, 255 * 0.8 * std::sin(0.3));
}

TEST(DisplayOptics, EncodingIsTheInterpolatedLookupAlongEachChiefRay) {
  // encodeLightField takes each subpixel's ray straight to the light field's
  // coordinates; it must give what rayFromPixel and LightField::radiance give,
  // here for a light field that varies in position and angle at random (values
  // past white and below 0 included, to be clamped), on a panel wider than it.
  for (const SubpixelLayout layout : {SubpixelLayout::RgbStripe, SubpixelLayout::Mono}) {
    const DisplayInfo info = smallLenticular(layout, 0.1826);
    const DisplayOptics optics(info);
    const int sub = info.subpixelsPerPixel();
    LightFieldGeometry g{.spatialX = 5, .spatialY = 4, .angular = 8, .pixelPitch_mm = 0.12};
    LightField lf(g);
    cv::RNG rng(7);
    rng.fill(lf.lensletImage(), cv::RNG::UNIFORM, -0.1, 1.1);
    const double white = 0.9;
    const cv::Mat panel = encodeLightField(lf, optics, white);
    int differing = 0, maxError = 0, dark = 0;
    for (int row = 0; row < info.panelHeight_px; ++row)
      for (int col = 0; col < info.panelWidth_px; ++col)
        for (int k = 0; k < sub; ++k) {
          const DisplayRay ray = optics.rayFromPixel(col, row, k);
          const double r =
              lf.radiance({ray.origin_mm.x, ray.origin_mm.y}, ray.direction, LightFieldLookup::Interpolated);
          const long expected = std::clamp(std::lround(255 * r / white), 0L, 255L);
          const int got = panel.ptr<std::uint8_t>(row)[col * sub + k];
          differing += got != expected;
          maxError = std::max(maxError, static_cast<int>(std::abs(got - expected)));
          dark += r == 0;  // off the light field's plane
        }
    const int subpixels = info.panelWidth_px * info.panelHeight_px * sub;
    EXPECT_LE(maxError, 1) << toString(layout);  // a level, where rounding meets a half-way value
    EXPECT_LE(differing, subpixels / 1000) << toString(layout);
    EXPECT_GT(dark, 0) << toString(layout);  // the panel reaches past the light field
    EXPECT_LT(dark, subpixels / 2) << toString(layout);
  }
}

TEST(DisplayOptics, InvalidParametersNameTheField) {
  DisplayInfo info = defaultLenticularDisplay();
  info.optics.gap_mm = 0;
  EXPECT_TRUE(throwsError([&] { DisplayOptics optics(info); }, Errc::InvalidArgument, {"gap_mm"}));
  info = defaultLenticularDisplay();
  info.optics.type = OpticsType::LineBarrier;
  EXPECT_TRUE(throwsError([&] { DisplayOptics optics(info); }, Errc::InvalidArgument, {"slitWidth_mm"}));
  info.optics.slitWidth_mm = 0.05;
  EXPECT_NO_THROW(DisplayOptics optics(info));
}

// A valid device info block of a 640 x 400 panel, its maximum payload one frame.
usbdisplay::DeviceInfoBlock panelInfo(usbdisplay::SubpixelCode subpixels, std::uint8_t formats) {
  usbdisplay::DeviceInfoBlock info;
  info.vendor = "lfi", info.model = "panel", info.serial = "P1";
  info.panelWidth_px = 640, info.panelHeight_px = 400;
  info.subpixels = subpixels;
  info.formats = formats;
  info.brightnessMax = 255, info.brightness = 128, info.viewCount = 8;
  info.calibrationSize = 76;
  info.maxPayloadSize = 640 * 400 * (subpixels == usbdisplay::SubpixelCode::Mono ? 1 : 3);
  return info;
}

// The device's maximum payload must hold the panel's own frame: a mono panel
// that also takes RGB888 needs only width x height bytes.
TEST(UsbDisplayProtocol, TheMaximumPayloadIsCheckedAgainstThePanelsOwnFrame) {
  usbdisplay::DeviceInfoBlock info = panelInfo(usbdisplay::SubpixelCode::Mono, 0x3);
  EXPECT_EQ(usbdisplay::decodeDeviceInfo(usbdisplay::encodeDeviceInfo(info), "dev").maxPayloadSize, 640u * 400u);
  info.maxPayloadSize = 640 * 400 - 1;
  EXPECT_TRUE(throwsError([&] { usbdisplay::decodeDeviceInfo(usbdisplay::encodeDeviceInfo(info), "dev"); },
                          Errc::Device, {"dev", "maximum payload", "256000"}));
  info.subpixels = usbdisplay::SubpixelCode::RgbStripe;
  info.maxPayloadSize = 640 * 400;
  EXPECT_TRUE(throwsError([&] { usbdisplay::decodeDeviceInfo(usbdisplay::encodeDeviceInfo(info), "dev"); },
                          Errc::Device, {"768000"}));
}

// A device that answers nonsense: every field the decoders check, broken in
// turn in a valid reply (docs/usb-display-protocol.md's offsets, little-endian),
// is an Errc::Device naming the device and the field.
TEST(UsbDisplayProtocol, RepliesThatAreNonsenseNameTheFieldAndTheDevice) {
  const std::vector<std::uint8_t> goodInfo =
      usbdisplay::encodeDeviceInfo(panelInfo(usbdisplay::SubpixelCode::RgbStripe, 0x2));
  ASSERT_NO_THROW(usbdisplay::decodeDeviceInfo(goodInfo, "dev"));
  using Edit = std::function<void(std::vector<std::uint8_t>&)>;
  auto put16 = [](std::size_t at, unsigned v) -> Edit {
    return [=](std::vector<std::uint8_t>& b) { b[at] = v & 0xff, b[at + 1] = (v >> 8) & 0xff; };
  };
  auto put8 = [](std::size_t at, unsigned v) -> Edit {
    return [=](std::vector<std::uint8_t>& b) { b[at] = v & 0xff; };
  };
  auto put32 = [](std::size_t at, std::uint32_t v) -> Edit {
    return [=](std::vector<std::uint8_t>& b) {
      for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
    };
  };
  const std::vector<std::pair<Edit, std::string>> infoCases = {
      {[](auto& b) { b.resize(100); }, "GET_DEVICE_INFO returned 100 bytes"},
      {put16(0, 9), "GET_DEVICE_INFO has version 9"},
      {put16(2, 64), "declares a size of 64 bytes"},
      {put8(4, 0x07), "field 'vendor' has a non-printable byte 0x07"},
      {[](auto& b) { std::fill(b.begin() + 36, b.begin() + 68, 'x'); }, "'model' is not NUL-terminated"},
      {put16(100, 0), "panel size 0x400 px"},
      {put16(102, 9000), "panel size 640x9000 px"},
      {put8(104, 3), "subpixel layout code 3"},
      {put8(105, 0), "format mask 0x00"},
      {put8(105, 0x6), "format mask 0x06"},
      {put16(108, 300), "brightness 300 of maximum 255"},
      {put16(110, 0), "view count 0"},
      {put32(112, 12), "calibration size 12 bytes"},
      {put32(112, 0xffffffff), "calibration size 4294967295 bytes"},
      {put32(116, 1000), "maximum payload 1000 bytes"},
  };
  // Each case's edit of `good`, decoded, is refused naming the device and the case's message.
  auto expectRefused = [](const std::vector<std::uint8_t>& good, const std::vector<std::pair<Edit, std::string>>& cases,
                          const std::function<void(const std::vector<std::uint8_t>&)>& decode) {
    for (const auto& [edit, message] : cases) {
      std::vector<std::uint8_t> bytes = good;
      edit(bytes);
      EXPECT_TRUE(throwsError([&] { decode(bytes); }, Errc::Device, {"usb:1209:4c46", message})) << message;
    }
  };
  expectRefused(goodInfo, infoCases, [](const auto& b) { usbdisplay::decodeDeviceInfo(b, "usb:1209:4c46"); });

  usbdisplay::CalibrationBlock calibration;
  calibration.pixelPitch_mm = 0.05, calibration.lensPitch_px = 8, calibration.gap_mm = 1;
  calibration.focalLength_mm = 1;
  const std::vector<std::uint8_t> goodCalibration = usbdisplay::encodeCalibration(calibration);
  ASSERT_NO_THROW(usbdisplay::decodeCalibration(goodCalibration, "dev"));
  auto sealed = [](Edit edit) -> Edit {  // the edit, then a CRC-32 that matches: the field check itself is reached
    return [edit](std::vector<std::uint8_t>& b) {
      edit(b);
      const std::uint32_t crc = usbdisplay::crc32Of(std::span(b).first(b.size() - 4));
      for (int i = 0; i < 4; ++i) b[b.size() - 4 + i] = static_cast<std::uint8_t>(crc >> (8 * i));
    };
  };
  auto putF64 = [](std::size_t at, double v) -> Edit {
    return [=](std::vector<std::uint8_t>& b) { std::memcpy(b.data() + at, &v, sizeof v); };
  };
  const std::vector<std::pair<Edit, std::string>> calibrationCases = {
      {[](auto& b) { b.resize(40); }, "calibration blob has 40 bytes"},
      {put8(0, 0), "calibration blob has magic"},
      {put16(4, 7), "calibration blob version 7"},
      {put16(6, 80), "calibration blob declares 80 bytes"},
      {put8(20, 0x55), "calibration blob CRC-32"},
      {sealed(put8(8, 4)), "optics class code 4"},
      {sealed(putF64(16, std::numeric_limits<double>::quiet_NaN())), "pixelPitch"},
      {sealed(putF64(24, 0.5)), "lensPitch"},
      {sealed(putF64(32, 1.0)), "slant"},
      {sealed(putF64(48, 0)), "gap"},
      {sealed(putF64(56, std::numeric_limits<double>::infinity())), "focalLength"},
  };
  expectRefused(goodCalibration, calibrationCases,
                [](const auto& b) { usbdisplay::decodeCalibration(b, "usb:1209:4c46"); });

  std::vector<std::uint8_t> status = usbdisplay::encodeStatus({});
  ASSERT_NO_THROW(usbdisplay::decodeStatus(status, "dev"));
  status[0] = 2;
  EXPECT_TRUE(throwsError([&] { usbdisplay::decodeStatus(status, "usb:1209:4c46"); }, Errc::Device,
                          {"usb:1209:4c46", "GET_STATUS state 2"}));
  status.resize(20);
  EXPECT_TRUE(throwsError([&] { usbdisplay::decodeStatus(status, "usb:1209:4c46"); }, Errc::Device,
                          {"usb:1209:4c46", "GET_STATUS returned 20 bytes"}));

  // GET_LAST_ERROR: the code and frame as sent, the message shown in printable ASCII and held to its bound.
  std::vector<std::uint8_t> last =
      usbdisplay::encodeLastError(usbdisplay::DeviceError::PayloadCrc, 0x12345, "payload CRC mismatch");
  last.push_back(0x07);
  last.insert(last.end(), usbdisplay::kMaxErrorText, 'x');
  const usbdisplay::LastError decoded = usbdisplay::decodeLastError(last, "dev");
  EXPECT_EQ(decoded.code, usbdisplay::DeviceError::PayloadCrc);
  EXPECT_EQ(decoded.sequence, 0x12345u);
  EXPECT_EQ(decoded.message.size(), usbdisplay::kMaxErrorText);
  EXPECT_TRUE(decoded.message.starts_with("payload CRC mismatch?x"));
  last.resize(7);
  EXPECT_TRUE(throwsError([&] { usbdisplay::decodeLastError(last, "usb:1209:4c46"); }, Errc::Device,
                          {"usb:1209:4c46", "GET_LAST_ERROR returned 7 bytes"}));
}

// A frame header as docs/usb-display-protocol.md lays it out, byte by byte
// (little-endian; the header CRC-32 of bytes 0..27 as zlib computes it,
// 0x137eda8b, from Python's zlib), against the codec: the emulated device
// decodes with the same codec, so a layout error shared by both would pass
// every transfer test but not this one.
TEST(UsbDisplayProtocol, AFrameHeaderIsTheDocumentedBytes) {
  usbdisplay::FrameHeader header;
  header.sequence = 0x01020304;
  header.format = usbdisplay::Format::Rgb888;
  header.width = 640, header.height = 400;
  header.payloadSize = 640 * 400 * 3;
  header.payloadCrc = 0xdeadbeef;
  const std::vector<std::uint8_t> expected = {
      0x4c, 0x46, 0x49, 0x46,  // magic "LFIF"
      0x01, 0x00, 0x20, 0x00,  // protocol major 1, header size 32
      0x04, 0x03, 0x02, 0x01,  // sequence
      0x02, 0x00, 0x00, 0x00,  // format RGB888, flags
      0x80, 0x02, 0x90, 0x01,  // 640 x 400
      0x00, 0xb8, 0x0b, 0x00,  // payload 768000 bytes
      0xef, 0xbe, 0xad, 0xde,  // payload CRC
      0x8b, 0xda, 0x7e, 0x13,  // header CRC
  };
  EXPECT_EQ(usbdisplay::encodeFrameHeader(header), expected);
  EXPECT_EQ(usbdisplay::crc32Of(std::span(expected).first(28)), 0x137eda8bu);
  usbdisplay::FrameHeader decoded;
  EXPECT_EQ(usbdisplay::decodeFrameHeader(expected, decoded), usbdisplay::DeviceError::None);
  EXPECT_EQ(decoded.sequence, header.sequence);
  EXPECT_EQ(decoded.payloadSize, header.payloadSize);
  // The standard check value of CRC-32: "123456789" -> 0xcbf43926.
  const std::string check = "123456789";
  EXPECT_EQ(usbdisplay::crc32Of({reinterpret_cast<const std::uint8_t*>(check.data()), check.size()}), 0xcbf43926u);
}

// The device info block at the documented offsets (docs/usb-display-protocol.md).
TEST(UsbDisplayProtocol, ADeviceInfoBlockIsTheDocumentedBytes) {
  usbdisplay::DeviceInfoBlock info;
  info.vendor = "Vend", info.model = "Model X", info.serial = "S/1";
  info.panelWidth_px = 0x0a00, info.panelHeight_px = 0x0600;  // 2560 x 1536
  info.subpixels = usbdisplay::SubpixelCode::BgrStripe;
  info.formats = 0x3;
  info.brightnessMax = 0x0102, info.brightness = 0x0101, info.viewCount = 45;
  info.calibrationSize = 76;
  info.maxPayloadSize = 2560 * 1536 * 3;
  const std::vector<std::uint8_t> b = usbdisplay::encodeDeviceInfo(info);
  ASSERT_EQ(b.size(), 128u);
  auto u16 = [&](size_t at) { return b[at] | b[at + 1] << 8; };
  auto u32 = [&](size_t at) {
    return static_cast<std::uint32_t>(u16(at)) | static_cast<std::uint32_t>(u16(at + 2)) << 16;
  };
  auto text = [&](size_t at) { return std::string(reinterpret_cast<const char*>(&b[at])); };  // NUL-terminated
  EXPECT_EQ(u16(0), 1);                                                                       // info version
  EXPECT_EQ(u16(2), 128);                                                                     // block size
  EXPECT_EQ(text(4), "Vend");
  EXPECT_EQ(text(36), "Model X");
  EXPECT_EQ(text(68), "S/1");
  EXPECT_EQ(u16(100), 2560);
  EXPECT_EQ(u16(102), 1536);
  EXPECT_EQ(b[104], 2);  // BGR stripe
  EXPECT_EQ(b[105], 3);  // Mono8 and RGB888
  EXPECT_EQ(u16(106), 0x0102);
  EXPECT_EQ(u16(108), 0x0101);
  EXPECT_EQ(u16(110), 45);
  EXPECT_EQ(u32(112), 76u);
  EXPECT_EQ(u32(116), 2560u * 1536u * 3u);
  for (size_t at = 120; at < 128; ++at) EXPECT_EQ(b[at], 0) << "reserved byte " << at;
}

TEST(DisplayCalibrationFile, ValuesTheDisplayWouldRefuseAreNamedInTheFile) {
  // A calibration file overrides what the device reports; a value that
  // DisplayInfo::validate() refuses is named in the file, not blamed on the device.
  const auto file = std::filesystem::path(::testing::TempDir()) / fmt::format("lfi-cal-{}.toml", ::getpid());
  const DisplayOpticsParams device = defaultLenticularDisplay().optics;  // no slit width: a lenslet display
  auto read = [&](const std::string& optics) {
    std::ofstream(file) << "format = \"lfi-display-calibration\"\nversion = 1\n[optics]\n" << optics;
    return readDisplayOpticsFile(file, device);
  };
  EXPECT_DOUBLE_EQ(read("lens_pitch_px = 12.5\n").lensPitch_px, 12.5);
  struct Case {
    std::string optics, key, field;           // field: what DisplayInfo::validate names
    std::function<void(DisplayInfo&)> spoil;  // the same value, set on the display's info
  };
  const std::vector<Case> cases = {
      {"lens_pitch_px = 0.5\n", "optics.lens_pitch_px", "lensPitch_px",
       [](DisplayInfo& i) { i.optics.lensPitch_px = 0.5; }},
      {"slant_rad = 0.8\n", "optics.slant_rad", "slant_rad", [](DisplayInfo& i) { i.optics.slant_rad = 0.8; }},
      {"optics = \"line_barrier\"\n", "optics.slit_width_mm", "slitWidth_mm",
       [](DisplayInfo& i) { i.optics.type = OpticsType::LineBarrier; }},
      {"gap_mm = 0.0005\n", "optics.gap_mm", "gap_mm", [](DisplayInfo& i) { i.optics.gap_mm = 0.0005; }},
  };
  for (const Case& c : cases) {
    EXPECT_TRUE(throwsError([&] { read(c.optics); }, Errc::Config, {file.string() + ":", c.key})) << c.optics;
    DisplayInfo info = defaultLenticularDisplay();
    c.spoil(info);
    // The display's own check refuses the same value, naming the field: the file keeps to the display's bounds.
    EXPECT_TRUE(throwsError([&] { info.validate(); }, Errc::InvalidArgument, {"display info " + c.field})) << c.optics;
  }
  EXPECT_EQ(read("optics = \"line_barrier\"\nslit_width_mm = 0.05\n").type, OpticsType::LineBarrier);
  std::filesystem::remove(file);
}

TEST(DisplayCalibrationFile, MutatedValuesGiveOpticsTheDisplayTakesOrAreNamedErrors) {
  // Seeded value edits of a whole calibration file (toml_mutation.h). Each
  // either reads as optics the display's own check accepts, and whose rays
  // are finite, or is an lfi::Error naming the file; never a crash.
  const auto file = std::filesystem::path(::testing::TempDir()) / fmt::format("lfi-cal-mut-{}.toml", ::getpid());
  const DisplayInfo device = defaultLenticularDisplay();
  const std::string seed =
      "format = \"lfi-display-calibration\"\nversion = 1\n[optics]\noptics = \"lenticular\"\nlens_pitch_px = 7.22\n"
      "slant_rad = 0.1826\noffset_px = 0.30\ngap_mm = 0.7333\nfocal_length_mm = 0.7333\n";
  std::mt19937 rng(20261123);
  int read = 0, refused = 0;
  for (int n = 0; n < 1000; ++n) {
    std::string what;
    const std::string text = testing_support::mutateTomlValues(seed, rng, 2, what);
    SCOPED_TRACE(fmt::format("case {}: {}", n, what));
    std::ofstream(file) << text;
    try {
      DisplayInfo info = device;
      info.optics = readDisplayOpticsFile(file, device.optics);
      info.validate();
      const DisplayOptics optics(info);
      for (const auto& [col, row] : {std::pair{0, 0}, {info.panelWidth_px / 2, info.panelHeight_px / 2}}) {
        const DisplayRay ray = optics.rayFromPixel(col, row);
        ASSERT_TRUE(std::isfinite(ray.origin_mm.x + ray.origin_mm.y + ray.origin_mm.z)) << col << ", " << row;
        ASSERT_TRUE(std::isfinite(ray.direction.x + ray.direction.y + ray.direction.z)) << col << ", " << row;
      }
      ++read;
    } catch (const Error& e) {
      ASSERT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
      ++refused;
    }
  }
  EXPECT_GT(read, 100);
  EXPECT_GT(refused, 300);
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace lfi
