// SPDX-License-Identifier: Apache-2.0
#pragma once
// The lfi light field display's USB vendor protocol, version 1.0
// (docs/usb-display-protocol.md is the normative text; this header is its code).
// Shared by the host backend (drivers/src/usb/) and the emulated device of the tests,
// so both sides encode and check the same bytes. Every multi-byte field is
// little-endian; every length is bounded by a constant below, and the decoders
// reject anything outside those bounds with Errc::Device naming the field.

#include "lfi/drivers/display.h"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace lfi::usbdisplay {

inline constexpr std::uint16_t kProtocolMajor = 1;
inline constexpr std::uint16_t kProtocolMinor = 0;

// Default identity: pid.codes VID 0x1209 (open hardware); the PID is this project's.
inline constexpr std::uint16_t kDefaultVendorId = 0x1209;
inline constexpr std::uint16_t kDefaultProductId = 0x4c46;

inline constexpr std::uint8_t kInterfaceClass = 0xff;     // vendor specific
inline constexpr std::uint8_t kInterfaceSubclass = 0x4c;  // 'L'
inline constexpr std::uint8_t kInterfaceProtocol = 0x01;  // this protocol, major 1
inline constexpr std::uint8_t kFrameEndpoint = 0x01;      // bulk OUT

// Control requests: bmRequestType vendor | interface recipient, wIndex = interface number.
enum class Request : std::uint8_t {
  GetProtocolVersion = 0x01,  // IN, 4 bytes
  GetDeviceInfo = 0x02,       // IN, kDeviceInfoSize bytes
  GetCalibration = 0x03,      // IN, wValue = chunk index, up to kCalibrationChunk bytes
  SetBrightness = 0x04,       // OUT, wValue = level, no data
  Present = 0x05,             // OUT, wValue = low 16 bits of the frame's sequence number, no data
  Blank = 0x06,               // OUT, no data
  GetStatus = 0x07,           // IN, kStatusSize bytes
  GetLastError = 0x08,        // IN, 8 + up to kMaxErrorText bytes
};
const char* toString(Request request);

inline constexpr std::uint8_t kRequestTypeIn = 0xc1;   // device-to-host | vendor | interface
inline constexpr std::uint8_t kRequestTypeOut = 0x41;  // host-to-device | vendor | interface

inline constexpr std::size_t kDeviceInfoSize = 128;
inline constexpr std::size_t kStatusSize = 28;
inline constexpr std::size_t kCalibrationChunk = 512;
inline constexpr std::size_t kMaxCalibrationSize = 4096;
inline constexpr std::size_t kMaxErrorText = 120;
inline constexpr std::size_t kFrameHeaderSize = 32;
inline constexpr int kMaxPanelSide_px = 8192;
inline constexpr std::uint32_t kMaxPayloadSize = 8192u * 8192u * 3u;

inline constexpr std::uint32_t kFrameMagic = 0x4649464c;        // "LFIF"
inline constexpr std::uint32_t kCalibrationMagic = 0x4243464c;  // "LFCB"

enum class Format : std::uint16_t { Mono8 = 1, Rgb888 = 2 };
enum class SubpixelCode : std::uint8_t { Mono = 0, RgbStripe = 1, BgrStripe = 2 };
// The optics class in the calibration block. Version 1 blocks know codes 0 and 1 only.
enum class OpticsCode : std::uint8_t { Lenticular = 0, LineBarrier = 1, LensletArray = 2, PinholeArray = 3 };
enum class PackingCode : std::uint8_t { Square = 0, Hexagonal = 1 };

// Calibration block versions: 1 (76 bytes: the lenticular and line-barrier
// classes) and 2 (124 bytes: every class). A host reads both; a device sends
// the lowest version that holds its class.
inline constexpr std::uint16_t kCalibrationVersion1 = 1;
inline constexpr std::uint16_t kCalibrationVersion2 = 2;

// Device-side rejection reasons (GetLastError / GetStatus lastError).
enum class DeviceError : std::uint32_t {
  None = 0,
  BadMagic = 1,
  BadVersion = 2,
  BadHeaderCrc = 3,
  BadFormat = 4,
  BadSize = 5,
  PayloadCrc = 6,
  Truncated = 7,
  SequenceMismatch = 8,
  Overflow = 9,
  NoFrame = 10,
  BadRequest = 11,
};
const char* toString(DeviceError error);

struct DeviceInfoBlock {
  std::string vendor;  // each at most 31 characters on the wire
  std::string model;
  std::string serial;
  int panelWidth_px = 0;
  int panelHeight_px = 0;
  SubpixelCode subpixels = SubpixelCode::Mono;
  std::uint8_t formats = 1;  // bit 0 Mono8, bit 1 Rgb888
  int brightnessMax = 0;
  int brightness = 0;
  std::uint32_t calibrationSize = 0;
  std::uint32_t maxPayloadSize = 0;
  int viewCount = 0;
};

struct CalibrationBlock {
  std::uint16_t version = kCalibrationVersion2;  // as encoded or decoded
  double pixelPitch_mm = 0;
  OpticsCode optics = OpticsCode::Lenticular;
  // Lenticular, line barrier.
  double lensPitch_px = 0;
  double slant_rad = 0;
  double offset_px = 0;
  // Lenslet and pinhole arrays (version 2).
  PackingCode packing = PackingCode::Square;
  double arrayPitch_mm = 0;
  double rotation_rad = 0;
  double arrayOffsetX_mm = 0;
  double arrayOffsetY_mm = 0;
  double fillFactor = 0;
  double pinholeDiameter_mm = 0;
  // Every class.
  double gap_mm = 0;
  double focalLength_mm = 0;
  double slitWidth_mm = 0;
};

struct StatusBlock {
  std::uint32_t showing = 0;
  std::uint32_t presentedSequence = 0;
  std::uint32_t framesPresented = 0;
  std::uint32_t framesRejected = 0;
  std::uint16_t brightness = 0;
  std::uint32_t lastError = 0;
  std::uint32_t lastErrorSequence = 0;
};

struct FrameHeader {
  std::uint32_t sequence = 0;
  Format format = Format::Mono8;
  std::uint16_t flags = 0;
  std::uint16_t width = 0;
  std::uint16_t height = 0;
  std::uint32_t payloadSize = 0;
  std::uint32_t payloadCrc = 0;
};

std::uint32_t crc32Of(std::span<const std::uint8_t> bytes);
std::uint32_t bytesPerPixel(Format format);

std::vector<std::uint8_t> encodeDeviceInfo(const DeviceInfoBlock& info);
// `device` names the device in messages. Throws Errc::Device for a short block, an
// unknown version, or a field outside its bound.
DeviceInfoBlock decodeDeviceInfo(std::span<const std::uint8_t> bytes, const std::string& device);

// Encodes `calibration` as its `version` (Errc::InvalidArgument for a class
// version 1 cannot hold).
std::vector<std::uint8_t> encodeCalibration(const CalibrationBlock& calibration);
// Throws Errc::Device naming the device and field for a short or corrupt block,
// an unknown version or optics class, or a value out of range.
CalibrationBlock decodeCalibration(std::span<const std::uint8_t> bytes, const std::string& device);

std::vector<std::uint8_t> encodeStatus(const StatusBlock& status);
StatusBlock decodeStatus(std::span<const std::uint8_t> bytes, const std::string& device);

// The 32-byte frame header; its last field is the CRC-32 of the 28 bytes before it.
std::vector<std::uint8_t> encodeFrameHeader(const FrameHeader& header);
// Device side: returns the error a device reports for a malformed header.
DeviceError decodeFrameHeader(std::span<const std::uint8_t> bytes, FrameHeader& header);

// The calibration block's optics as the display model's parameters, and back
// (the lowest block version that holds the class).
DisplayOpticsParams toOpticsParams(const CalibrationBlock& calibration);
CalibrationBlock toCalibrationBlock(double pixelPitch_mm, const DisplayOpticsParams& optics);

// GetLastError reply: u32 code, u32 sequence, then the message (no NUL), at most kMaxErrorText bytes.
std::vector<std::uint8_t> encodeLastError(DeviceError code, std::uint32_t sequence, const std::string& message);
// The reply as the host reads it: a code the protocol does not name stays as
// it is (toString says so), the message's bytes outside printable ASCII are
// '?' and the message ends at kMaxErrorText bytes. Throws Errc::Device naming
// the device for a reply shorter than 8 bytes.
struct LastError {
  DeviceError code = DeviceError::None;
  std::uint32_t sequence = 0;
  std::string message;
};
LastError decodeLastError(std::span<const std::uint8_t> bytes, const std::string& device);

// Little-endian helpers.
void putU16(std::vector<std::uint8_t>& out, std::uint16_t v);
void putU32(std::vector<std::uint8_t>& out, std::uint32_t v);
void putF64(std::vector<std::uint8_t>& out, double v);
std::uint16_t getU16(const std::uint8_t* p);
std::uint32_t getU32(const std::uint8_t* p);
double getF64(const std::uint8_t* p);

}  // namespace lfi::usbdisplay
