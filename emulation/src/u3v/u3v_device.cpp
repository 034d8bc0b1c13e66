// SPDX-License-Identifier: Apache-2.0
// The emulated USB3 Vision camera's device side (u3v_camera_impl.h): its USB
// descriptors and string descriptors, the standard requests on endpoint 0,
// GenCP commands and acks on the control endpoints, and the register memory
// those read and write, with what a write to a camera register does.

#include "u3v_camera_impl.h"

#include "u3v_registers.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace lfi::emulation {
namespace {

using namespace u3v;

constexpr std::uint32_t kGencpMagic = 0x43563355;  // "U3VC"
constexpr std::uint16_t kReadMemory = 0x0800, kWriteMemory = 0x0802;
constexpr std::uint16_t kRequestAck = 0x4000;
constexpr std::uint32_t kMaxAckTransfer = 16384 + 12;           // a READMEM ack: 16 KiB of data
constexpr std::uint32_t kMaxCmdTransfer = kMaxAckTransfer + 8;  // a WRITEMEM command of as much

bool isPixelFormat(std::uint32_t v) {
  return v == kPfncMono8 || v == kPfncMono12 || v == kPfncMono12p || v == kPfncMono16;
}

}  // namespace

// The default: the vendor id and a 32-bit FNV-1a hash of the serial, 12 hex digits as USB3 Vision GUIDs are.
std::string emulatedU3vGuid(const EmulatedU3vCameraConfig& config) {
  if (!config.guid.empty()) return config.guid;
  std::uint32_t h = 2166136261u;
  for (char c : config.serial) h = (h ^ static_cast<std::uint8_t>(c)) * 16777619u;
  return fmt::format("{:04X}{:08X}", config.vendorId, h);
}

EmulatedU3vCamera::Impl::Impl(const EmulatedU3vCameraConfig& c, ServedFrameFiller f)
    : config(c),
      filler(std::move(f)),
      guid(emulatedU3vGuid(c)),
      node(c.busNumber, c.deviceNumber, "emulated USB3 Vision camera", *this) {
  resetRegisters();
  frameThread = std::thread([this] { runFrames(); });
}

EmulatedU3vCamera::Impl::~Impl() {
  {
    std::lock_guard lock(node.mutex());
    stopThread = true;
  }
  wake.notify_all();
  frameThread.join();
}

// ---- descriptors -------------------------------------------------------------

std::string EmulatedU3vCamera::Impl::record() const {
  std::vector<std::uint8_t> d;
  d.reserve(128);  // (all of it; GCC 12's -Wstringop-overflow misreads the growth of an empty vector)
  auto u16 = [&](int v) {
    d.push_back(static_cast<std::uint8_t>(v));
    d.push_back(static_cast<std::uint8_t>(v >> 8));
  };
  auto endpoint = [&](std::uint8_t address) {  // bulk, 1024-byte SuperSpeed packets
    d.insert(d.end(), {7, 5, address, 2});
    u16(1024);
    d.push_back(0);
  };
  // Device: USB 3.0, miscellaneous class with an interface association.
  detail::appendDeviceDescriptor(d, {.usbRelease = 0x0300,
                                     .deviceClass = 0xEF,
                                     .deviceSubclass = 0x02,
                                     .deviceProtocol = 0x01,
                                     .maxPacket0 = 9,
                                     .vendorId = config.vendorId,
                                     .productId = config.productId});
  // Configuration: the association, the control interface with the USB3 Vision
  // device info descriptor right after it (iDeviceGUID = string 4), the stream interface.
  const std::size_t configuration = d.size();
  d.insert(d.end(), {9, 2, 0, 0, 2, 1, 0, 0x80, 112});
  d.insert(d.end(), {8, 0x0B, 0, 2, 0xEF, 0x05, 0x00, 0});
  d.insert(d.end(), {9, 4, u3vusb::kControlInterface, 0, 2, 0xEF, 0x05, 0x00, 0});
  d.insert(d.end(), {20, 0x24, 0x01});
  u16(0), u16(1), u16(0), u16(1);                     // GenCP 1.0, USB3 Vision 1.0
  d.insert(d.end(), {4, 1, 2, 0, 0, 0, 3, 0, 0x0C});  // GUID, vendor, model, ..., serial; high and super speed
  endpoint(u3vusb::kControlOut);
  endpoint(u3vusb::kControlIn);
  d.insert(d.end(), {9, 4, u3vusb::kStreamInterface, 0, 1, 0xEF, 0x05, 0x02, 0});
  endpoint(u3vusb::kStreamIn);
  putU16(d.data() + configuration + 2, static_cast<std::uint16_t>(d.size() - configuration));
  return detail::recordText(node, {.vendorId = config.vendorId,
                                   .productId = config.productId,
                                   .manufacturer = config.vendor,
                                   .product = config.model,
                                   .serial = config.serial,
                                   .speed_mbps = 5000,
                                   .interfaces = 2,
                                   .descriptors = std::move(d)});
}

// ---- registers ---------------------------------------------------------------

void EmulatedU3vCamera::Impl::resetRegisters() {
  memory.clear();
  auto& abrm = memory[kAbrm];
  abrm.assign(0x210, 0);
  auto text = [&](std::uint64_t address, const std::string& s) {
    std::memcpy(abrm.data() + address, s.data(), std::min<std::size_t>(s.size(), kAbrmStringLength - 1));
  };
  putU32(abrm.data() + kAbrmGencpVersion, 1u << 16);  // 1.0
  text(kAbrmManufacturerName, config.vendor);
  text(kAbrmModelName, config.model);
  text(kAbrmFamilyName, "lfi");
  text(kAbrmDeviceVersion, "1.0");
  text(kAbrmManufacturerInfo, "emulated on umockdev");
  text(kAbrmSerialNumber, config.serial);
  putU32(abrm.data() + kAbrmMaxDeviceResponseTime, config.maxDeviceResponseTime_ms);
  putU64(abrm.data() + kAbrmManifestTableAddress, kManifestTable);
  putU64(abrm.data() + kAbrmSbrmAddress, kSbrm);
  putU32(abrm.data() + kAbrmProtocolEndianness, 0xFFFFFFFF);  // little-endian
  putU32(abrm.data() + kAbrmImplementationEndianness, 0xFFFFFFFF);

  auto& sbrm = memory[kSbrm];
  sbrm.assign(0x44, 0);
  putU32(sbrm.data() + (kSbrmU3vVersion - kSbrm), 1u << 16);
  putU32(sbrm.data() + (kSbrmMaxCmdTransfer - kSbrm), kMaxCmdTransfer);
  putU32(sbrm.data() + (kSbrmMaxAckTransfer - kSbrm), kMaxAckTransfer);
  putU32(sbrm.data() + (kSbrmNumStreamChannels - kSbrm), 1);
  putU64(sbrm.data() + (kSbrmSirmAddress - kSbrm), kSirm);
  putU32(sbrm.data() + (kSbrmSirmLength - kSbrm), 0x30);
  putU32(sbrm.data() + (kSbrmCurrentSpeed - kSbrm), 8);  // SuperSpeed

  auto& sirm = memory[kSirm];
  sirm.assign(0x30, 0);  // Info 0: no alignment
  putU32(sirm.data() + (kSirmRequiredLeaderSize - kSirm), u3vusb::kLeaderSize);
  putU32(sirm.data() + (kSirmRequiredTrailerSize - kSirm), u3vusb::kTrailerSize);

  auto& manifest = memory[kManifestTable];
  manifest.assign(8 + kManifestEntrySize, 0);
  putU64(manifest.data(), 1);
  manifest[8 + 3] = 1;                                // file version 1.0.0
  putU32(manifest.data() + 12, 1u << 24 | 1u << 16);  // schema 1.1, uncompressed device description
  putU64(manifest.data() + 16, kGenicamXmlAddress);
  putU64(manifest.data() + 24, kGenicamXml.size());
  memory[kGenicamXmlAddress].assign(kGenicamXml.begin(), kGenicamXml.end());

  memory[kCameraRegisters].assign(kCameraRegistersEnd - kCameraRegisters, 0);
  setReg(kRegWidth, static_cast<std::uint32_t>(config.sensorWidth_px));
  setReg(kRegHeight, static_cast<std::uint32_t>(config.sensorHeight_px));
  setReg(kRegPixelFormat, kPfncMono8);
  setReg(kRegBinningHorizontal, 1);
  setReg(kRegBinningVertical, 1);
  setReg(kRegSensorWidth, static_cast<std::uint32_t>(config.sensorWidth_px));
  setReg(kRegSensorHeight, static_cast<std::uint32_t>(config.sensorHeight_px));
  setReg(kRegWidthMax, static_cast<std::uint32_t>(config.sensorWidth_px));
  setReg(kRegHeightMax, static_cast<std::uint32_t>(config.sensorHeight_px));
  setReg(kRegAcquisitionMode, kAcquisitionModeContinuous);
  setReg(kRegTriggerMode, kTriggerModeOff);
  setReg(kRegTriggerSource, kTriggerSourceSoftware);
  setReg(kRegExposureTime, std::bit_cast<std::uint32_t>(10000.0f));
  setReg(kRegGain, std::bit_cast<std::uint32_t>(0.0f));
  setReg(kRegAcquisitionFrameRate, std::bit_cast<std::uint32_t>(25.0f));
  setReg(kRegAcquisitionFrameCount, 1);
  setReg(kRegDeviceLinkThroughputLimit, kDeviceLinkThroughputLimitMax);
  updatePayloadSize();
}

std::uint8_t* EmulatedU3vCamera::Impl::at(std::uint64_t address, std::size_t length) {
  auto it = memory.upper_bound(address);
  if (it == memory.begin()) return nullptr;
  --it;
  const std::uint64_t offset = address - it->first;
  if (offset > it->second.size() || length > it->second.size() - offset) return nullptr;
  return it->second.data() + offset;
}

std::uint32_t EmulatedU3vCamera::Impl::reg(std::uint64_t address) const {
  return getU32(memory.at(kCameraRegisters).data() + (address - kCameraRegisters));
}

void EmulatedU3vCamera::Impl::setReg(std::uint64_t address, std::uint32_t value) {
  putU32(memory.at(kCameraRegisters).data() + (address - kCameraRegisters), value);
}

float EmulatedU3vCamera::Impl::floatReg(std::uint64_t address) const {
  return std::bit_cast<float>(reg(address));
}

std::uint64_t EmulatedU3vCamera::Impl::payloadSize() const {
  const std::uint64_t pixels = static_cast<std::uint64_t>(reg(kRegWidth)) * reg(kRegHeight);
  switch (reg(kRegPixelFormat)) {
    case kPfncMono8:
      return pixels;
    case kPfncMono12p:
      return (pixels * 3 + 1) / 2;
    default:
      return 2 * pixels;
  }
}

void EmulatedU3vCamera::Impl::updatePayloadSize() {
  const std::uint64_t size = payloadSize();
  setReg(kRegPayloadSize, static_cast<std::uint32_t>(size));
  putU64(memory.at(kSirm).data() + (kSirmRequiredPayloadSize - kSirm), size);
}

GencpStatus EmulatedU3vCamera::Impl::read(std::uint64_t address, std::size_t length,
                                          std::vector<std::uint8_t>& out) const {
  const std::uint8_t* p = const_cast<Impl*>(this)->at(address, length);
  if (p == nullptr) return GencpStatus::InvalidAddress;
  out.assign(p, p + length);
  return GencpStatus::Success;
}

GencpStatus EmulatedU3vCamera::Impl::write(std::uint64_t address, const std::uint8_t* data, std::size_t length) {
  std::uint8_t* p = at(address, length);
  if (p == nullptr) return GencpStatus::InvalidAddress;
  const bool inUserName = address >= kAbrmUserDefinedName && address + length <= kAbrmDeviceCapability;
  const bool inSirm = address >= kSirmControl && address + length <= kSirmMaximumTrailerSize + 4 &&
                      !(address < kSirmMaximumLeaderSize && address + length > kSirmRequiredPayloadSize);
  if (inUserName || inSirm) {
    std::memcpy(p, data, length);
    if (inSirm && address <= kSirmControl) {
      const bool enable = (getU32(memory.at(kSirm).data() + (kSirmControl - kSirm)) & 1) != 0;
      if (!enable) stream.clear(), queuedFrames = 0;
      state.streamEnabled = enable;
      wake.notify_all();
    }
    return GencpStatus::Success;
  }
  if (address < kCameraRegisters || address + length > kCameraRegistersEnd) return GencpStatus::WriteProtect;
  if (address % 4 != 0 || length % 4 != 0) return GencpStatus::BadAlignment;
  for (std::size_t i = 0; i < length; i += 4) {
    const std::uint64_t r = address + i;
    const std::uint32_t v = getU32(data + i);
    const float f = std::bit_cast<float>(v);
    const std::uint32_t widthMax = reg(kRegWidthMax), heightMax = reg(kRegHeightMax);
    const bool geometry = r == kRegWidth || r == kRegHeight || r == kRegOffsetX || r == kRegOffsetY ||
                          r == kRegPixelFormat || r == kRegBinningHorizontal || r == kRegBinningVertical;
    if (geometry && state.acquiring) return GencpStatus::WriteProtect;  // (locked while streaming, as TLParamsLocked)
    bool ok = true;
    switch (r) {
      case kRegWidth:
        ok = v >= 1 && v + reg(kRegOffsetX) <= widthMax;
        break;
      case kRegHeight:
        ok = v >= 1 && v + reg(kRegOffsetY) <= heightMax;
        break;
      case kRegOffsetX:
        ok = v + reg(kRegWidth) <= widthMax;
        break;
      case kRegOffsetY:
        ok = v + reg(kRegHeight) <= heightMax;
        break;
      case kRegPixelFormat:
        ok = isPixelFormat(v);
        break;
      case kRegBinningHorizontal:
      case kRegBinningVertical:
        ok = v >= 1 && v <= kBinningMax;
        break;
      case kRegSensorWidth:
      case kRegSensorHeight:
      case kRegWidthMax:
      case kRegHeightMax:
      case kRegPayloadSize:
        return GencpStatus::WriteProtect;
      case kRegAcquisitionMode:
        ok = v <= kAcquisitionModeMultiFrame;
        break;
      case kRegTriggerSelector:
      case kRegUserOutputSelector:
        ok = v == 0;
        break;
      case kRegTriggerMode:
      case kRegLineMode:
      case kRegLineSource:
      case kRegUserOutputValue:
        ok = v <= 1;
        break;
      case kRegTriggerSource:
      case kRegLineSelector:
        ok = v <= 2;
        break;
      case kRegExposureTime:
        ok = f >= kExposureTimeMin && f <= kExposureTimeMax;
        break;
      case kRegGain:
        ok = f >= kGainMin && f <= kGainMax;
        break;
      case kRegAcquisitionFrameRate:
        ok = f >= kAcquisitionFrameRateMin && f <= kAcquisitionFrameRateMax;
        break;
      case kRegAcquisitionFrameCount:
        ok = v >= kAcquisitionFrameCountMin && v <= kAcquisitionFrameCountMax;
        break;
      case kRegDeviceLinkThroughputLimit:
        ok = v >= kDeviceLinkThroughputLimitMin && v <= kDeviceLinkThroughputLimitMax;
        break;
      default:
        break;
    }
    if (!ok) return GencpStatus::InvalidParameter;
    const bool execute = v == kCommandExecute;
    if (r == kRegAcquisitionStart || r == kRegAcquisitionStop || r == kRegTriggerSoftware || r == kRegDeviceReset) {
      if (!execute) continue;
      if (r == kRegAcquisitionStart) startAcquisition();
      if (r == kRegAcquisitionStop) state.acquiring = false, framesLeft = 0;
      if (r == kRegTriggerSoftware && state.acquiring && reg(kRegTriggerMode) == kTriggerModeOn &&
          reg(kRegTriggerSource) == kTriggerSourceSoftware)
        ++pendingTriggers, wake.notify_all();
      if (r == kRegDeviceReset) resetRegisters(), state.acquiring = false;
      continue;
    }
    setReg(r, v);
    if (r == kRegUserOutputValue) state.userOutput = v != 0;
    if (r == kRegBinningHorizontal || r == kRegBinningVertical) {  // the binned sensor, and the region inside it
      const auto maxW = static_cast<std::uint32_t>(config.sensorWidth_px) / reg(kRegBinningHorizontal);
      const auto maxH = static_cast<std::uint32_t>(config.sensorHeight_px) / reg(kRegBinningVertical);
      setReg(kRegWidthMax, maxW), setReg(kRegHeightMax, maxH);
      setReg(kRegWidth, std::min(reg(kRegWidth), maxW)), setReg(kRegHeight, std::min(reg(kRegHeight), maxH));
      setReg(kRegOffsetX, std::min(reg(kRegOffsetX), maxW - reg(kRegWidth)));
      setReg(kRegOffsetY, std::min(reg(kRegOffsetY), maxH - reg(kRegHeight)));
    }
    if (geometry) updatePayloadSize();
  }
  return GencpStatus::Success;
}

// ---- the host's URBs, on the node's handler thread -----------------------------

detail::UsbdevfsDevice::Submitted EmulatedU3vCamera::Impl::submit(Urb& u) {
  if (!u.bulk) return control(u);
  if (u.endpoint == u3vusb::kControlOut) {
    command(u.bytes(), u.length());
    u.status = 0;
    u.actualLength = u.length();
    return Submitted::Complete;
  }
  if (u.endpoint == u3vusb::kControlIn) {
    if (acks.empty()) return Submitted::Hold;
    const std::vector<std::uint8_t>& ack = acks.front();
    const int n = std::min(u.length(), static_cast<int>(ack.size()));
    std::memcpy(u.bytes(), ack.data(), static_cast<std::size_t>(n));
    u.status = n < static_cast<int>(ack.size()) ? -EOVERFLOW : 0;  // (the host's buffer was too short: babble)
    u.actualLength = n;
    acks.pop_front();
    return Submitted::Complete;
  }
  if (u.endpoint == u3vusb::kStreamIn) return fillStream(u) ? Submitted::Complete : Submitted::Hold;
  return Submitted::Refuse;
}

void EmulatedU3vCamera::Impl::deliverAcks() {
  while (!acks.empty()) {
    Urb* u = node.oldestHeld(u3vusb::kControlIn);
    if (u == nullptr) return;
    submit(*u);
    node.complete(u);
  }
}

// Standard requests on endpoint 0: string descriptors; SET_FEATURE and
// CLEAR_FEATURE(ENDPOINT_HALT) of the stream endpoint (Aravis resets it so when
// it opens the device). Anything else stalls.
detail::UsbdevfsDevice::Submitted EmulatedU3vCamera::Impl::control(Urb& u) {
  std::uint8_t* bytes = u.bytes();
  const std::uint8_t type = bytes[0], request = bytes[1];
  const std::uint16_t value = getU16(bytes + 2), index = getU16(bytes + 4), wLength = getU16(bytes + 6);
  std::vector<std::uint8_t> reply;
  bool stall = false;
  if (type == 0x80 && request == 6 && (value >> 8) == 3) {  // GET_DESCRIPTOR(string)
    switch (value & 0xff) {
      case 0:
        reply = {4, 3, 0x09, 0x04};
        break;
      case 1:
        reply = detail::stringDescriptor(config.vendor);
        break;
      case 2:
        reply = detail::stringDescriptor(config.model);
        break;
      case 3:
        reply = detail::stringDescriptor(config.serial);
        break;
      case 4:
        reply = detail::stringDescriptor(guid);
        break;
      default:
        stall = true;
    }
  } else if (type == 0x02 && (request == 3 || request == 1) && value == 0 && index == u3vusb::kStreamIn) {
    streamHalted = request == 3;  // SET_FEATURE halts: what the endpoint held is dropped
    if (streamHalted) stream.clear(), queuedFrames = 0;
  } else {
    stall = true;
  }
  if (stall) {
    u.status = -EPIPE;
    u.actualLength = 0;
    return Submitted::Complete;
  }
  const std::size_t n = std::min<std::size_t>({reply.size(), wLength, static_cast<std::size_t>(u.length() - 8)});
  if (n > 0) std::memcpy(bytes + 8, reply.data(), n);
  u.status = 0;
  u.actualLength = static_cast<int>(n);
  return Submitted::Complete;
}

int EmulatedU3vCamera::Impl::claimInterface(unsigned interface, bool claim) {
  if (interface == u3vusb::kControlInterface)
    state.controlClaimed = claim;
  else if (interface == u3vusb::kStreamInterface)
    state.streamClaimed = claim;
  else
    return EINVAL;
  return 0;
}

int EmulatedU3vCamera::Impl::clearHalt(unsigned endpoint) {
  if (endpoint == u3vusb::kStreamIn) streamHalted = false;
  return 0;
}

// One GenCP command from the control OUT endpoint; its ack goes to the control IN queue.
void EmulatedU3vCamera::Impl::command(const std::uint8_t* bytes, int length) {
  if (length < 12 || getU32(bytes) != kGencpMagic) return;  // not GenCP: nothing to answer
  ++state.commands;
  if (silent) return;
  const std::uint16_t flags = getU16(bytes + 4), id = getU16(bytes + 10);
  const std::uint16_t command = getU16(bytes + 6), size = getU16(bytes + 8);
  GencpStatus status = GencpStatus::Success;
  std::vector<std::uint8_t> data;
  if (12 + size != length) {
    status = GencpStatus::InvalidParameter;
  } else if (command == kReadMemory && size == 12) {
    const std::uint16_t n = getU16(bytes + 22);
    status = 12u + n > kMaxAckTransfer ? GencpStatus::InvalidParameter : read(getU64(bytes + 12), n, data);
  } else if (command == kWriteMemory && size >= 8) {
    status = write(getU64(bytes + 12), bytes + 20, size - 8u);
    data.assign(4, 0);
    putU16(data.data() + 2, status == GencpStatus::Success ? static_cast<std::uint16_t>(size - 8) : 0);
  } else {
    status = GencpStatus::NotImplemented;
  }
  if (failNext != 0) status = static_cast<GencpStatus>(std::exchange(failNext, 0));
  if ((flags & kRequestAck) == 0) return;
  if (status != GencpStatus::Success && command == kReadMemory) data.clear();
  std::vector<std::uint8_t> ack(12 + data.size());
  putU32(ack.data(), kGencpMagic);
  putU16(ack.data() + 4, static_cast<std::uint16_t>(status));
  putU16(ack.data() + 6, static_cast<std::uint16_t>(command + 1));
  putU16(ack.data() + 8, static_cast<std::uint16_t>(data.size()));
  putU16(ack.data() + 10, id);
  std::copy(data.begin(), data.end(), ack.begin() + 12);
  acks.push_back(std::move(ack));
  deliverAcks();
}

}  // namespace lfi::emulation
