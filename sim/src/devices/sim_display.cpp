// SPDX-License-Identifier: Apache-2.0
// The ray-traced display backend (sim_display.h): the Display state machine over
// the shared SimBench's panel.

#include "lfi/sim/devices/sim_display.h"

#include "lfi/core/error.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_bench.h"

#include <fmt/format.h>

namespace lfi::sim {

namespace fs = std::filesystem;

namespace {

class SimDisplay final : public Display {
 public:
  explicit SimDisplay(fs::path sceneFile)
      : sceneFile_(std::move(sceneFile)), name_(DeviceUri{.scheme = "sim", .path = sceneFile_.string()}.text()) {
    open();
  }
  ~SimDisplay() override { close(); }

  State state() const override { return state_; }
  std::string name() const override { return name_; }

  void open() override {
    requireDisplayState(state_, {State::Closed}, "open", name_);
    auto bench = SimBench::open(sceneFile_, fmt::format("display '{}'", name_));
    if (!bench->hasDisplay())
      fail(Errc::Config, "display '{}': the scene file has no [display] table (docs/scene-files.md)", name_);
    if (!bench->claimDisplay())
      fail(Errc::Device,
           "display '{}': already open in this process (one display drives a scene file's panel; "
           "close the other first)",
           name_);
    bench_ = std::move(bench);  // (holds the claim: close() releases it)
    try {
      info_ = bench_->description().display->info;
      info_.serial = bench_->description().name;
      info_.deviceId = percentEncodeUriPart(sceneFile_.string());  // (reopens it after "sim:")
      sequence_ = 0;  // frames count from 1 after each open, as the USB protocol's do
      bench_->blankPanel();
      bench_->setBacklight(info_.brightnessMax);
    } catch (...) {  // (e.g. a camera's change listener failed: the display stays closed, its claim released)
      close();
      throw;
    }
    state_ = State::Open;
  }

  void close() noexcept override {
    if (bench_) {
      try {
        bench_->blankPanel();
      } catch (...) {  // close() does not throw; a change listener (a camera's) that failed is not its business
      }
      bench_->releaseDisplay();
    }
    bench_.reset();
    state_ = State::Closed;
  }

  DisplayInfo info() const override {
    requireDisplayState(state_, {State::Open, State::Showing}, "info", name_);
    return info_;
  }

  PresentResult show(const cv::Mat& panel) override {
    requireDisplayState(state_, {State::Open, State::Showing}, "show", name_);
    requirePanelImage(info_, panel, name_);
    bench_->showPanel(panel);
    ++framesPresented_;
    state_ = State::Showing;
    return {PresentStatus::Presented, ++sequence_, {}};
  }

  void blank() override {
    requireDisplayState(state_, {State::Open, State::Showing}, "blank", name_);
    bench_->blankPanel();
    state_ = State::Open;
  }

  void setBrightness(int level) override {
    requireDisplayState(state_, {State::Open, State::Showing}, "setBrightness", name_);
    if (level < info_.brightnessMin || level > info_.brightnessMax)
      fail(Errc::InvalidArgument, "{}: brightness {} is outside {}..{}", name_, level, info_.brightnessMin,
           info_.brightnessMax);
    bench_->setBacklight(level);
  }

  DisplayStatus status() override {
    requireDisplayState(state_, {State::Open, State::Showing}, "status", name_);
    DisplayStatus s;
    s.showing = state_ == State::Showing;
    s.presentedSequence = sequence_;
    s.framesPresented = framesPresented_;
    s.brightness = bench_->backlight();
    return s;
  }

 private:
  fs::path sceneFile_;
  std::string name_;
  State state_ = State::Closed;
  std::shared_ptr<SimBench> bench_;
  DisplayInfo info_;
  std::uint32_t sequence_ = 0;
  std::uint64_t framesPresented_ = 0;
};

}  // namespace

std::unique_ptr<Display> openSimDisplay(const fs::path& sceneFile) {
  return std::make_unique<SimDisplay>(sceneFile);
}

void registerSimDisplayBackend() {
  backendRegistry<Display>().addOnce(DisplayBackend{
      .scheme = "sim",
      .keys = {},
      .description = "sim:<scene-file>  ray-traced light field display (the scene file's [display])",
      .factory = [](const DeviceUri& uri) { return openSimDisplay(uri.path); },
  });
}

}  // namespace lfi::sim
