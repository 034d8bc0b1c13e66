#include "lfi/drivers/usb/usb_display.h"

#include "lfi/drivers/display_calibration_file.h"

#include "lfi/core/error.h"
#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/usb/usb_display_protocol.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <libusb.h>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <optional>
#include <vector>

namespace lfi {
namespace {

namespace proto = usbdisplay;
using Clock = std::chrono::steady_clock;

std::uint16_t parseHex16(std::string_view text, const char* what, const std::string& uri) {
  unsigned value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value, 16);
  if (text.size() != 4 || ec != std::errc() || end != text.data() + text.size())
    fail(Errc::Config, "display URI '{}': {} '{}' is not 4 hex digits (expected usb:<vid>:<pid>[/<serial>])", uri,
         what, text);
  return static_cast<std::uint16_t>(value);
}

// The device's serial number string (ASCII), or "" when it has none or it
// cannot be read (then `error` is libusb's error code).
std::string serialOf(libusb_device_handle* handle, const libusb_device_descriptor& desc, int& error) {
  error = 0;
  if (desc.iSerialNumber == 0) return {};
  unsigned char text[256] = {};
  const int n = libusb_get_string_descriptor_ascii(handle, desc.iSerialNumber, text, sizeof(text) - 1);
  if (n < 0) error = n;
  return n > 0 ? std::string(reinterpret_cast<char*>(text), static_cast<std::size_t>(n)) : std::string();
}

// A serial as it stands in a URI ('/' too: the serial follows the ids after one).
std::string serialInUri(std::string_view serial) { return percentEncodeUriPart(serial, "/"); }

SubpixelLayout toLayout(proto::SubpixelCode code) {
  switch (code) {
    case proto::SubpixelCode::RgbStripe: return SubpixelLayout::RgbStripe;
    case proto::SubpixelCode::BgrStripe: return SubpixelLayout::BgrStripe;
    case proto::SubpixelCode::Mono: break;
  }
  return SubpixelLayout::Mono;
}

// One bulk OUT transfer of a frame and the state its callback fills in.
struct Chunk {
  libusb_transfer* transfer = nullptr;
  bool submitted = false;
  bool done = false;
  bool cancelled = false;
  libusb_transfer_status status = LIBUSB_TRANSFER_COMPLETED;
  int actual = 0;
  int length = 0;
};

void LIBUSB_CALL onChunkDone(libusb_transfer* transfer) {
  auto* chunk = static_cast<Chunk*>(transfer->user_data);
  chunk->done = true;
  chunk->status = transfer->status;
  chunk->actual = transfer->actual_length;
}

enum class BulkOutcome { Ok, Stall, Timeout, NoDevice, Error };

class UsbDisplay final : public Display {
public:
  UsbDisplay(UsbDisplaySelector selector, UsbDisplayOptions options)
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
      fail(Errc::InvalidArgument, "{}: timeouts must be 1 .. 600000 ms and stallRetries >= 0 (control {} ms, "
           "transfer {} ms, stallRetries {})", name_, options_.controlTimeout.count(),
           options_.transferTimeout.count(), options_.stallRetries);
  }
  ~UsbDisplay() override { close(); }

  State state() const override { return state_; }
  std::string name() const override { return name_; }

  void open() override {
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
        fail(Errc::Timeout, "{}: CLEAR_HALT of endpoint 0x{:02x} got no answer ({}): the device does not answer",
             name_, endpoint_, clearHaltError_);
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

  void close() noexcept override {
    if (handle_) {
      // The panel goes dark, as after blank() (best effort: a device that does
      // not answer keeps its frame until the next open() blanks it).
      if (claimed_ && state_ == State::Showing)
        control(LIBUSB_ENDPOINT_OUT, proto::Request::Blank, 0, nullptr, 0);
      if (claimed_) libusb_release_interface(handle_, interface_);
      libusb_close(handle_);
    }
    handle_ = nullptr;
    claimed_ = false;
    if (ctx_) libusb_exit(ctx_);
    ctx_ = nullptr;
    state_ = State::Closed;
  }

  DisplayInfo info() const override {
    requireDisplayState(state_, {State::Open, State::Showing}, "info", name_);
    return info_;
  }

  PresentResult show(const cv::Mat& panel) override {
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
                          "failed ({}); the next frame tries again", name_, endpoint_, clearHaltError_)};

    for (int attempt = 0;; ++attempt) {
      std::size_t sent = 0;
      const BulkOutcome outcome = sendFrame(sent);
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
      fail(Errc::Device, "{}: bulk OUT of frame {} to endpoint 0x{:02x} failed ({} of {} bytes sent)", name_,
           sequence, endpoint_, sent, frame_.size());
    }

    const int rc = control(LIBUSB_ENDPOINT_OUT, proto::Request::Present, static_cast<std::uint16_t>(sequence),
                           nullptr, 0);
    if (rc == LIBUSB_ERROR_PIPE) return {PresentStatus::Rejected, sequence, rejection(sequence)};
    resync_ = rc < 0;  // unanswered or failed: the device may still hold the frame
    uncertain_ = rc < 0;  // (and may show it)
    requireOk(rc, proto::Request::Present);
    state_ = State::Showing;
    lastPresented_ = sequence;
    return {PresentStatus::Presented, sequence, {}};
  }

  void blank() override {
    requireDisplayState(state_, {State::Open, State::Showing}, "blank", name_);
    const int rc = control(LIBUSB_ENDPOINT_OUT, proto::Request::Blank, 0, nullptr, 0);
    uncertain_ = rc < 0;  // (it may have blanked)
    requireOk(rc, proto::Request::Blank);
    state_ = State::Open;
  }

  void setBrightness(int level) override {
    requireDisplayState(state_, {State::Open, State::Showing}, "setBrightness", name_);
    if (level < info_.brightnessMin || level > info_.brightnessMax)
      fail(Errc::InvalidArgument, "{}: brightness {} is outside {}..{}", name_, level, info_.brightnessMin,
           info_.brightnessMax);
    requireOk(control(LIBUSB_ENDPOINT_OUT, proto::Request::SetBrightness, static_cast<std::uint16_t>(level), nullptr,
                      0),
              proto::Request::SetBrightness);
  }

  DisplayStatus status() override {
    requireDisplayState(state_, {State::Open, State::Showing}, "status", name_);
    const proto::StatusBlock s =
        proto::decodeStatus(controlIn(proto::Request::GetStatus, 0, proto::kStatusSize), name_);
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

private:
  void openDevice() {
    libusb_device** list = nullptr;
    const ssize_t count = libusb_get_device_list(ctx_, &list);
    if (count < 0) fail(Errc::Device, "{}: cannot list USB devices: {}", name_, libusb_error_name(int(count)));
    std::vector<std::string> seen;
    std::vector<std::pair<libusb_device_handle*, std::string>> matches;
    int lastOpenError = 0, lastSerialError = 0, unopened = 0;
    for (ssize_t i = 0; i < count; ++i) {
      libusb_device_descriptor desc{};
      if (libusb_get_device_descriptor(list[i], &desc) != 0) continue;
      seen.push_back(fmt::format("{:04x}:{:04x}", desc.idVendor, desc.idProduct));
      if (desc.idVendor != selector_.vendorId || desc.idProduct != selector_.productId) continue;
      libusb_device_handle* handle = nullptr;
      if (const int rc = libusb_open(list[i], &handle); rc != 0) {
        lastOpenError = rc;
        ++unopened;
        continue;
      }
      int unreadable = 0;
      const std::string serial = serialOf(handle, desc, unreadable);
      if (!selector_.serial.empty() && serial != selector_.serial) {
        if (unreadable != 0) lastSerialError = unreadable;
        seen.back() += unreadable != 0 ? "/(serial unreadable)" : "/" + serialInUri(serial);  // as the URI names it
        libusb_close(handle);
        continue;
      }
      matches.emplace_back(handle, serial);
    }
    libusb_free_device_list(list, 1);
    if (matches.empty()) {
      if (lastOpenError == LIBUSB_ERROR_ACCESS)
        fail(Errc::NotFound, "{}: the device is present but cannot be opened: permission denied (udev rules?)", name_);
      if (lastOpenError != 0)
        fail(Errc::NotFound, "{}: the device is present but cannot be opened: {}", name_,
             libusb_error_name(lastOpenError));
      if (lastSerialError != 0)
        fail(Errc::NotFound, "{}: a device {:04x}:{:04x} is present but its serial cannot be read: {}", name_,
             selector_.vendorId, selector_.productId, libusb_error_name(lastSerialError));
      fail(Errc::NotFound, "{}: no such USB device (present: {})", name_,
           seen.empty() ? std::string("none") : fmt::format("{}", fmt::join(seen, ", ")));
    }
    // Without a serial, a second display that cannot be opened still makes the choice ambiguous: opening the
    // other one silently could drive the wrong panel.
    if (matches.size() == 1 && unopened > 0 && selector_.serial.empty()) {
      libusb_close(matches.front().first);
      fail(Errc::Config, "{}: {} displays match, {} of them cannot be opened ({}); name one by serial "
           "(usb:{:04x}:{:04x}/<serial>; this one's: {})", name_, unopened + 1, unopened,
           libusb_error_name(lastOpenError), selector_.vendorId, selector_.productId,
           serialInUri(matches.front().second));
    }
    if (matches.size() > 1) {
      std::vector<std::string> serials;
      for (auto& [h, s] : matches) {
        serials.push_back(serialInUri(s));
        libusb_close(h);
      }
      fail(Errc::Config, "{}: {} displays match; name one by serial (usb:{:04x}:{:04x}/<serial>, serials: {})", name_,
           matches.size(), selector_.vendorId, selector_.productId, fmt::join(serials, ", "));
    }
    handle_ = matches.front().first;
    serial_ = matches.front().second;

    libusb_config_descriptor* config = nullptr;
    if (const int rc = libusb_get_active_config_descriptor(libusb_get_device(handle_), &config); rc != 0)
      fail(Errc::Device, "{}: cannot read the configuration descriptor: {}", name_, libusb_error_name(rc));
    bool found = false;
    int altSetting = 0;
    for (int i = 0; i < config->bNumInterfaces && !found; ++i) {
      for (int a = 0; a < config->interface[i].num_altsetting && !found; ++a) {
        const libusb_interface_descriptor& alt = config->interface[i].altsetting[a];
        if (alt.bInterfaceClass != proto::kInterfaceClass || alt.bInterfaceSubClass != proto::kInterfaceSubclass)
          continue;
        for (int e = 0; e < alt.bNumEndpoints; ++e) {
          const libusb_endpoint_descriptor& ep = alt.endpoint[e];
          if ((ep.bmAttributes & 0x3) == LIBUSB_TRANSFER_TYPE_BULK && (ep.bEndpointAddress & 0x80) == 0) {
            interface_ = alt.bInterfaceNumber;
            altSetting = alt.bAlternateSetting;
            endpoint_ = ep.bEndpointAddress;
            found = true;
            break;
          }
        }
      }
    }
    libusb_free_config_descriptor(config);
    if (!found)
      fail(Errc::Device, "{}: no vendor interface (class 0x{:02x}, subclass 0x{:02x}) with a bulk OUT endpoint", name_,
           proto::kInterfaceClass, proto::kInterfaceSubclass);
    if (const int rc = libusb_claim_interface(handle_, interface_); rc != 0) {
      if (rc == LIBUSB_ERROR_NO_DEVICE) vanished("CLAIM_INTERFACE");
      fail(Errc::Device, "{}: cannot claim interface {}: {}{}", name_, interface_, libusb_error_name(rc),
           rc != LIBUSB_ERROR_BUSY ? ""
           : wedged_ ? " (this process still holds it: transfers of an earlier frame never completed nor were "
                       "cancelled; restart the process)"
                     : " (another program, or another display object of this process, has it)");
    }
    claimed_ = true;
    if (altSetting != 0)  // the endpoint is in an alternate setting: select it
      if (const int rc = libusb_set_interface_alt_setting(handle_, interface_, altSetting); rc != 0) {
        if (rc == LIBUSB_ERROR_NO_DEVICE) vanished("SET_INTERFACE");
        fail(Errc::Device, "{}: cannot select alternate setting {} of interface {}: {}", name_, altSetting,
             interface_, libusb_error_name(rc));
      }
  }

  void readIdentity() {
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
    info.deviceId = serial_.empty() ? fmt::format("{:04x}:{:04x}", selector_.vendorId, selector_.productId)
                                    : fmt::format("{:04x}:{:04x}/{}", selector_.vendorId, selector_.productId,
                                                  serialInUri(serial_));
    info.panelWidth_px = block.panelWidth_px;
    info.panelHeight_px = block.panelHeight_px;
    info.pixelPitch_mm = cal.pixelPitch_mm;
    info.subpixels = toLayout(block.subpixels);
    info.optics.type = cal.optics == proto::OpticsCode::Barrier ? OpticsType::Barrier : OpticsType::Lenslet;
    info.optics.lensPitch_px = cal.lensPitch_px;
    info.optics.slant_rad = cal.slant_rad;
    info.optics.offset_px = cal.offset_px;
    info.optics.gap_mm = cal.gap_mm;
    info.optics.focalLength_mm = cal.focalLength_mm;
    info.optics.slitWidth_mm = cal.slitWidth_mm;
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
  int control(int direction, proto::Request request, std::uint16_t value, unsigned char* data, std::uint16_t length) {
    const std::uint8_t type = direction == LIBUSB_ENDPOINT_IN ? proto::kRequestTypeIn : proto::kRequestTypeOut;
    return libusb_control_transfer(handle_, type, static_cast<std::uint8_t>(request), value,
                                   static_cast<std::uint16_t>(interface_), data, length,
                                   static_cast<unsigned>(options_.controlTimeout.count()));
  }

  // CLEAR_FEATURE(ENDPOINT_HALT) of the frame endpoint, which also resets the
  // device's receive state. False, with the reason in clearHaltError_, when
  // the device did not answer: until it does, it may hold part of a frame, so
  // the next frame tries again first. (libusb has no timeout for it: on Linux
  // the kernel gives up after 5 s and that comes back as LIBUSB_ERROR_OTHER.)
  // A refusal (LIBUSB_ERROR_PIPE and the like) is Errc::Device.
  bool clearHalt() {
    const int rc = libusb_clear_halt(handle_, endpoint_);
    if (rc == LIBUSB_ERROR_NO_DEVICE) vanished("CLEAR_HALT");
    resync_ = rc != 0;
    if (rc == 0) return true;
    clearHaltError_ = libusb_error_name(rc);
    if (rc != LIBUSB_ERROR_TIMEOUT && rc != LIBUSB_ERROR_OTHER)  // a refusal: trying again would not help
      fail(Errc::Device, "{}: CLEAR_HALT on endpoint 0x{:02x} refused: {}", name_, endpoint_, clearHaltError_);
    return false;
  }

  void requireOk(int rc, proto::Request request) {
    if (rc >= 0) return;
    if (rc == LIBUSB_ERROR_NO_DEVICE) vanished(proto::toString(request));
    if (rc == LIBUSB_ERROR_TIMEOUT)
      fail(Errc::Timeout, "{}: control request {} timed out after {} ms (the device does not answer)", name_,
           proto::toString(request), options_.controlTimeout.count());
    if (rc == LIBUSB_ERROR_PIPE)
      fail(Errc::Device, "{}: the device refused control request {} (stall)", name_, proto::toString(request));
    fail(Errc::Device, "{}: control request {} failed: {}", name_, proto::toString(request), libusb_error_name(rc));
  }

  std::vector<std::uint8_t> controlIn(proto::Request request, std::uint16_t value, std::size_t length) {
    std::vector<std::uint8_t> buffer(length);
    const int rc = control(LIBUSB_ENDPOINT_IN, request, value, buffer.data(), static_cast<std::uint16_t>(length));
    requireOk(rc, request);
    buffer.resize(std::min<std::size_t>(static_cast<std::size_t>(rc), length));
    return buffer;
  }

  // The device's last error; with `rejected`, the frame it should be about (a
  // device that gives none, or one about another frame, is said to).
  std::string lastErrorText(std::optional<std::uint32_t> rejected = std::nullopt) {
    const std::vector<std::uint8_t> reply =
        controlIn(proto::Request::GetLastError, 0, 8 + proto::kMaxErrorText);
    if (reply.size() < 8)
      fail(Errc::Device, "{}: GET_LAST_ERROR returned {} bytes, expected at least 8", name_, reply.size());
    const auto code = static_cast<proto::DeviceError>(proto::getU32(reply.data()));
    const std::uint32_t frame = proto::getU32(reply.data() + 4);
    std::string text;
    for (std::size_t i = 8; i < reply.size(); ++i)
      text.push_back(reply[i] >= 0x20 && reply[i] <= 0x7e ? static_cast<char>(reply[i]) : '?');
    if (rejected && code == proto::DeviceError::None) return "the device gives no reason for it";
    const std::string reason = fmt::format("{} (code {}, frame {}){}{}", proto::toString(code),
                                           static_cast<unsigned>(code), frame, text.empty() ? "" : ": ", text);
    if (rejected && (frame & 0xffff) != (*rejected & 0xffff))
      return fmt::format("its last error concerns another frame: {}", reason);
    return reason;
  }

  std::string rejection(std::uint32_t sequence) {
    const std::string reason = lastErrorText(sequence);
    return fmt::format("{}: PRESENT of frame {} refused by the device: {}", name_, sequence, reason);
  }

  [[noreturn]] void vanished(const std::string& request) {
    const std::string name = name_;
    state_ = State::Closed;  // (close() sends nothing to a device that is gone)
    close();
    fail(Errc::Device, "{}: the device vanished during {}; the display is closed, open() it again when it is back",
         name, request);
  }

  void buildFrame(const cv::Mat& panel, std::uint32_t sequence) {
    const std::size_t rowBytes = static_cast<std::size_t>(panel.cols) * panel.elemSize();
    const std::size_t payload = rowBytes * static_cast<std::size_t>(panel.rows);
    frame_.resize(proto::kFrameHeaderSize + payload);
    std::uint8_t* out = frame_.data() + proto::kFrameHeaderSize;
    for (int r = 0; r < panel.rows; ++r) std::memcpy(out + r * rowBytes, panel.ptr<std::uint8_t>(r), rowBytes);
    proto::FrameHeader header;
    header.sequence = sequence;
    header.format = format_;
    header.width = static_cast<std::uint16_t>(panel.cols);
    header.height = static_cast<std::uint16_t>(panel.rows);
    header.payloadSize = static_cast<std::uint32_t>(payload);
    header.payloadCrc = proto::crc32Of({out, payload});
    const std::vector<std::uint8_t> bytes = proto::encodeFrameHeader(header);
    std::memcpy(frame_.data(), bytes.data(), bytes.size());
  }

  // Sends frame_ as bulk transfers, several in flight; cancels the rest on the first failure.
  BulkOutcome sendFrame(std::size_t& sent) {
    const std::size_t size = options_.transferSize_bytes;
    const std::size_t count = (frame_.size() + size - 1) / size;
    std::vector<Chunk> chunks(count);
    BulkOutcome outcome = BulkOutcome::Ok;
    bool outOfMemory = false;  // reported once the transfers in flight are drained, not while libusb holds `chunks`
    std::size_t next = 0, inFlight = 0;
    // A guard above libusb's own per-transfer timeouts, in case a cancellation never completes.
    auto deadline =
        Clock::now() + options_.transferTimeout * static_cast<int>(count + options_.transfersInFlight + 1) +
        std::chrono::seconds(2);
    auto record = [&](BulkOutcome o) {
      if (outcome == BulkOutcome::Ok || o == BulkOutcome::NoDevice) outcome = o;
    };
    while (true) {
      while (outcome == BulkOutcome::Ok && next < count &&
             inFlight < static_cast<std::size_t>(options_.transfersInFlight)) {
        Chunk& c = chunks[next];
        c.length = static_cast<int>(std::min(size, frame_.size() - next * size));
        c.transfer = libusb_alloc_transfer(0);
        if (!c.transfer) {
          outOfMemory = true;
          record(BulkOutcome::Error);
          break;
        }
        // libusb times a transfer from its submission, and the device takes the queued ones in turn: a chunk
        // gets transferTimeout for itself and for each one queued before it.
        const auto timeout = options_.transferTimeout * static_cast<int>(inFlight + 1);
        libusb_fill_bulk_transfer(c.transfer, handle_, endpoint_, frame_.data() + next * size, c.length, onChunkDone,
                                  &c, static_cast<unsigned>(timeout.count()));
        const int rc = libusb_submit_transfer(c.transfer);
        ++next;
        if (rc != 0) {
          c.done = true;
          record(rc == LIBUSB_ERROR_NO_DEVICE ? BulkOutcome::NoDevice
                                              : rc == LIBUSB_ERROR_PIPE ? BulkOutcome::Stall : BulkOutcome::Error);
          break;
        }
        c.submitted = true;
        ++inFlight;
      }
      if (inFlight == 0 && (outcome != BulkOutcome::Ok || next == count)) break;
      timeval tv{0, 50'000};
      const int rc = libusb_handle_events_timeout_completed(ctx_, &tv, nullptr);
      if (rc == LIBUSB_ERROR_NO_DEVICE) record(BulkOutcome::NoDevice);
      for (Chunk& c : chunks) {
        if (!c.submitted || !c.done) continue;
        c.submitted = false;
        --inFlight;
        if (c.status == LIBUSB_TRANSFER_COMPLETED && c.actual == c.length) {
          sent += static_cast<std::size_t>(c.actual);
          continue;
        }
        switch (c.status) {
          case LIBUSB_TRANSFER_STALL: record(BulkOutcome::Stall); break;
          case LIBUSB_TRANSFER_TIMED_OUT: record(BulkOutcome::Timeout); break;
          case LIBUSB_TRANSFER_NO_DEVICE: record(BulkOutcome::NoDevice); break;
          case LIBUSB_TRANSFER_CANCELLED:  // we cancelled it after another one failed, or the system did
            if (!c.cancelled) record(BulkOutcome::Error);  // (a hole in the frame: never PRESENT it)
            break;
          default: record(BulkOutcome::Error); break;
        }
      }
      if (outcome != BulkOutcome::Ok && inFlight > 0) {
        for (Chunk& c : chunks) {
          if (c.submitted && !c.done && !c.cancelled) {
            libusb_cancel_transfer(c.transfer);
            c.cancelled = true;
          }
        }
      }
      if (Clock::now() > deadline) {
        // The frame was not all sent in time (the host stalled, say): never PRESENT it. Transfers in flight are
        // cancelled above on the next turn and get a last second to come back.
        if (outcome == BulkOutcome::Ok && (next < count || inFlight > 0)) {
          record(BulkOutcome::Timeout);
          deadline = Clock::now() + std::chrono::seconds(1);
          continue;
        }
        if (inFlight > 0) {
          // Transfers that neither complete nor cancel: libusb still owns them, so they
          // (and the context) must not be freed; give the device up.
          for (Chunk& c : chunks) c.transfer = nullptr;
          handle_ = nullptr;
          ctx_ = nullptr;
          claimed_ = false;
          wedged_ = true;
          state_ = State::Closed;
          fail(Errc::Device, "{}: bulk OUT transfers neither completed nor cancelled within the deadline; the "
                             "display is closed", name_);
        }
        break;
      }
    }
    for (Chunk& c : chunks)
      if (c.transfer) libusb_free_transfer(c.transfer);
    if (outcome == BulkOutcome::Ok && (next != count || sent != frame_.size()))  // (cannot happen: said, not PRESENTed)
      fail(Errc::Device, "{}: {} of the frame's {} bytes sent, reported complete (a defect in lfi)", name_, sent,
           frame_.size());
    if (outOfMemory) {
      resync_ = true;  // the device may hold the transfers sent before
      fail(Errc::Device, "{}: libusb_alloc_transfer failed (out of memory)", name_);
    }
    return outcome;
  }

  UsbDisplaySelector selector_;
  UsbDisplayOptions options_;
  std::string name_;
  std::string serial_;
  libusb_context* ctx_ = nullptr;
  libusb_device_handle* handle_ = nullptr;
  bool claimed_ = false;
  int interface_ = 0;
  std::uint8_t endpoint_ = proto::kFrameEndpoint;
  proto::Format format_ = proto::Format::Mono8;
  DisplayInfo info_;
  State state_ = State::Closed;
  std::uint32_t sequence_ = 0;
  std::uint32_t lastPresented_ = 0;  // the sequence of the last frame presented (State::Showing)
  bool uncertain_ = false;  // a PRESENT or BLANK went unanswered: the device may show either (status() trusts it)
  std::uint64_t stallsCleared_ = 0;
  bool resync_ = false;  // a frame failed or timed out: clear the endpoint's halt before the next one
  std::string clearHaltError_;  // why the last CLEAR_HALT failed (libusb's error name)
  bool wedged_ = false;  // given up with transfers libusb still owns (sendFrame's deadline)
  std::vector<std::uint8_t> frame_;
};

}  // namespace

std::string UsbDisplaySelector::uri() const {
  return serial.empty() ? fmt::format("usb:{:04x}:{:04x}", vendorId, productId)
                        : fmt::format("usb:{:04x}:{:04x}/{}", vendorId, productId, serialInUri(serial));
}

UsbDisplaySelector parseUsbDisplayPath(std::string_view path, const std::string& uri) {
  UsbDisplaySelector s;
  const std::size_t slash = path.find('/');
  const std::string_view ids = path.substr(0, slash);
  const std::size_t colon = ids.find(':');
  if (colon == std::string_view::npos)
    fail(Errc::Config, "display URI '{}': expected usb:<vid>:<pid>[/<serial>] with 4 hex digits each", uri);
  s.vendorId = parseHex16(ids.substr(0, colon), "vendor id", uri);
  s.productId = parseHex16(ids.substr(colon + 1), "product id", uri);
  if (slash != std::string_view::npos) {
    s.serial = std::string(path.substr(slash + 1));  // (decoded with the rest of the URI: it may hold a '/')
    if (s.serial.empty() || s.serial.size() > 126)
      fail(Errc::Config, "display URI '{}': the serial must be 1..126 bytes, not {} (write a space, '/', '%', '?', "
           "'&', '#', '=' or a non-ASCII byte as %XX)", uri, s.serial.size());
  }
  return s;
}

std::vector<UsbDisplayInfo> listUsbDisplays() {
  libusb_context* ctx = nullptr;
  if (const int rc = libusb_init(&ctx); rc != 0) fail(Errc::Device, "USB displays: libusb_init failed: {}",
                                                      libusb_error_name(rc));
  libusb_device** list = nullptr;
  const ssize_t count = libusb_get_device_list(ctx, &list);
  if (count < 0) {
    libusb_exit(ctx);
    fail(Errc::Device, "USB displays: cannot list USB devices: {}", libusb_error_name(int(count)));
  }
  std::vector<UsbDisplayInfo> displays;
  for (ssize_t i = 0; i < count; ++i) {
    libusb_device_descriptor desc{};
    libusb_config_descriptor* config = nullptr;
    if (libusb_get_device_descriptor(list[i], &desc) != 0 || libusb_get_active_config_descriptor(list[i], &config) != 0)
      continue;
    bool display = false;
    for (int k = 0; k < config->bNumInterfaces && !display; ++k)
      for (int a = 0; a < config->interface[k].num_altsetting && !display; ++a)
        display = config->interface[k].altsetting[a].bInterfaceClass == proto::kInterfaceClass &&
                  config->interface[k].altsetting[a].bInterfaceSubClass == proto::kInterfaceSubclass;
    libusb_free_config_descriptor(config);
    if (!display) continue;
    UsbDisplayInfo info;
    info.selector.vendorId = desc.idVendor;
    info.selector.productId = desc.idProduct;
    info.bus = libusb_get_bus_number(list[i]);
    info.address = libusb_get_device_address(list[i]);
    libusb_device_handle* handle = nullptr;
    if (const int rc = libusb_open(list[i], &handle); rc != 0) {
      info.problem = rc == LIBUSB_ERROR_ACCESS ? "permission denied (udev rules?)" : libusb_error_name(rc);
    } else {
      int unreadable = 0;
      info.selector.serial = serialOf(handle, desc, unreadable);
      if (unreadable != 0) info.problem = fmt::format("its serial cannot be read: {}", libusb_error_name(unreadable));
      libusb_close(handle);
    }
    displays.push_back(std::move(info));
  }
  libusb_free_device_list(list, 1);
  libusb_exit(ctx);
  return displays;
}

std::unique_ptr<Display> openUsbDisplay(const UsbDisplaySelector& selector, const UsbDisplayOptions& options) {
  auto display = std::make_unique<UsbDisplay>(selector, options);
  display->open();
  return display;
}

}  // namespace lfi
