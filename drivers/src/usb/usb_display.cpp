// SPDX-License-Identifier: Apache-2.0
// The usb: backend's Display (usb_display.h): open/close, show, blank, brightness and
// status over the vendor interface's control requests, and the identity read at open.

#include "usb_display_impl.h"

#include "lfi/drivers/display_calibration_file.h"
#include "lfi/drivers/driver_trace.h"

#include "lfi/core/error.h"

#include <fmt/format.h>
#include <libusb.h>

#include <algorithm>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace lfi {
namespace detail {
namespace {

SubpixelLayout toLayout(proto::SubpixelCode code) {
  switch (code) {
    case proto::SubpixelCode::RgbStripe:
      return SubpixelLayout::RgbStripe;
    case proto::SubpixelCode::BgrStripe:
      return SubpixelLayout::BgrStripe;
    case proto::SubpixelCode::Mono:
      break;
  }
  return SubpixelLayout::Mono;
}

}  // namespace

UsbDisplay::UsbDisplay(UsbDisplaySelector selector, UsbDisplayOptions options)
    : selector_(std::move(selector)), options_(options), name_(selector_.uri()) {
  if (options_.transfersInFlight < 1 || options_.transfersInFlight > 32)
    fail(Errc::InvalidArgument, "{}: transfersInFlight = {} is outside 1..32", name_, options_.transfersInFlight);
  if (options_.transferSize_bytes < 512 || options_.transferSize_bytes > (16u << 20) ||
      options_.transferSize_bytes % 512 != 0)
    fail(Errc::InvalidArgument, "{}: transferSize_bytes = {} is not a multiple of 512 in 512..16 MiB", name_,
         options_.transferSize_bytes);
  // (libusb takes an unsigned ms count, 0 = forever; the URI's timeout_ms has the same bound.)
  constexpr std::chrono::milliseconds kLongest{600'000};
  if (options_.controlTimeout.count() < 1 || options_.transferTimeout.count() < 1 ||
      options_.controlTimeout > kLongest || options_.transferTimeout > kLongest || options_.stallRetries < 0)
    fail(Errc::InvalidArgument,
         "{}: timeouts must be 1 .. 600000 ms and stallRetries >= 0 (control {} ms, "
         "transfer {} ms, stallRetries {})",
         name_, options_.controlTimeout.count(), options_.transferTimeout.count(), options_.stallRetries);
}

UsbDisplay::~UsbDisplay() {
  close();
}

void UsbDisplay::open() {
  requireDisplayState(state_, {State::Closed}, "open", name_);
  sequence_ = 0;  // frames count from 1 after each open (docs/usb-display-protocol.md)
  if (const int rc = libusb_init(&ctx_); rc != 0)
    fail(Errc::Device, "{}: libusb_init failed: {}", name_, libusb_error_name(rc));
  try {
    openDevice();
    readIdentity();
    // Start from a known receive state: a host that died, or gave up, in the
    // middle of a frame left its bytes in the device.
    if (!clearHalt())
      fail(Errc::Timeout, "{}: CLEAR_HALT of endpoint 0x{:02x} got no answer ({}): the device does not answer", name_,
           endpoint_, clearHaltError_);
    // Open is dark at the backlight's maximum (display.h), whatever an earlier
    // host left on the panel: it may have died showing a frame.
    stallsCleared_ = 0, uncertain_ = false, lastPresented_ = 0;
    requireOk(control(LIBUSB_ENDPOINT_OUT, proto::Request::Blank, 0, nullptr, 0), proto::Request::Blank);
    requireOk(control(LIBUSB_ENDPOINT_OUT, proto::Request::SetBrightness,
                      static_cast<std::uint16_t>(info_.brightnessMax), nullptr, 0),
              proto::Request::SetBrightness);
  } catch (...) {
    close();
    throw;
  }
  state_ = State::Open;
}

void UsbDisplay::close() noexcept {
  if (handle_) {
    // The panel goes dark, as after blank() (best effort: a device that does
    // not answer keeps its frame until the next open() blanks it).
    if (claimed_ && state_ == State::Showing) control(LIBUSB_ENDPOINT_OUT, proto::Request::Blank, 0, nullptr, 0);
    if (claimed_) libusb_release_interface(handle_, interface_);
    libusb_close(handle_);
  }
  handle_ = nullptr;
  claimed_ = false;
  if (ctx_) libusb_exit(ctx_);
  ctx_ = nullptr;
  state_ = State::Closed;
}

DisplayInfo UsbDisplay::info() const {
  requireDisplayState(state_, {State::Open, State::Showing}, "info", name_);
  return info_;
}

PresentResult UsbDisplay::show(const cv::Mat& panel) {
  requireDisplayState(state_, {State::Open, State::Showing}, "show", name_);
  requirePanelImage(info_, panel, name_);
  const std::uint32_t sequence = ++sequence_;
  buildFrame(panel, sequence);
  // The device keeps the bytes of a frame that failed or timed out (in bulk
  // OUT or at PRESENT) until PRESENT or CLEAR_HALT resets its receive state;
  // appended to them, this frame would overflow.
  if (resync_ && !clearHalt())
    return {PresentStatus::Timeout, sequence,
            fmt::format("{}: CLEAR_HALT of endpoint 0x{:02x}, sent to discard an earlier frame that failed, "
                        "failed ({}); the next frame tries again",
                        name_, endpoint_, clearHaltError_)};

  for (int attempt = 0;; ++attempt) {
    std::size_t sent = 0;
    const BulkOutcome outcome = sendFrame(sent);
    traceDriverCall("usb", name_, "bulk OUT", fmt::format("frame {}: {} of {} bytes", sequence, sent, frame_.size()));
    if (outcome == BulkOutcome::Ok) break;
    resync_ = true;  // the device may hold part of the frame (cleared below for a stall)
    if (outcome == BulkOutcome::NoDevice) vanished(fmt::format("bulk OUT of frame {}", sequence));
    if (outcome == BulkOutcome::Timeout)
      return {PresentStatus::Timeout, sequence,
              fmt::format("{}: bulk OUT of frame {} to endpoint 0x{:02x} timed out ({} ms per transfer after those "
                          "queued before it, up to {} queued; {} of {} bytes acknowledged)",
                          name_, sequence, endpoint_, options_.transferTimeout.count(), options_.transfersInFlight,
                          sent, frame_.size())};
    if (outcome == BulkOutcome::Stall) {
      if (attempt >= options_.stallRetries)
        fail(Errc::Device, "{}: endpoint 0x{:02x} stalled again on frame {} after {} clear-halt retries", name_,
             endpoint_, sequence, options_.stallRetries);
      if (!clearHalt())
        return {PresentStatus::Timeout, sequence,
                fmt::format("{}: endpoint 0x{:02x} stalled on frame {} and CLEAR_HALT failed ({})", name_, endpoint_,
                            sequence, clearHaltError_)};
      ++stallsCleared_;
      continue;
    }
    fail(Errc::Device, "{}: bulk OUT of frame {} to endpoint 0x{:02x} failed ({} of {} bytes sent)", name_, sequence,
         endpoint_, sent, frame_.size());
  }

  const int rc =
      control(LIBUSB_ENDPOINT_OUT, proto::Request::Present, static_cast<std::uint16_t>(sequence), nullptr, 0);
  if (rc == LIBUSB_ERROR_PIPE) return {PresentStatus::Rejected, sequence, rejection(sequence)};
  resync_ = rc < 0;     // unanswered or failed: the device may still hold the frame
  uncertain_ = rc < 0;  // (and may show it)
  requireOk(rc, proto::Request::Present);
  state_ = State::Showing;
  lastPresented_ = sequence;
  return {PresentStatus::Presented, sequence, {}};
}

void UsbDisplay::blank() {
  requireDisplayState(state_, {State::Open, State::Showing}, "blank", name_);
  const int rc = control(LIBUSB_ENDPOINT_OUT, proto::Request::Blank, 0, nullptr, 0);
  uncertain_ = rc < 0;  // (it may have blanked)
  requireOk(rc, proto::Request::Blank);
  state_ = State::Open;
}

void UsbDisplay::setBrightness(int level) {
  requireDisplayState(state_, {State::Open, State::Showing}, "setBrightness", name_);
  if (level < info_.brightnessMin || level > info_.brightnessMax)
    fail(Errc::InvalidArgument, "{}: brightness {} is outside {}..{}", name_, level, info_.brightnessMin,
         info_.brightnessMax);
  requireOk(control(LIBUSB_ENDPOINT_OUT, proto::Request::SetBrightness, static_cast<std::uint16_t>(level), nullptr, 0),
            proto::Request::SetBrightness);
}

DisplayStatus UsbDisplay::status() {
  requireDisplayState(state_, {State::Open, State::Showing}, "status", name_);
  const proto::StatusBlock s = proto::decodeStatus(controlIn(proto::Request::GetStatus, 0, proto::kStatusSize), name_);
  // What the device says must agree with what this host did and with the device's own description.
  if (s.brightness < info_.brightnessMin || s.brightness > info_.brightnessMax)
    fail(Errc::Device, "{}: GET_STATUS says brightness {}, outside the device's own {}..{}", name_, s.brightness,
         info_.brightnessMin, info_.brightnessMax);
  if (state_ == State::Showing && !uncertain_ && (s.showing != 1 || s.presentedSequence != lastPresented_))
    fail(Errc::Device, "{}: GET_STATUS says {} frame {}; the last frame this host presented is {}", name_,
         s.showing == 1 ? "it shows" : "it is blank, after", s.presentedSequence, lastPresented_);
  DisplayStatus out;
  out.showing = s.showing == 1;
  out.presentedSequence = s.presentedSequence;
  out.framesPresented = s.framesPresented;
  out.framesRejected = s.framesRejected;
  out.brightness = s.brightness;
  if (s.lastError != 0) out.lastError = lastErrorText();
  out.stallsCleared = stallsCleared_;
  return out;
}

void UsbDisplay::readIdentity() {
  const std::vector<std::uint8_t> version = controlIn(proto::Request::GetProtocolVersion, 0, 4);
  if (version.size() != 4)
    fail(Errc::Device, "{}: GET_PROTOCOL_VERSION returned {} bytes, expected 4", name_, version.size());
  const std::uint16_t major = proto::getU16(version.data()), minor = proto::getU16(version.data() + 2);
  if (major != proto::kProtocolMajor)
    fail(Errc::Device, "{}: the device speaks protocol {}.{}, this host speaks {}.x", name_, major, minor,
         proto::kProtocolMajor);
  const proto::DeviceInfoBlock block =
      proto::decodeDeviceInfo(controlIn(proto::Request::GetDeviceInfo, 0, proto::kDeviceInfoSize), name_);
  std::vector<std::uint8_t> blob;
  for (std::uint16_t chunk = 0; blob.size() < block.calibrationSize; ++chunk) {
    const std::size_t want = std::min<std::size_t>(proto::kCalibrationChunk, block.calibrationSize - blob.size());
    const std::vector<std::uint8_t> part = controlIn(proto::Request::GetCalibration, chunk, want);
    if (part.size() != want)
      fail(Errc::Device, "{}: GET_CALIBRATION chunk {} returned {} bytes, expected {}", name_, chunk, part.size(),
           want);
    blob.insert(blob.end(), part.begin(), part.end());
  }
  const proto::CalibrationBlock cal = proto::decodeCalibration(blob, name_);

  DisplayInfo info;
  info.vendor = block.vendor;
  info.model = block.model;
  info.serial = block.serial;
  // The id that selects this device (display.h): by its USB serial, which
  // openDevice() matches; the info block's serial cannot select it.
  info.deviceId = serial_.empty()
                      ? fmt::format("{:04x}:{:04x}", selector_.vendorId, selector_.productId)
                      : fmt::format("{:04x}:{:04x}/{}", selector_.vendorId, selector_.productId, serialInUri(serial_));
  info.panelWidth_px = block.panelWidth_px;
  info.panelHeight_px = block.panelHeight_px;
  info.pixelPitch_mm = cal.pixelPitch_mm;
  info.subpixels = toLayout(block.subpixels);
  info.optics = proto::toOpticsParams(cal);
  if (!options_.opticsOverride.empty()) info.optics = readDisplayOpticsFile(options_.opticsOverride, info.optics);
  info.viewCount = block.viewCount;
  info.brightnessMin = 0;
  info.brightnessMax = block.brightnessMax;
  const bool wantsRgb = info.subpixels != SubpixelLayout::Mono;
  if (!(block.formats & (wantsRgb ? 0x2 : 0x1)))
    fail(Errc::Device, "{}: device info format mask 0x{:02x} lacks the {} format its {} panel needs", name_,
         block.formats, wantsRgb ? "RGB888" : "Mono8", toString(info.subpixels));
  try {
    info.validate();
  } catch (const Error& e) {
    fail(Errc::Device, "{}: calibration read from the device is invalid: {}", name_, e.what());
  }
  info_ = info;
  format_ = wantsRgb ? proto::Format::Rgb888 : proto::Format::Mono8;
}

// Raw synchronous control transfer on the vendor interface; returns bytes or a libusb error.
int UsbDisplay::control(int direction, proto::Request request, std::uint16_t value, unsigned char* data,
                        std::uint16_t length) {
  const std::uint8_t type = direction == LIBUSB_ENDPOINT_IN ? proto::kRequestTypeIn : proto::kRequestTypeOut;
  const int rc = libusb_control_transfer(handle_, type, static_cast<std::uint8_t>(request), value,
                                         static_cast<std::uint16_t>(interface_), data, length,
                                         static_cast<unsigned>(options_.controlTimeout.count()));
  traceDriverCall("usb", name_, proto::toString(request),
                  fmt::format("value {} length {}: {}", value, length, rc < 0 ? libusb_error_name(rc) : "ok"));
  return rc;
}

// CLEAR_FEATURE(ENDPOINT_HALT) of the frame endpoint, which also resets the
// device's receive state. False, with the reason in clearHaltError_, when
// the device did not answer: until it does, it may hold part of a frame, so
// the next frame tries again first. (libusb has no timeout for it: on Linux
// the kernel gives up after 5 s and that comes back as LIBUSB_ERROR_OTHER.)
// A refusal (LIBUSB_ERROR_PIPE and the like) is Errc::Device.
bool UsbDisplay::clearHalt() {
  const int rc = libusb_clear_halt(handle_, endpoint_);
  traceDriverCall("usb", name_, "CLEAR_HALT", rc < 0 ? libusb_error_name(rc) : "ok");
  if (rc == LIBUSB_ERROR_NO_DEVICE) vanished("CLEAR_HALT");
  resync_ = rc != 0;
  if (rc == 0) return true;
  clearHaltError_ = libusb_error_name(rc);
  if (rc != LIBUSB_ERROR_TIMEOUT && rc != LIBUSB_ERROR_OTHER)  // a refusal: trying again would not help
    fail(Errc::Device, "{}: CLEAR_HALT on endpoint 0x{:02x} refused: {}", name_, endpoint_, clearHaltError_);
  return false;
}

void UsbDisplay::requireOk(int rc, proto::Request request) {
  if (rc >= 0) return;
  if (rc == LIBUSB_ERROR_NO_DEVICE) vanished(proto::toString(request));
  if (rc == LIBUSB_ERROR_TIMEOUT)
    fail(Errc::Timeout, "{}: control request {} timed out after {} ms (the device does not answer)", name_,
         proto::toString(request), options_.controlTimeout.count());
  if (rc == LIBUSB_ERROR_PIPE)
    fail(Errc::Device, "{}: the device refused control request {} (stall)", name_, proto::toString(request));
  fail(Errc::Device, "{}: control request {} failed: {}", name_, proto::toString(request), libusb_error_name(rc));
}

std::vector<std::uint8_t> UsbDisplay::controlIn(proto::Request request, std::uint16_t value, std::size_t length) {
  std::vector<std::uint8_t> buffer(length);
  const int rc = control(LIBUSB_ENDPOINT_IN, request, value, buffer.data(), static_cast<std::uint16_t>(length));
  requireOk(rc, request);
  buffer.resize(std::min<std::size_t>(static_cast<std::size_t>(rc), length));
  return buffer;
}

// The device's last error; with `rejected`, the frame it should be about (a
// device that gives none, or one about another frame, is said to).
std::string UsbDisplay::lastErrorText(std::optional<std::uint32_t> rejected) {
  const proto::LastError last =
      proto::decodeLastError(controlIn(proto::Request::GetLastError, 0, 8 + proto::kMaxErrorText), name_);
  if (rejected && last.code == proto::DeviceError::None) return "the device gives no reason for it";
  const std::string reason =
      fmt::format("{} (code {}, frame {}){}{}", proto::toString(last.code), static_cast<unsigned>(last.code),
                  last.sequence, last.message.empty() ? "" : ": ", last.message);
  if (rejected && (last.sequence & 0xffff) != (*rejected & 0xffff))
    return fmt::format("its last error concerns another frame: {}", reason);
  return reason;
}

std::string UsbDisplay::rejection(std::uint32_t sequence) {
  const std::string reason = lastErrorText(sequence);
  return fmt::format("{}: PRESENT of frame {} refused by the device: {}", name_, sequence, reason);
}

[[noreturn]] void UsbDisplay::vanished(const std::string& request) {
  const std::string name = name_;
  state_ = State::Closed;  // (close() sends nothing to a device that is gone)
  close();
  fail(Errc::Device, "{}: the device vanished during {}; the display is closed, open() it again when it is back", name,
       request);
}

}  // namespace detail

std::unique_ptr<Display> openUsbDisplay(const UsbDisplaySelector& selector, const UsbDisplayOptions& options) {
  auto display = std::make_unique<detail::UsbDisplay>(selector, options);
  display->open();
  return display;
}

}  // namespace lfi
