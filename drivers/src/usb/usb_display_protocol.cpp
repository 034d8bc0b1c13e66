// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/usb/usb_display_protocol.h"

#include "lfi/core/error.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <utility>

namespace lfi::usbdisplay {
namespace {

constexpr std::uint16_t kInfoVersion = 1;
// The calibration block's f64 fields in wire order from byte 16, after a
// 16-byte header and before the CRC-32: version 1 holds the first 7 (76
// bytes), version 2 all 13 (124 bytes).
constexpr double CalibrationBlock::*kCalibrationFields[] = {
    &CalibrationBlock::pixelPitch_mm,     &CalibrationBlock::lensPitch_px,    &CalibrationBlock::slant_rad,
    &CalibrationBlock::offset_px,         &CalibrationBlock::gap_mm,          &CalibrationBlock::focalLength_mm,
    &CalibrationBlock::slitWidth_mm,      &CalibrationBlock::arrayPitch_mm,   &CalibrationBlock::rotation_rad,
    &CalibrationBlock::arrayOffsetX_mm,   &CalibrationBlock::arrayOffsetY_mm, &CalibrationBlock::fillFactor,
    &CalibrationBlock::pinholeDiameter_mm};
constexpr std::size_t fieldsOf(std::uint16_t version) {
  return version == kCalibrationVersion1 ? 7 : 13;
}
constexpr std::size_t calibrationSize(std::uint16_t version) {
  return 16 + 8 * fieldsOf(version) + 4;
}
constexpr std::size_t kCalibrationSize = calibrationSize(kCalibrationVersion1);
static_assert(kCalibrationSize == 76 && calibrationSize(kCalibrationVersion2) == 124);
constexpr std::size_t kNameField = 32;

void putName(std::vector<std::uint8_t>& out, const std::string& text) {
  std::uint8_t field[kNameField] = {};
  std::memcpy(field, text.data(), std::min(text.size(), kNameField - 1));
  out.insert(out.end(), field, field + kNameField);
}

// A NUL-padded name; printable ASCII only, so that a device cannot put control
// characters into our messages.
std::string getName(const std::uint8_t* p, const char* field, const std::string& device) {
  std::string text;
  for (std::size_t i = 0; i < kNameField && p[i] != 0; ++i) {
    if (p[i] < 0x20 || p[i] > 0x7e)
      fail(Errc::Device, "{}: device info field '{}' has a non-printable byte 0x{:02x} at {}", device, field, p[i], i);
    text.push_back(static_cast<char>(p[i]));
  }
  if (text.size() == kNameField)
    fail(Errc::Device, "{}: device info field '{}' is not NUL-terminated within {} bytes", device, field, kNameField);
  return text;
}

void requireRange(double value, double lo, double hi, const char* field, const char* unit, const std::string& device) {
  if (!std::isfinite(value) || value < lo || value > hi)
    fail(Errc::Device, "{}: calibration field '{}' = {} {} is outside {}..{} {}", device, field, value, unit, lo, hi,
         unit);
}

}  // namespace

const char* toString(Request request) {
  switch (request) {
    case Request::GetProtocolVersion:
      return "GET_PROTOCOL_VERSION";
    case Request::GetDeviceInfo:
      return "GET_DEVICE_INFO";
    case Request::GetCalibration:
      return "GET_CALIBRATION";
    case Request::SetBrightness:
      return "SET_BRIGHTNESS";
    case Request::Present:
      return "PRESENT";
    case Request::Blank:
      return "BLANK";
    case Request::GetStatus:
      return "GET_STATUS";
    case Request::GetLastError:
      return "GET_LAST_ERROR";
  }
  return "unknown request";
}

const char* toString(DeviceError error) {
  switch (error) {
    case DeviceError::None:
      return "no error";
    case DeviceError::BadMagic:
      return "bad frame magic";
    case DeviceError::BadVersion:
      return "unsupported frame header version";
    case DeviceError::BadHeaderCrc:
      return "frame header CRC mismatch";
    case DeviceError::BadFormat:
      return "unsupported pixel format";
    case DeviceError::BadSize:
      return "frame size does not match the panel";
    case DeviceError::PayloadCrc:
      return "payload CRC mismatch";
    case DeviceError::Truncated:
      return "truncated frame";
    case DeviceError::SequenceMismatch:
      return "PRESENT sequence does not match the received frame";
    case DeviceError::Overflow:
      return "more bytes than the header announced";
    case DeviceError::NoFrame:
      return "no complete frame to present";
    case DeviceError::BadRequest:
      return "malformed request";
  }
  return "unknown device error";
}

std::uint32_t crc32Of(std::span<const std::uint8_t> bytes) {
  uLong crc = crc32(0L, Z_NULL, 0);
  // zlib takes uInt lengths; feed large buffers in pieces.
  std::size_t offset = 0;
  while (offset < bytes.size()) {
    const std::size_t n = std::min<std::size_t>(bytes.size() - offset, 1u << 30);
    crc = crc32(crc, bytes.data() + offset, static_cast<uInt>(n));
    offset += n;
  }
  return static_cast<std::uint32_t>(crc);
}

std::uint32_t bytesPerPixel(Format format) {
  return format == Format::Rgb888 ? 3 : 1;
}

void putU16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
}
void putU32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void putF64(std::vector<std::uint8_t>& out, double v) {
  const auto bits = std::bit_cast<std::uint64_t>(v);
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(bits >> (8 * i)));
}
std::uint16_t getU16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t getU32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
double getF64(const std::uint8_t* p) {
  std::uint64_t bits = 0;
  for (int i = 0; i < 8; ++i) bits |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return std::bit_cast<double>(bits);
}

std::vector<std::uint8_t> encodeDeviceInfo(const DeviceInfoBlock& info) {
  std::vector<std::uint8_t> out;
  out.reserve(kDeviceInfoSize);
  putU16(out, kInfoVersion);
  putU16(out, kDeviceInfoSize);
  putName(out, info.vendor);
  putName(out, info.model);
  putName(out, info.serial);
  putU16(out, static_cast<std::uint16_t>(info.panelWidth_px));
  putU16(out, static_cast<std::uint16_t>(info.panelHeight_px));
  out.push_back(static_cast<std::uint8_t>(info.subpixels));
  out.push_back(info.formats);
  putU16(out, static_cast<std::uint16_t>(info.brightnessMax));
  putU16(out, static_cast<std::uint16_t>(info.brightness));
  putU16(out, static_cast<std::uint16_t>(info.viewCount));
  putU32(out, info.calibrationSize);
  putU32(out, info.maxPayloadSize);
  out.resize(kDeviceInfoSize, 0);
  return out;
}

DeviceInfoBlock decodeDeviceInfo(std::span<const std::uint8_t> bytes, const std::string& device) {
  if (bytes.size() < kDeviceInfoSize)
    fail(Errc::Device, "{}: GET_DEVICE_INFO returned {} bytes, expected {}", device, bytes.size(), kDeviceInfoSize);
  const std::uint8_t* p = bytes.data();
  if (getU16(p) != kInfoVersion)
    fail(Errc::Device, "{}: GET_DEVICE_INFO has version {}, this host understands {}", device, getU16(p), kInfoVersion);
  if (getU16(p + 2) != kDeviceInfoSize)
    fail(Errc::Device, "{}: GET_DEVICE_INFO declares a size of {} bytes, expected {}", device, getU16(p + 2),
         kDeviceInfoSize);
  DeviceInfoBlock info;
  info.vendor = getName(p + 4, "vendor", device);
  info.model = getName(p + 36, "model", device);
  info.serial = getName(p + 68, "serial", device);
  info.panelWidth_px = getU16(p + 100);
  info.panelHeight_px = getU16(p + 102);
  const std::uint8_t subpixels = p[104];
  info.formats = p[105];
  info.brightnessMax = getU16(p + 106);
  info.brightness = getU16(p + 108);
  info.viewCount = getU16(p + 110);
  info.calibrationSize = getU32(p + 112);
  info.maxPayloadSize = getU32(p + 116);
  if (info.panelWidth_px < 1 || info.panelWidth_px > kMaxPanelSide_px || info.panelHeight_px < 1 ||
      info.panelHeight_px > kMaxPanelSide_px)
    fail(Errc::Device, "{}: device info panel size {}x{} px is outside 1..{} px per side", device, info.panelWidth_px,
         info.panelHeight_px, kMaxPanelSide_px);
  if (subpixels > 2) fail(Errc::Device, "{}: device info subpixel layout code {} is unknown (0..2)", device, subpixels);
  info.subpixels = static_cast<SubpixelCode>(subpixels);
  if ((info.formats & 0x3) == 0 || (info.formats & ~0x3) != 0)
    fail(Errc::Device, "{}: device info format mask 0x{:02x} is invalid (bits 0..1, at least one)", device,
         info.formats);
  if (info.brightnessMax < 1 || info.brightness > info.brightnessMax)
    fail(Errc::Device, "{}: device info brightness {} of maximum {} is invalid", device, info.brightness,
         info.brightnessMax);
  if (info.viewCount < 1 || info.viewCount > 1024)
    fail(Errc::Device, "{}: device info view count {} is outside 1..1024", device, info.viewCount);
  if (info.calibrationSize < kCalibrationSize || info.calibrationSize > kMaxCalibrationSize)
    fail(Errc::Device, "{}: device info calibration size {} bytes is outside {}..{}", device, info.calibrationSize,
         kCalibrationSize, kMaxCalibrationSize);
  // The host sends the panel's own format (Mono8 to a mono panel whatever else the device takes).
  const std::uint64_t panelFrame = static_cast<std::uint64_t>(info.panelWidth_px) * info.panelHeight_px *
                                   (info.subpixels == SubpixelCode::Mono ? 1u : 3u);
  if (info.maxPayloadSize < panelFrame || info.maxPayloadSize > kMaxPayloadSize)
    fail(Errc::Device, "{}: device info maximum payload {} bytes is outside {}..{} for its panel", device,
         info.maxPayloadSize, panelFrame, kMaxPayloadSize);
  return info;
}

std::vector<std::uint8_t> encodeCalibration(const CalibrationBlock& c) {
  const bool v1 = c.version == kCalibrationVersion1;
  if (!v1 && c.version != kCalibrationVersion2)
    fail(Errc::InvalidArgument, "calibration block version {} is not 1 or 2", c.version);
  if (v1 && c.optics != OpticsCode::Lenticular && c.optics != OpticsCode::LineBarrier)
    fail(Errc::InvalidArgument, "a version 1 calibration block cannot hold optics class {}",
         static_cast<int>(c.optics));
  const std::size_t size = calibrationSize(c.version);
  std::vector<std::uint8_t> out;
  out.reserve(size);
  putU32(out, kCalibrationMagic);
  putU16(out, c.version);
  putU16(out, static_cast<std::uint16_t>(size));
  out.push_back(static_cast<std::uint8_t>(c.optics));
  if (!v1) out.push_back(static_cast<std::uint8_t>(c.packing));
  out.resize(16, 0);
  for (std::size_t i = 0; i < fieldsOf(c.version); ++i) putF64(out, c.*kCalibrationFields[i]);
  putU32(out, crc32Of(out));
  return out;
}

CalibrationBlock decodeCalibration(std::span<const std::uint8_t> bytes, const std::string& device) {
  if (bytes.size() < kCalibrationSize)
    fail(Errc::Device, "{}: calibration blob has {} bytes, expected at least {}", device, bytes.size(),
         kCalibrationSize);
  const std::uint8_t* p = bytes.data();
  if (getU32(p) != kCalibrationMagic)
    fail(Errc::Device, "{}: calibration blob has magic 0x{:08x}, expected 0x{:08x}", device, getU32(p),
         kCalibrationMagic);
  CalibrationBlock c;
  c.version = getU16(p + 4);
  if (c.version != kCalibrationVersion1 && c.version != kCalibrationVersion2)
    fail(Errc::Device, "{}: calibration blob version {} is not supported (this host reads 1 and 2)", device, c.version);
  const bool v1 = c.version == kCalibrationVersion1;
  const std::size_t expected = calibrationSize(c.version);
  const std::size_t size = getU16(p + 6);
  if (size != expected || size > bytes.size())
    fail(Errc::Device, "{}: calibration blob declares {} bytes, expected {} for version {}", device, size, expected,
         c.version);
  const std::uint32_t stored = getU32(p + size - 4);
  const std::uint32_t computed = crc32Of(bytes.first(size - 4));
  if (stored != computed)
    fail(Errc::Device, "{}: calibration blob CRC-32 is 0x{:08x}, computed 0x{:08x}", device, stored, computed);
  const int known = v1 ? 1 : 3;
  if (p[8] > known)
    fail(Errc::Device,
         "{}: calibration optics class code {} is unknown to this host (version {} blocks: 0 lenticular, "
         "1 line barrier{})",
         device, p[8], c.version, v1 ? "" : ", 2 lenslet array, 3 pinhole array");
  c.optics = static_cast<OpticsCode>(p[8]);
  if (!v1) {
    if (p[9] > 1)
      fail(Errc::Device, "{}: calibration packing code {} is unknown (0 square, 1 hexagonal)", device, p[9]);
    c.packing = static_cast<PackingCode>(p[9]);
  }
  for (std::size_t i = 0; i < fieldsOf(c.version); ++i) c.*kCalibrationFields[i] = getF64(p + 16 + 8 * i);
  requireRange(c.pixelPitch_mm, 1e-4, 10, "pixelPitch", "mm", device);
  requireRange(c.gap_mm, 1e-3, 100, "gap", "mm", device);
  switch (c.optics) {
    case OpticsCode::Lenticular:
    case OpticsCode::LineBarrier:
      requireRange(c.lensPitch_px, 1, 1000, "lensPitch", "px", device);
      requireRange(c.slant_rad, -0.785, 0.785, "slant", "rad", device);
      requireRange(c.offset_px, -1e4, 1e4, "offset", "px", device);
      break;
    case OpticsCode::LensletArray:
    case OpticsCode::PinholeArray:
      requireRange(c.arrayPitch_mm, c.pixelPitch_mm, 100, "arrayPitch", "mm", device);
      requireRange(c.rotation_rad, -0.785, 0.785, "rotation", "rad", device);
      requireRange(c.arrayOffsetX_mm, -1e4, 1e4, "arrayOffsetX", "mm", device);
      requireRange(c.arrayOffsetY_mm, -1e4, 1e4, "arrayOffsetY", "mm", device);
      break;
  }
  if (c.optics == OpticsCode::Lenticular || c.optics == OpticsCode::LensletArray)
    requireRange(c.focalLength_mm, 1e-3, 100, "focalLength", "mm", device);
  if (c.optics == OpticsCode::LineBarrier) requireRange(c.slitWidth_mm, 1e-5, 100, "slitWidth", "mm", device);
  if (c.optics == OpticsCode::LensletArray) requireRange(c.fillFactor, 1e-3, 1, "fillFactor", "", device);
  if (c.optics == OpticsCode::PinholeArray)
    requireRange(c.pinholeDiameter_mm, 1e-4, c.arrayPitch_mm, "pinholeDiameter", "mm", device);
  return c;
}

namespace {

// The optics values the calibration block and the display model share.
constexpr std::pair<double CalibrationBlock::*, double DisplayOpticsParams::*> kSharedOptics[] = {
    {&CalibrationBlock::lensPitch_px, &DisplayOpticsParams::lensPitch_px},
    {&CalibrationBlock::slant_rad, &DisplayOpticsParams::slant_rad},
    {&CalibrationBlock::offset_px, &DisplayOpticsParams::offset_px},
    {&CalibrationBlock::arrayPitch_mm, &DisplayOpticsParams::arrayPitch_mm},
    {&CalibrationBlock::rotation_rad, &DisplayOpticsParams::rotation_rad},
    {&CalibrationBlock::arrayOffsetX_mm, &DisplayOpticsParams::arrayOffsetX_mm},
    {&CalibrationBlock::arrayOffsetY_mm, &DisplayOpticsParams::arrayOffsetY_mm},
    {&CalibrationBlock::fillFactor, &DisplayOpticsParams::fillFactor},
    {&CalibrationBlock::pinholeDiameter_mm, &DisplayOpticsParams::pinholeDiameter_mm},
    {&CalibrationBlock::gap_mm, &DisplayOpticsParams::gap_mm},
    {&CalibrationBlock::focalLength_mm, &DisplayOpticsParams::focalLength_mm},
    {&CalibrationBlock::slitWidth_mm, &DisplayOpticsParams::slitWidth_mm},
};

// The wire codes are the model's enumerators in order.
static_assert(static_cast<int>(OpticsType::Lenticular) == static_cast<int>(OpticsCode::Lenticular) &&
              static_cast<int>(OpticsType::LineBarrier) == static_cast<int>(OpticsCode::LineBarrier) &&
              static_cast<int>(OpticsType::LensletArray) == static_cast<int>(OpticsCode::LensletArray) &&
              static_cast<int>(OpticsType::PinholeArray) == static_cast<int>(OpticsCode::PinholeArray));
static_assert(static_cast<int>(LensPacking::Square) == static_cast<int>(PackingCode::Square) &&
              static_cast<int>(LensPacking::Hexagonal) == static_cast<int>(PackingCode::Hexagonal));

}  // namespace

DisplayOpticsParams toOpticsParams(const CalibrationBlock& c) {
  DisplayOpticsParams o;
  o.type = static_cast<OpticsType>(c.optics);
  o.packing = static_cast<LensPacking>(c.packing);
  for (const auto& [block, model] : kSharedOptics) o.*model = c.*block;
  return o;
}

CalibrationBlock toCalibrationBlock(double pixelPitch_mm, const DisplayOpticsParams& o) {
  CalibrationBlock c;
  c.version = fullParallax(o.type) ? kCalibrationVersion2 : kCalibrationVersion1;
  c.pixelPitch_mm = pixelPitch_mm;
  c.optics = static_cast<OpticsCode>(o.type);
  c.packing = static_cast<PackingCode>(o.packing);
  for (const auto& [block, model] : kSharedOptics) c.*block = o.*model;
  return c;
}

std::vector<std::uint8_t> encodeStatus(const StatusBlock& s) {
  std::vector<std::uint8_t> out;
  out.reserve(kStatusSize);
  putU32(out, s.showing);
  putU32(out, s.presentedSequence);
  putU32(out, s.framesPresented);
  putU32(out, s.framesRejected);
  putU16(out, s.brightness);
  putU16(out, 0);
  putU32(out, s.lastError);
  putU32(out, s.lastErrorSequence);
  return out;
}

StatusBlock decodeStatus(std::span<const std::uint8_t> bytes, const std::string& device) {
  if (bytes.size() < kStatusSize)
    fail(Errc::Device, "{}: GET_STATUS returned {} bytes, expected {}", device, bytes.size(), kStatusSize);
  const std::uint8_t* p = bytes.data();
  StatusBlock s;
  s.showing = getU32(p);
  s.presentedSequence = getU32(p + 4);
  s.framesPresented = getU32(p + 8);
  s.framesRejected = getU32(p + 12);
  s.brightness = getU16(p + 16);
  s.lastError = getU32(p + 20);
  s.lastErrorSequence = getU32(p + 24);
  if (s.showing > 1) fail(Errc::Device, "{}: GET_STATUS state {} is not 0 (blank) or 1 (showing)", device, s.showing);
  return s;
}

std::vector<std::uint8_t> encodeFrameHeader(const FrameHeader& h) {
  std::vector<std::uint8_t> out;
  out.reserve(kFrameHeaderSize);
  putU32(out, kFrameMagic);
  putU16(out, kProtocolMajor);
  putU16(out, kFrameHeaderSize);
  putU32(out, h.sequence);
  putU16(out, static_cast<std::uint16_t>(h.format));
  putU16(out, h.flags);
  putU16(out, h.width);
  putU16(out, h.height);
  putU32(out, h.payloadSize);
  putU32(out, h.payloadCrc);
  putU32(out, crc32Of(out));
  return out;
}

DeviceError decodeFrameHeader(std::span<const std::uint8_t> bytes, FrameHeader& h) {
  if (bytes.size() < kFrameHeaderSize) return DeviceError::Truncated;
  const std::uint8_t* p = bytes.data();
  if (getU32(p) != kFrameMagic) return DeviceError::BadMagic;
  if (getU16(p + 4) != kProtocolMajor || getU16(p + 6) != kFrameHeaderSize) return DeviceError::BadVersion;
  if (getU32(p + 28) != crc32Of(bytes.first(28))) return DeviceError::BadHeaderCrc;
  h.sequence = getU32(p + 8);
  const std::uint16_t format = getU16(p + 12);
  if (format != 1 && format != 2) return DeviceError::BadFormat;
  h.format = static_cast<Format>(format);
  h.flags = getU16(p + 14);
  h.width = getU16(p + 16);
  h.height = getU16(p + 18);
  h.payloadSize = getU32(p + 20);
  h.payloadCrc = getU32(p + 24);
  if (h.width < 1 || h.width > kMaxPanelSide_px || h.height < 1 || h.height > kMaxPanelSide_px ||
      h.payloadSize != static_cast<std::uint32_t>(h.width) * h.height * bytesPerPixel(h.format))
    return DeviceError::BadSize;
  return DeviceError::None;
}

std::vector<std::uint8_t> encodeLastError(DeviceError code, std::uint32_t sequence, const std::string& message) {
  std::vector<std::uint8_t> out;
  putU32(out, static_cast<std::uint32_t>(code));
  putU32(out, sequence);
  out.insert(out.end(), message.begin(),
             message.begin() + static_cast<std::ptrdiff_t>(std::min(message.size(), kMaxErrorText)));
  return out;
}

LastError decodeLastError(std::span<const std::uint8_t> bytes, const std::string& device) {
  if (bytes.size() < 8)
    fail(Errc::Device, "{}: GET_LAST_ERROR returned {} bytes, expected at least 8", device, bytes.size());
  LastError out;
  out.code = static_cast<DeviceError>(getU32(bytes.data()));
  out.sequence = getU32(bytes.data() + 4);
  for (std::size_t i = 8; i < bytes.size() && i < 8 + kMaxErrorText; ++i)
    out.message.push_back(bytes[i] >= 0x20 && bytes[i] <= 0x7e ? static_cast<char>(bytes[i]) : '?');
  return out;
}

}  // namespace lfi::usbdisplay
