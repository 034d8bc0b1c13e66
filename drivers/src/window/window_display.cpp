// SPDX-License-Identifier: Apache-2.0
// The `window:` display: this side of the presenter (presenter_protocol.h). It
// starts lfi-window-presenter, maps the frame buffer it hands over, writes each
// panel image into it in the output's layout and waits for the present.
#include "lfi/drivers/window/window_display.h"

#include "lfi/core/error.h"
#include "lfi/drivers/display_calibration_file.h"
#include "lfi/drivers/driver_trace.h"
#include "presenter_process.h"
#include "presenter_protocol.h"

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <utility>

namespace lfi {

namespace {

using window::PresenterErrc;
using window::PresenterMessage;
using window::PresenterOp;
using window::PresenterProcess;

Errc toErrc(PresenterErrc e) {
  switch (e) {
    case PresenterErrc::NotFound:
      return Errc::NotFound;
    case PresenterErrc::Config:
      return Errc::Config;
    case PresenterErrc::Device:
      break;
  }
  return Errc::Device;
}

// Distinct directions under one lens (slit) along a panel row: what the optics give at this pitch.
int viewsUnderALens(const DisplayOpticsParams& o, double pitch_mm) {
  const double views = fullParallax(o.type) ? o.arrayPitch_mm / pitch_mm : o.lensPitch_px;
  return std::isfinite(views) ? std::max(1, static_cast<int>(views)) : 1;
}

class WindowDisplay final : public Display {
 public:
  explicit WindowDisplay(WindowDisplayOptions options) : options_(std::move(options)), name_(options_.uri()) {}
  ~WindowDisplay() override { close(); }

  State state() const override { return state_; }
  std::string name() const override { return name_; }

  void open() override {
    requireDisplayState(state_, {State::Closed}, "open", name_);
    std::vector<std::string> args = {"--output", options_.output, "--vsync", options_.vsync ? "1" : "0"};
    if (options_.modeWidth_px)
      args.insert(args.end(), {"--mode", std::to_string(*options_.modeWidth_px) + "x" +
                                             std::to_string(options_.modeHeight_px.value_or(0))});
    presenter_ = PresenterProcess::start(options_.presenter, args, name_);
    int frameFd = -1;
    const PresenterMessage ready = presenter_->receive(options_.timeout, "open the window", &frameFd);
    if (ready.op != PresenterOp::Ready) {
      const std::string why(ready.textView());
      presenter_.reset();
      fail(toErrc(ready.errc), "{}: {}", name_, why);
    }
    if (frameFd < 0 || ready.width_px <= 0 || ready.height_px <= 0) {
      presenter_.reset();
      fail(Errc::Device, "{}: the presenter's ready message lacks the frame buffer or the mode", name_);
    }
    const std::size_t bytes = static_cast<std::size_t>(ready.width_px) * static_cast<std::size_t>(ready.height_px) * 3;
    void* frame = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, frameFd, 0);
    ::close(frameFd);
    if (frame == MAP_FAILED) {
      presenter_.reset();
      fail(Errc::Device, "{}: cannot map the frame buffer ({} bytes): {}", name_, bytes, std::strerror(errno));
    }
    frame_ = cv::Mat(ready.height_px, ready.width_px, CV_8UC3, frame);
    try {
      info_ = describe(ready);
    } catch (const Error&) {
      close();
      throw;
    }
    traceDriverCall("window", name_, "presenter",
                    fmt::format("{} output '{}' {}x{} at {} mHz, vsync {}", ready.driver, ready.textView(),
                                ready.width_px, ready.height_px, ready.refresh_mHz, ready.vsync ? "on" : "off"));
    state_ = State::Open;
    framesPresented_ = 0;
    lastPresent_.reset();
  }

  void close() noexcept override {
    presenter_.reset();  // the presenter ends when its socket closes; the window goes with it
    if (!frame_.empty()) ::munmap(frame_.data, frame_.total() * frame_.elemSize());
    frame_ = cv::Mat();
    state_ = State::Closed;
  }

  DisplayInfo info() const override {
    requireDisplayState(state_, {State::Open, State::Showing}, "info", name_);
    return info_;
  }

  PresentResult show(const cv::Mat& panel) override {
    requireDisplayState(state_, {State::Open, State::Showing}, "show", name_);
    requirePanelImage(info_, panel, name_);
    switch (options_.layout) {
      case WindowLayout::Rgb:
        panel.copyTo(frame_);
        break;
      case WindowLayout::Bgr:
        cv::cvtColor(panel, frame_, cv::COLOR_BGR2RGB);
        break;
      case WindowLayout::Mono:
        cv::cvtColor(panel, frame_, cv::COLOR_GRAY2RGB);
        break;
      case WindowLayout::MonoSubpixels:  // three mono pixels are one RGB pixel's bytes, in order
        panel.reshape(3, panel.rows).copyTo(frame_);
        break;
    }
    const std::uint32_t sequence = ++sequence_;
    present(PresenterOp::Show, sequence);
    state_ = State::Showing;
    PresentResult result;
    result.status = PresentStatus::Presented;
    result.sequence = sequence;
    return result;
  }

  void blank() override {
    requireDisplayState(state_, {State::Open, State::Showing}, "blank", name_);
    present(PresenterOp::Blank, ++sequence_);
    state_ = State::Open;
  }

  void setBrightness(int level) override {
    requireDisplayState(state_, {State::Open, State::Showing}, "setBrightness", name_);
    if (level != 255)
      fail(Errc::InvalidArgument, "{}: brightness {} is not 255: a monitor's backlight is set on the monitor", name_,
           level);
  }

  // Asks the presenter, which asks its display server: a server, output or window gone since the last frame
  // is a Device error here, before anything relies on the panel still showing.
  DisplayStatus status() override {
    requireDisplayState(state_, {State::Open, State::Showing}, "status", name_);
    PresenterMessage request;
    request.op = PresenterOp::Status;
    try {
      presenter_->send(request);
      const PresenterMessage reply = presenter_->receive(options_.timeout, "answer");
      if (reply.op != PresenterOp::Status)
        fail(reply.op == PresenterOp::Lost || reply.op == PresenterOp::Failed ? toErrc(reply.errc) : Errc::Device,
             "{}: {}", name_,
             reply.op == PresenterOp::Presented ? std::string("the presenter answered a frame nobody sent")
                                                : std::string(reply.textView()));
    } catch (const Error&) {
      close();
      throw;
    }
    DisplayStatus s;
    s.showing = state_ == State::Showing;
    s.presentedSequence = presentedSequence_;
    s.framesPresented = framesPresented_;
    s.brightness = 255;
    s.lastPresent = lastPresent_;
    return s;
  }

 private:
  // The panel on the output in its mode, as the options describe it.
  DisplayInfo describe(const PresenterMessage& ready) const {
    DisplayInfo info;
    info.vendor = ready.driver;
    info.model = std::string(ready.textView());
    info.deviceId = options_.output;
    const bool subpixelPanel = options_.layout == WindowLayout::MonoSubpixels;
    info.panelWidth_px = ready.width_px * (subpixelPanel ? 3 : 1);
    info.panelHeight_px = ready.height_px;
    info.pixelPitch_mm = options_.pixelPitch_mm;
    info.subpixels = options_.layout == WindowLayout::Rgb   ? SubpixelLayout::RgbStripe
                     : options_.layout == WindowLayout::Bgr ? SubpixelLayout::BgrStripe
                                                            : SubpixelLayout::Mono;
    info.opticsStated = !options_.opticsFile.empty();
    if (info.opticsStated) info.optics = readDisplayOpticsFile(options_.opticsFile, DisplayOpticsParams{});
    info.viewCount = info.opticsStated ? viewsUnderALens(info.optics, info.pixelPitch_mm) : 1;
    // (A monitor's backlight is its own: lfi drives the pixels only.)
    info.brightnessMin = info.brightnessMax = 255;
    return info;
  }

  // Has the presenter present the frame buffer (or black) and waits for it.
  void present(PresenterOp op, std::uint32_t sequence) {
    PresenterMessage request;
    request.op = op;
    request.sequence = sequence;
    try {
      presenter_->send(request);
      const PresenterMessage reply = presenter_->receive(options_.timeout, "present the frame");
      if (reply.op != PresenterOp::Presented || reply.sequence != sequence)
        fail(reply.op == PresenterOp::Failed || reply.op == PresenterOp::Lost ? toErrc(reply.errc) : Errc::Device,
             "{}: {}", name_,
             reply.op == PresenterOp::Presented ? std::string("the presenter answered for another frame")
                                                : std::string(reply.textView()));
      traceDriverCall("window", name_, op == PresenterOp::Show ? "present" : "present black",
                      fmt::format("frame {} at {} ns", sequence, reply.presentTime_ns));
      presentedSequence_ = sequence;
      ++framesPresented_;
      lastPresent_ = std::chrono::steady_clock::time_point(std::chrono::nanoseconds(reply.presentTime_ns));
    } catch (const Error&) {
      close();
      throw;
    }
  }

  WindowDisplayOptions options_;
  std::string name_;
  State state_ = State::Closed;
  std::unique_ptr<PresenterProcess> presenter_;
  DisplayInfo info_;
  cv::Mat frame_;  // the shared frame buffer, RGB24
  std::uint32_t sequence_ = 0;
  std::uint32_t presentedSequence_ = 0;
  std::uint64_t framesPresented_ = 0;
  std::optional<std::chrono::steady_clock::time_point> lastPresent_;
};

}  // namespace

const char* toString(WindowLayout layout) {
  switch (layout) {
    case WindowLayout::Rgb:
      return "rgb";
    case WindowLayout::Bgr:
      return "bgr";
    case WindowLayout::Mono:
      return "mono";
    case WindowLayout::MonoSubpixels:
      return "mono_subpixels";
  }
  return "?";
}

WindowLayout parseWindowLayout(std::string_view word, const std::string& uriForMessages) {
  for (WindowLayout l : {WindowLayout::Rgb, WindowLayout::Bgr, WindowLayout::Mono, WindowLayout::MonoSubpixels})
    if (word == toString(l)) return l;
  fail(Errc::Config, "display URI '{}': layout '{}' is none of rgb, bgr, mono, mono_subpixels", uriForMessages, word);
}

std::string WindowDisplayOptions::uri() const {
  return "window:" + output;
}

std::string WindowOutput::uri() const {
  return "window:" + std::to_string(index);
}

std::unique_ptr<Display> openWindowDisplay(const WindowDisplayOptions& options) {
  auto display = std::make_unique<WindowDisplay>(options);
  display->open();
  return display;
}

}  // namespace lfi
