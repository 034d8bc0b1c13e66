// SPDX-License-Identifier: Apache-2.0
// The driver trace (driver_trace.h): its file, and the Camera and Display
// wrappers that trace interface calls.

#include "lfi/drivers/driver_trace.h"

#include "lfi/core/log.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <utility>

namespace lfi {

namespace {

constexpr char kHeader[] =
    "# lfi driver trace, version 1: time (s since the Unix epoch), pid, layer "
    "(camera|display|aravis|usb|served), device, call, detail; tab-separated\n";

// The trace file, opened at the first call; -1 when the trace is off.
int traceFile() {
  static const int fd = [] {
    const char* path = std::getenv("LFI_DRIVER_TRACE");
    if (!path || !*path) return -1;
    const int file = ::open(path, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (file < 0) {
      spdlog::warn("LFI_DRIVER_TRACE: cannot open '{}': {}; no driver trace", path, std::strerror(errno));
      return -1;
    }
    struct stat st {};
    if (::fstat(file, &st) == 0 && st.st_size == 0 && ::write(file, kHeader, sizeof kHeader - 1) < 0) {
      // (a trace that cannot be written is no reason to stop a bench; the lines below fail alike)
    }
    return file;
  }();
  return fd;
}

std::string clean(std::string_view text) {
  std::string out(text);
  for (char& c : out)
    if (c == '\t' || c == '\n' || c == '\r') c = ' ';
  return out;
}

// Runs a call and traces it once it returned (so that the backend's own lines
// for it come before it), or its failure when it throws. The overload without
// a detail traces only the failure: its caller traces the outcome.
template <class F>
auto traced(std::string_view layer, const std::string& device, const char* call, F&& f) {
  try {
    return f();
  } catch (const std::exception& e) {
    traceDriverCall(layer, device, call, std::string("failed: ") + e.what());
    throw;
  }
}

template <class F>
void traced(std::string_view layer, const std::string& device, const char* call, const std::string& detail, F&& f) {
  traced(layer, device, call, std::forward<F>(f));
  traceDriverCall(layer, device, call, detail);
}

class TracingCamera final : public Camera {
 public:
  TracingCamera(std::unique_ptr<Camera> camera, std::string uri) : c_(std::move(camera)), uri_(std::move(uri)) {}
  ~TracingCamera() override {
    c_.reset();  // (closes it)
    traceDriverCall("camera", uri_, "close");
  }
  State state() const override { return c_->state(); }
  void open() override {
    traced("camera", uri_, "open", "", [&] { c_->open(); });
  }
  void close() noexcept override {
    c_->close();
    traceDriverCall("camera", uri_, "close");
  }
  CameraInfo info() const override { return c_->info(); }
  void configure(const CameraSettings& s) override {
    traced("camera", uri_, "configure",
           fmt::format("exposure_us={} gain={} format={} binning={} trigger={}", s.exposure_us, s.gain,
                       toString(s.pixelFormat), s.binning, toString(s.trigger)),
           [&] { c_->configure(s); });
  }
  CameraSettings settings() const override { return c_->settings(); }
  void start(int bufferCount) override {
    traced("camera", uri_, "start", fmt::format("buffers={}", bufferCount), [&] { c_->start(bufferCount); });
  }
  void stop() override {
    traced("camera", uri_, "stop", "", [&] { c_->stop(); });
  }
  void softwareTrigger() override {
    traced("camera", uri_, "trigger", "", [&] { c_->softwareTrigger(); });
  }
  void grabInto(Frame& frame, std::chrono::milliseconds timeout) override {
    traced("camera", uri_, "grab", [&] { c_->grabInto(frame, timeout); });
    traceDriverCall("camera", uri_, "grab", fmt::format("{} frame {}", toString(frame.status), frame.frameId));
  }
  StreamStatistics statistics() const override { return c_->statistics(); }
  std::string getFeature(const std::string& name) override { return c_->getFeature(name); }
  void setFeature(const std::string& name, const std::string& value) override {
    traced("camera", uri_, "setFeature", name + "=" + value, [&] { c_->setFeature(name, value); });
  }
  std::int64_t getIntegerFeature(const std::string& name) override { return c_->getIntegerFeature(name); }
  void setIntegerFeature(const std::string& name, std::int64_t value) override {
    traced("camera", uri_, "setFeature", fmt::format("{}={}", name, value),
           [&] { c_->setIntegerFeature(name, value); });
  }
  double getFloatFeature(const std::string& name) override { return c_->getFloatFeature(name); }
  void setFloatFeature(const std::string& name, double value) override {
    traced("camera", uri_, "setFeature", fmt::format("{}={}", name, value), [&] { c_->setFloatFeature(name, value); });
  }
  void executeCommand(const std::string& name) override {
    traced("camera", uri_, "executeCommand", name, [&] { c_->executeCommand(name); });
  }

 private:
  std::unique_ptr<Camera> c_;
  std::string uri_;
};

class TracingDisplay final : public Display {
 public:
  TracingDisplay(std::unique_ptr<Display> display, std::string uri) : d_(std::move(display)), uri_(std::move(uri)) {}
  ~TracingDisplay() override {
    d_.reset();  // (closes it)
    traceDriverCall("display", uri_, "close");
  }
  State state() const override { return d_->state(); }
  std::string name() const override { return d_->name(); }
  void open() override {
    traced("display", uri_, "open", "", [&] { d_->open(); });
  }
  void close() noexcept override {
    d_->close();
    traceDriverCall("display", uri_, "close");
  }
  DisplayInfo info() const override { return d_->info(); }
  PresentResult show(const cv::Mat& panel) override {
    const PresentResult r = traced("display", uri_, "show", [&] { return d_->show(panel); });
    traceDriverCall("display", uri_, "show",
                    fmt::format("{} x {}: {} sequence {}{}{}", panel.cols, panel.rows, toString(r.status), r.sequence,
                                r.message.empty() ? "" : ": ", r.message));
    return r;
  }
  void blank() override {
    traced("display", uri_, "blank", "", [&] { d_->blank(); });
  }
  void setBrightness(int level) override {
    traced("display", uri_, "brightness", std::to_string(level), [&] { d_->setBrightness(level); });
  }
  DisplayStatus status() override {
    const DisplayStatus st = traced("display", uri_, "status", [&] { return d_->status(); });
    traceDriverCall("display", uri_, "status",
                    fmt::format("showing={} sequence={}", st.showing ? 1 : 0, st.presentedSequence));
    return st;
  }

 private:
  std::unique_ptr<Display> d_;
  std::string uri_;
};

}  // namespace

bool driverTraceOn() {
  return traceFile() >= 0;
}

void traceDriverCall(std::string_view layer, std::string_view device, std::string_view call, std::string_view detail) {
  const int fd = traceFile();
  if (fd < 0) return;
  const auto now = std::chrono::system_clock::now().time_since_epoch();
  const std::string line = fmt::format("{:.6f}\t{}\t{}\t{}\t{}\t{}\n", std::chrono::duration<double>(now).count(),
                                       ::getpid(), layer, clean(device), clean(call), clean(detail));
  if (::write(fd, line.data(), line.size()) < 0) {
    // (see traceFile)
  }
}

std::unique_ptr<Camera> traceCalls(std::unique_ptr<Camera> camera, std::string_view uri) {
  if (!driverTraceOn() || !camera) return camera;
  traceDriverCall("camera", uri, "open");
  return std::make_unique<TracingCamera>(std::move(camera), std::string(uri));
}

std::unique_ptr<Display> traceCalls(std::unique_ptr<Display> display, std::string_view uri) {
  if (!driverTraceOn() || !display) return display;
  traceDriverCall("display", uri, "open");
  return std::make_unique<TracingDisplay>(std::move(display), std::string(uri));
}

}  // namespace lfi
