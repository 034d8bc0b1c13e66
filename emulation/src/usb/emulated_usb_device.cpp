// SPDX-License-Identifier: Apache-2.0
// The emulated USB display's device side, as firmware would behave: frame assembly and
// validation from bulk OUT data, PRESENT, and the answers to the protocol's control requests.

#include "emulated_usb_display_impl.h"

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstring>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace lfi::emulation {
void EmulatedUsbDisplay::Impl::resetFrame() {
  rx.clear();
  expected = 0;
  rxError = proto::DeviceError::None;
  frameStarted = false;
  frameCorrupt = frameUnplug = false;
  frameTruncate = 0;
  frameUrb = frameShortBy = 0;
  frameStallAt = frameShortAt = -1;
}

void EmulatedUsbDisplay::Impl::bulkOut(const std::uint8_t* bytes, int length, Urb& u) {
  if (stallAll || halted) {
    halted = true;
    u.status = -EPIPE;
    return;
  }
  if (!frameStarted) {
    frameStarted = true;
    frameCorrupt = std::exchange(corruptNext, false);
    frameTruncate = std::exchange(truncateNext, 0);
    frameUnplug = std::exchange(unplugNext, false);
    frameStallAt = std::exchange(stallNextAt, -1);
    frameShortAt = std::exchange(shortNextAt, -1);
    frameShortBy = std::exchange(shortNextBy, 0);
  }
  const int urb = frameUrb++;
  if (urb == frameStallAt) {  // (CLEAR_HALT then drops what the frame sent before)
    halted = true;
    u.status = -EPIPE;
    return;
  }
  if (urb == frameShortAt) length = std::max(0, length - frameShortBy);
  u.status = 0;
  u.actualLength = length;
  if (rxError != proto::DeviceError::None) return;  // discard until PRESENT
  if (expected > 0 && rx.size() + static_cast<std::size_t>(length) > expected) {
    rxError = proto::DeviceError::Overflow;
    return;
  }
  rx.insert(rx.end(), bytes, bytes + length);
  if (expected == 0 && rx.size() >= proto::kFrameHeaderSize) {
    rxError = proto::decodeFrameHeader(rx, header);
    if (rxError == proto::DeviceError::None) {
      const int sub = config.subpixels == proto::SubpixelCode::Mono ? 1 : 3;
      const auto want = static_cast<int>(proto::bytesPerPixel(header.format));
      if (header.width != config.panelWidth_px || header.height != config.panelHeight_px || want != sub)
        rxError = proto::DeviceError::BadSize;
      expected = proto::kFrameHeaderSize + header.payloadSize;
    }
  }
  if (expected > 0 && rx.size() > expected) rxError = proto::DeviceError::Overflow;
  if (expected > 0 && rx.size() == expected) {
    if (frameCorrupt) rx[proto::kFrameHeaderSize + header.payloadSize / 2] ^= 0x5a;
    if (frameTruncate > 0) rx.resize(rx.size() - std::min(frameTruncate, header.payloadSize + std::size_t{0}));
  }
}

void EmulatedUsbDisplay::Impl::reject(proto::DeviceError error, std::uint32_t sequence, std::string text) {
  state.lastError = error;
  lastErrorSequence = sequence;
  lastErrorText = std::move(text);
  ++state.framesRejected;
}

proto::DeviceError EmulatedUsbDisplay::Impl::present(std::uint16_t sequence16) {
  const std::uint32_t sequence = expected ? header.sequence : 0;
  if (!frameStarted || rx.empty()) {
    reject(proto::DeviceError::NoFrame, sequence, "nothing received since the last PRESENT");
    return proto::DeviceError::NoFrame;
  }
  proto::DeviceError error = rxError;
  std::string text;
  if (error == proto::DeviceError::None && (expected == 0 || rx.size() < expected)) {
    error = proto::DeviceError::Truncated;
    text = fmt::format("received {} of {} bytes", rx.size(), expected ? expected : proto::kFrameHeaderSize);
  }
  if (error == proto::DeviceError::None && static_cast<std::uint16_t>(header.sequence) != sequence16) {
    error = proto::DeviceError::SequenceMismatch;
    text = fmt::format("PRESENT names {} but frame {} arrived", sequence16, header.sequence);
  }
  if (error == proto::DeviceError::None) {
    const std::uint32_t crc =
        proto::crc32Of(std::span<const std::uint8_t>(rx).subspan(proto::kFrameHeaderSize, header.payloadSize));
    if (crc != header.payloadCrc) {
      error = proto::DeviceError::PayloadCrc;
      text = fmt::format("header says 0x{:08x}, payload has 0x{:08x}", header.payloadCrc, crc);
    }
  }
  if (error != proto::DeviceError::None) {
    reject(error, sequence, text);
    resetFrame();
    return error;
  }
  const int type = header.format == proto::Format::Rgb888 ? CV_8UC3 : CV_8UC1;
  cv::Mat image(header.height, header.width, type);
  std::memcpy(image.data, rx.data() + proto::kFrameHeaderSize, header.payloadSize);
  presented = image;
  state.presentedSequence = header.sequence;
  ++state.framesPresented;
  state.showing = true;
  resetFrame();
  if (observer.presented) observer.presented(presented, state.presentedSequence);
  return proto::DeviceError::None;
}

// Answers one control transfer; `bytes` is the 8-byte setup packet and the data stage.
void EmulatedUsbDisplay::Impl::control(std::uint8_t* bytes, int length, Urb& u) {
  const std::uint8_t type = bytes[0], request = bytes[1];
  const std::uint16_t value = proto::getU16(bytes + 2), wLength = proto::getU16(bytes + 6);
  std::vector<std::uint8_t> reply;
  bool stall = false;
  if (type == 0x80 && request == 6 && (value >> 8) == 3) {  // GET_DESCRIPTOR(string)
    const int index = value & 0xff;
    if (index == 0)
      reply = {4, 3, 0x09, 0x04};
    else if (index == 1)
      reply = detail::stringDescriptor(config.vendor);
    else if (index == 2)
      reply = detail::stringDescriptor(config.model);
    else if (index == 3 && config.serialDescriptor)
      reply = detail::stringDescriptor(config.serial);
    else
      stall = true;
  } else if (type == proto::kRequestTypeIn) {
    switch (static_cast<proto::Request>(request)) {
      case proto::Request::GetProtocolVersion:
        proto::putU16(reply, proto::kProtocolMajor);
        proto::putU16(reply, proto::kProtocolMinor);
        break;
      case proto::Request::GetDeviceInfo:
        reply = deviceInfo();
        break;
      case proto::Request::GetCalibration: {
        std::vector<std::uint8_t> blob = proto::encodeCalibration(config.calibration);
        if (badCalibrationCrc) blob[20] ^= 0xff;
        const std::size_t offset = static_cast<std::size_t>(value) * proto::kCalibrationChunk;
        if (offset >= blob.size())
          stall = true;
        else
          reply.assign(
              blob.begin() + static_cast<std::ptrdiff_t>(offset),
              blob.begin() + static_cast<std::ptrdiff_t>(std::min(blob.size(), offset + proto::kCalibrationChunk)));
        break;
      }
      case proto::Request::GetStatus: {
        proto::StatusBlock s;
        s.showing = state.showing ? 1 : 0;
        s.presentedSequence = statusPresentedSequence >= 0 ? static_cast<std::uint32_t>(statusPresentedSequence)
                                                           : state.presentedSequence;
        s.framesPresented = state.framesPresented;
        s.framesRejected = state.framesRejected;
        s.brightness = static_cast<std::uint16_t>(statusBrightness >= 0 ? statusBrightness : state.brightness);
        s.lastError = static_cast<std::uint32_t>(state.lastError);
        s.lastErrorSequence = lastErrorSequence;
        reply = proto::encodeStatus(s);
        break;
      }
      case proto::Request::GetLastError:
        reply = forgetErrors ? proto::encodeLastError(proto::DeviceError::None, 0, "")
                             : proto::encodeLastError(state.lastError, lastErrorSequence, lastErrorText);
        break;
      default:
        stall = true;
    }
  } else if (type == proto::kRequestTypeOut) {
    switch (static_cast<proto::Request>(request)) {
      case proto::Request::SetBrightness:
        if (value > config.brightnessMax) {
          reject(proto::DeviceError::BadRequest, 0, fmt::format("brightness {} > {}", value, config.brightnessMax));
          stall = true;
        } else {
          state.brightness = value;
          if (observer.brightness) observer.brightness(value);
        }
        break;
      case proto::Request::Present:
        stall = present(value) != proto::DeviceError::None;
        break;
      case proto::Request::Blank:
        state.showing = false;
        if (observer.blanked) observer.blanked();
        break;
      default:
        stall = true;
    }
  } else {
    stall = true;
  }
  if (stall) {
    u.status = -EPIPE;
    u.actualLength = 0;
    return;
  }
  const std::size_t n = std::min<std::size_t>({reply.size(), wLength, static_cast<std::size_t>(length - 8)});
  if (n > 0) std::memcpy(bytes + 8, reply.data(), n);
  u.status = 0;
  u.actualLength = static_cast<int>(n);
}

std::vector<std::uint8_t> EmulatedUsbDisplay::Impl::deviceInfo() const {
  proto::DeviceInfoBlock info;
  info.vendor = config.vendor;
  info.model = config.model;
  info.serial = config.serial;
  info.panelWidth_px = config.panelWidth_px;
  info.panelHeight_px = config.panelHeight_px;
  info.subpixels = config.subpixels;
  info.formats = config.subpixels == proto::SubpixelCode::Mono ? 0x1 : 0x2;
  info.brightnessMax = config.brightnessMax;
  info.brightness = state.brightness;
  info.viewCount = config.viewCount;
  info.calibrationSize =
      absurdInfo ? 0xffffffffu : static_cast<std::uint32_t>(proto::encodeCalibration(config.calibration).size());
  info.maxPayloadSize = static_cast<std::uint32_t>(config.panelWidth_px * config.panelHeight_px *
                                                   (config.subpixels == proto::SubpixelCode::Mono ? 1 : 3));
  return proto::encodeDeviceInfo(info);
}

}  // namespace lfi::emulation
