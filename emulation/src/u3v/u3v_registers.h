// SPDX-License-Identifier: Apache-2.0
#pragma once
// The register map of the emulated USB3 Vision camera: the GenCP memory space
// (little-endian) that its control endpoint's READMEM and WRITEMEM commands
// read and write. The bootstrap registers (ABRM at 0, then the SBRM and SIRM
// that ABRM and SBRM point at, and the manifest table) follow the USB3 Vision
// standard; the camera's own registers, from kCameraRegisters on, are what
// kGenicamXml (u3v_genicam_xml.cpp) maps its features onto. Every address
// below is absolute. Camera registers are 4-byte unsigned integers unless
// said: "float" is an IEEE 754 binary32, "command" executes on a write of 1.
// The value ranges and enumeration values here are the XML's: change both.

#include <cstdint>
#include <string_view>

namespace lfi::emulation::u3v {

// Technology agnostic bootstrap register map (ABRM).
inline constexpr std::uint64_t kAbrm = 0x0000;
inline constexpr std::uint64_t kAbrmGencpVersion = kAbrm + 0x0000;              // u32
inline constexpr std::uint64_t kAbrmManufacturerName = kAbrm + 0x0004;          // char[64]
inline constexpr std::uint64_t kAbrmModelName = kAbrm + 0x0044;                 // char[64]
inline constexpr std::uint64_t kAbrmFamilyName = kAbrm + 0x0084;                // char[64]
inline constexpr std::uint64_t kAbrmDeviceVersion = kAbrm + 0x00C4;             // char[64]
inline constexpr std::uint64_t kAbrmManufacturerInfo = kAbrm + 0x0104;          // char[64]
inline constexpr std::uint64_t kAbrmSerialNumber = kAbrm + 0x0144;              // char[64]
inline constexpr std::uint64_t kAbrmUserDefinedName = kAbrm + 0x0184;           // char[64]
inline constexpr std::uint64_t kAbrmDeviceCapability = kAbrm + 0x01C4;          // u64
inline constexpr std::uint64_t kAbrmMaxDeviceResponseTime = kAbrm + 0x01CC;     // u32, ms
inline constexpr std::uint64_t kAbrmManifestTableAddress = kAbrm + 0x01D0;      // u64
inline constexpr std::uint64_t kAbrmSbrmAddress = kAbrm + 0x01D8;               // u64
inline constexpr std::uint64_t kAbrmDeviceConfiguration = kAbrm + 0x01E0;       // u64
inline constexpr std::uint64_t kAbrmHeartbeatTimeout = kAbrm + 0x01E8;          // u32
inline constexpr std::uint64_t kAbrmMessageChannelId = kAbrm + 0x01EC;          // u32
inline constexpr std::uint64_t kAbrmTimestamp = kAbrm + 0x01F0;                 // u64
inline constexpr std::uint64_t kAbrmTimestampLatch = kAbrm + 0x01F8;            // u32
inline constexpr std::uint64_t kAbrmTimestampIncrement = kAbrm + 0x01FC;        // u64
inline constexpr std::uint64_t kAbrmAccessPrivilege = kAbrm + 0x0204;           // u32
inline constexpr std::uint64_t kAbrmProtocolEndianness = kAbrm + 0x0208;        // u32
inline constexpr std::uint64_t kAbrmImplementationEndianness = kAbrm + 0x020C;  // u32
inline constexpr std::uint32_t kAbrmStringLength = 64;

// Technology specific bootstrap register map (SBRM).
inline constexpr std::uint64_t kSbrm = 0x10000;
inline constexpr std::uint64_t kSbrmU3vVersion = kSbrm + 0x00;          // u32
inline constexpr std::uint64_t kSbrmU3vcpCapability = kSbrm + 0x04;     // u64
inline constexpr std::uint64_t kSbrmU3vcpConfiguration = kSbrm + 0x0C;  // u64
inline constexpr std::uint64_t kSbrmMaxCmdTransfer = kSbrm + 0x14;      // u32
inline constexpr std::uint64_t kSbrmMaxAckTransfer = kSbrm + 0x18;      // u32
inline constexpr std::uint64_t kSbrmNumStreamChannels = kSbrm + 0x1C;   // u32
inline constexpr std::uint64_t kSbrmSirmAddress = kSbrm + 0x20;         // u64
inline constexpr std::uint64_t kSbrmSirmLength = kSbrm + 0x28;          // u32
inline constexpr std::uint64_t kSbrmEirmAddress = kSbrm + 0x2C;         // u64
inline constexpr std::uint64_t kSbrmEirmLength = kSbrm + 0x34;          // u32
inline constexpr std::uint64_t kSbrmIidc2Address = kSbrm + 0x38;        // u64
inline constexpr std::uint64_t kSbrmCurrentSpeed = kSbrm + 0x40;        // u32

// Streaming interface register map (SIRM) of the one stream channel.
inline constexpr std::uint64_t kSirm = 0x20000;
inline constexpr std::uint64_t kSirmInfo = kSirm + 0x00;                       // u32
inline constexpr std::uint64_t kSirmControl = kSirm + 0x04;                    // u32
inline constexpr std::uint64_t kSirmRequiredPayloadSize = kSirm + 0x08;        // u64
inline constexpr std::uint64_t kSirmRequiredLeaderSize = kSirm + 0x10;         // u32
inline constexpr std::uint64_t kSirmRequiredTrailerSize = kSirm + 0x14;        // u32
inline constexpr std::uint64_t kSirmMaximumLeaderSize = kSirm + 0x18;          // u32
inline constexpr std::uint64_t kSirmPayloadTransferSize = kSirm + 0x1C;        // u32
inline constexpr std::uint64_t kSirmPayloadTransferCount = kSirm + 0x20;       // u32
inline constexpr std::uint64_t kSirmPayloadFinalTransfer1Size = kSirm + 0x24;  // u32
inline constexpr std::uint64_t kSirmPayloadFinalTransfer2Size = kSirm + 0x28;  // u32
inline constexpr std::uint64_t kSirmMaximumTrailerSize = kSirm + 0x2C;         // u32

// Manifest table: a u64 entry count, then 64-byte entries. The XML file
// (kGenicamXml) is served from kGenicamXmlAddress.
inline constexpr std::uint64_t kManifestTable = 0x30000;
inline constexpr std::uint32_t kManifestEntrySize = 64;
inline constexpr std::uint64_t kGenicamXmlAddress = 0x40000;

// The camera's registers, which kGenicamXml describes.
inline constexpr std::uint64_t kCameraRegisters = 0x100000;
inline constexpr std::uint64_t kRegWidth = kCameraRegisters + 0x00;
inline constexpr std::uint64_t kRegHeight = kCameraRegisters + 0x04;
inline constexpr std::uint64_t kRegOffsetX = kCameraRegisters + 0x08;
inline constexpr std::uint64_t kRegOffsetY = kCameraRegisters + 0x0C;
inline constexpr std::uint64_t kRegPixelFormat = kCameraRegisters + 0x10;  // a PFNC code (kPfnc*)
inline constexpr std::uint64_t kRegBinningHorizontal = kCameraRegisters + 0x14;
inline constexpr std::uint64_t kRegBinningVertical = kCameraRegisters + 0x18;
inline constexpr std::uint64_t kRegSensorWidth = kCameraRegisters + 0x1C;   // RO
inline constexpr std::uint64_t kRegSensorHeight = kCameraRegisters + 0x20;  // RO
inline constexpr std::uint64_t kRegWidthMax = kCameraRegisters + 0x24;      // RO
inline constexpr std::uint64_t kRegHeightMax = kCameraRegisters + 0x28;     // RO
inline constexpr std::uint64_t kRegPayloadSize = kCameraRegisters + 0x2C;   // RO, bytes
inline constexpr std::uint64_t kRegAcquisitionMode = kCameraRegisters + 0x30;
inline constexpr std::uint64_t kRegAcquisitionStart = kCameraRegisters + 0x34;  // command
inline constexpr std::uint64_t kRegAcquisitionStop = kCameraRegisters + 0x38;   // command
inline constexpr std::uint64_t kRegTriggerSelector = kCameraRegisters + 0x3C;
inline constexpr std::uint64_t kRegTriggerMode = kCameraRegisters + 0x40;
inline constexpr std::uint64_t kRegTriggerSource = kCameraRegisters + 0x44;
inline constexpr std::uint64_t kRegTriggerSoftware = kCameraRegisters + 0x48;       // command
inline constexpr std::uint64_t kRegExposureTime = kCameraRegisters + 0x4C;          // float, us
inline constexpr std::uint64_t kRegGain = kCameraRegisters + 0x50;                  // float, dB
inline constexpr std::uint64_t kRegAcquisitionFrameRate = kCameraRegisters + 0x54;  // float, Hz
inline constexpr std::uint64_t kRegAcquisitionFrameCount = kCameraRegisters + 0x58;
inline constexpr std::uint64_t kRegLineSelector = kCameraRegisters + 0x60;
inline constexpr std::uint64_t kRegLineMode = kCameraRegisters + 0x64;
inline constexpr std::uint64_t kRegLineSource = kCameraRegisters + 0x68;
inline constexpr std::uint64_t kRegUserOutputSelector = kCameraRegisters + 0x6C;
inline constexpr std::uint64_t kRegUserOutputValue = kCameraRegisters + 0x70;            // 0 or 1
inline constexpr std::uint64_t kRegDeviceLinkThroughputLimit = kCameraRegisters + 0x74;  // bytes/s
inline constexpr std::uint64_t kRegDeviceReset = kCameraRegisters + 0x78;                // command
inline constexpr std::uint64_t kCameraRegistersEnd = kCameraRegisters + 0x7C;
inline constexpr std::uint32_t kCommandExecute = 1;  // what a command register's write executes on

// PFNC pixel format codes (PixelFormat's entries).
inline constexpr std::uint32_t kPfncMono8 = 0x01080001;
inline constexpr std::uint32_t kPfncMono12 = 0x01100005;
inline constexpr std::uint32_t kPfncMono12p = 0x010C0047;
inline constexpr std::uint32_t kPfncMono16 = 0x01100007;

// Enumeration values.
inline constexpr std::uint32_t kAcquisitionModeContinuous = 0;
inline constexpr std::uint32_t kAcquisitionModeSingleFrame = 1;
inline constexpr std::uint32_t kAcquisitionModeMultiFrame = 2;
inline constexpr std::uint32_t kTriggerSelectorFrameStart = 0;
inline constexpr std::uint32_t kTriggerModeOff = 0;
inline constexpr std::uint32_t kTriggerModeOn = 1;
inline constexpr std::uint32_t kTriggerSourceSoftware = 0;
inline constexpr std::uint32_t kTriggerSourceLine0 = 1;
inline constexpr std::uint32_t kTriggerSourceLine1 = 2;
inline constexpr std::uint32_t kLineSelectorLine0 = 0;
inline constexpr std::uint32_t kLineSelectorLine1 = 1;
inline constexpr std::uint32_t kLineSelectorLine2 = 2;
inline constexpr std::uint32_t kLineModeInput = 0;
inline constexpr std::uint32_t kLineModeOutput = 1;
inline constexpr std::uint32_t kLineSourceOff = 0;
inline constexpr std::uint32_t kLineSourceUserOutput0 = 1;
inline constexpr std::uint32_t kUserOutputSelectorUserOutput0 = 0;

// Value ranges the XML declares (inclusive).
inline constexpr std::uint32_t kBinningMax = 8;  // binning: 1 .. kBinningMax
inline constexpr float kExposureTimeMin = 1.0f;  // us
inline constexpr float kExposureTimeMax = 10'000'000.0f;
inline constexpr float kGainMin = 0.0f;  // dB
inline constexpr float kGainMax = 24.0f;
inline constexpr float kAcquisitionFrameRateMin = 0.001f;  // Hz
inline constexpr float kAcquisitionFrameRateMax = 1000.0f;
inline constexpr std::uint32_t kAcquisitionFrameCountMin = 1;
inline constexpr std::uint32_t kAcquisitionFrameCountMax = 65535;
inline constexpr std::uint32_t kDeviceLinkThroughputLimitMin = 1;  // bytes/s
inline constexpr std::uint32_t kDeviceLinkThroughputLimitMax = 500'000'000;

// The device's GenICam XML (schema 1.1) over the camera registers above.
extern const std::string_view kGenicamXml;

}  // namespace lfi::emulation::u3v
