// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to the usb: display backend: the Display implementation's class, its
// methods split over usb_display.cpp (lifecycle and control requests),
// usb_display_discovery.cpp (finding and claiming the device) and usb_frame_upload.cpp.

#include "lfi/drivers/usb/usb_display.h"

#include "lfi/drivers/usb/usb_display_protocol.h"

#include <libusb.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lfi::detail {

namespace proto = usbdisplay;

// The device's serial number string (ASCII), or "" when it has none or it
// cannot be read (then `error` is libusb's error code).
std::string serialOf(libusb_device_handle* handle, const libusb_device_descriptor& desc, int& error);

// A serial as it stands in a URI ('/' too: the serial follows the ids after one).
std::string serialInUri(std::string_view serial);

enum class BulkOutcome { Ok, Stall, Timeout, NoDevice, Error };

class UsbDisplay final : public Display {
 public:
  UsbDisplay(UsbDisplaySelector selector, UsbDisplayOptions options);
  ~UsbDisplay() override;

  State state() const override { return state_; }
  std::string name() const override { return name_; }

  void open() override;
  void close() noexcept override;
  DisplayInfo info() const override;
  PresentResult show(const cv::Mat& panel) override;
  void blank() override;
  void setBrightness(int level) override;
  DisplayStatus status() override;

 private:
  // usb_display_discovery.cpp
  void openDevice();

  // usb_display.cpp
  void readIdentity();
  int control(int direction, proto::Request request, std::uint16_t value, unsigned char* data, std::uint16_t length);
  bool clearHalt();
  void requireOk(int rc, proto::Request request);
  std::vector<std::uint8_t> controlIn(proto::Request request, std::uint16_t value, std::size_t length);
  std::string lastErrorText(std::optional<std::uint32_t> rejected = std::nullopt);
  std::string rejection(std::uint32_t sequence);
  [[noreturn]] void vanished(const std::string& request);

  // usb_frame_upload.cpp
  void buildFrame(const cv::Mat& panel, std::uint32_t sequence);
  BulkOutcome sendFrame(std::size_t& sent);

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
  bool resync_ = false;         // a frame failed or timed out: clear the endpoint's halt before the next one
  std::string clearHaltError_;  // why the last CLEAR_HALT failed (libusb's error name)
  bool wedged_ = false;         // given up with transfers libusb still owns (sendFrame's deadline)
  std::vector<std::uint8_t> frame_;
};

}  // namespace lfi::detail
