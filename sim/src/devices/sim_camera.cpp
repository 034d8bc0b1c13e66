// SPDX-License-Identifier: Apache-2.0
// The ray-traced camera backend (sim_camera.h): a state machine over SimImager
// with a simulated frame clock and buffer pool, so that timing, underruns and
// software triggers behave like a streaming device's.

#include "lfi/sim/devices/sim_camera.h"

#include "lfi/sim/devices/sim_light_field_capture.h"

#include "lfi/core/error.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/sim/devices/sim_bench.h"
#include "lfi/sim/devices/sim_display.h"
#include "lfi/sim/render.h"
#include "lfi/sim/scene.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <mutex>
#include <thread>

namespace lfi::sim {

namespace fs = std::filesystem;

std::uint64_t frameNoiseSeed(std::uint64_t sceneSeed, std::uint64_t frameId) {
  return splitMix64(splitMix64(sceneSeed) ^ frameId);
}

SimImager::SimImager(const fs::path& sceneFile) : sceneFile_(sceneFile) {
  const std::string name = DeviceUri{.scheme = "sim", .path = sceneFile.string()}.text();  // (a URI that opens it)
  bench_ = SimBench::open(sceneFile, fmt::format("camera '{}'", name));
  description_ = bench_->description();
  const auto* camera = std::get_if<TelecentricCamera>(&description_.sensor);
  if (camera == nullptr)
    fail(Errc::Config, "camera '{}': the scene has a [light_field_sensor], the sim camera needs a [camera]", name);
  camera_ = *camera;
  scene_ = std::make_unique<Scene>(std::move(description_.objects), description_.ambientIor);
  description_.objects.clear();
}

SimImager::~SimImager() = default;

void SimImager::setRenderOptions(int threads, std::function<void(double)> progress) {
  renderThreads_ = threads;
  renderProgress_ = std::move(progress);
}

CameraSettings SimImager::resolve(const CameraSettings& s, const std::string& device) const {
  const Limits limits;
  requireSaneSettings(s, device);
  CameraSettings r = s;
  if (!(s.exposure_us >= limits.minExposure_us && s.exposure_us <= limits.maxExposure_us))
    fail(Errc::InvalidArgument, "camera '{}': exposure_us {} is outside {}..{} us", device, s.exposure_us,
         limits.minExposure_us, limits.maxExposure_us);
  if (!(s.gain >= limits.minGain_dB && s.gain <= limits.maxGain_dB))
    fail(Errc::InvalidArgument, "camera '{}': gain {} is outside {}..{} dB", device, s.gain, limits.minGain_dB,
         limits.maxGain_dB);
  if (s.binning < 1 || s.binning > limits.maxBinning || camera_.width / s.binning < 1 || camera_.height / s.binning < 1)
    fail(Errc::InvalidArgument, "camera '{}': binning {} is outside 1..{} (sensor {} x {})", device, s.binning,
         limits.maxBinning, camera_.width, camera_.height);
  const int width = camera_.width / s.binning, height = camera_.height / s.binning;
  r.roiWidth_px = s.roiWidth_px > 0 ? s.roiWidth_px : width - s.roiX_px;
  r.roiHeight_px = s.roiHeight_px > 0 ? s.roiHeight_px : height - s.roiY_px;
  if (r.roiWidth_px < 1 || r.roiHeight_px < 1 || r.roiWidth_px > width - s.roiX_px ||
      r.roiHeight_px > height - s.roiY_px)
    fail(Errc::InvalidArgument, "camera '{}': ROI ({}, {}, {} x {}) does not fit the {} x {} (binned) sensor", device,
         s.roiX_px, s.roiY_px, r.roiWidth_px, r.roiHeight_px, width, height);
  if (s.trigger == TriggerMode::Line)
    fail(Errc::InvalidArgument,
         "camera '{}': TriggerMode::Line asked, the sim camera has no trigger lines "
         "(FreeRun, Software)",
         device);
  if (s.trigger == TriggerMode::FreeRun) {
    if (s.frameRate_hz == 0) r.frameRate_hz = limits.defaultFrameRate_hz;
    if (!(r.frameRate_hz >= limits.minFrameRate_hz && r.frameRate_hz <= limits.maxFrameRate_hz))
      fail(Errc::InvalidArgument, "camera '{}': frameRate_hz {} is outside {}..{} Hz (0: the default, {} Hz)", device,
           s.frameRate_hz, limits.minFrameRate_hz, limits.maxFrameRate_hz, limits.defaultFrameRate_hz);
  }
  return r;
}

const SensorPattern& SimImager::pattern(int binning) {
  if (auto it = patterns_.find(binning); it != patterns_.end()) return it->second;
  return patterns_.emplace(binning, sensorPattern(description_.cameraSensor, camera_.width, camera_.height, binning))
      .first->second;
}

CameraSensorModel SimImager::sensorModel(const CameraSettings& s) {
  const CameraSensorParameters& p = description_.cameraSensor;
  const double pixels = static_cast<double>(s.binning) * s.binning;
  CameraSensorModel model;
  model.fullWell_e = p.fullWell_e * pixels;
  model.readNoise_e = p.readNoise_e;
  model.bitDepth = p.bitDepth;
  model.electronsPerUnit = p.electronsPerUnitPerUs * s.exposure_us * pixels;
  model.gain = std::pow(10.0, s.gain / 20);
  if (const cv::Mat& offset = pattern(s.binning).offset_dn; !offset.empty())
    model.offset_dn = offset(cv::Rect(s.roiX_px, s.roiY_px, s.roiWidth_px, s.roiHeight_px));
  return model;
}

const cv::Mat& SimImager::radiance(int binning, const SimBench::DisplayState* display) {
  std::shared_ptr<const SimBench::DisplayState> now;
  if (display == nullptr) display = (now = bench_->displayState()).get();
  const auto key = std::make_pair(display->version, binning);
  if (auto it = radiance_.find(key); it != radiance_.end()) return it->second;
  // Keep this version's radiance and the newest other version's (the display
  // now, or the frames exposed before it changed).
  std::uint64_t kept = 0;
  for (const auto& [k, image] : radiance_)
    if (k.first != display->version) kept = std::max(kept, k.first);
  std::erase_if(radiance_,
                [&](const auto& entry) { return entry.first.first != display->version && entry.first.first != kept; });
  SimBench::applyDisplay(*scene_, description_.displayObject, *display);
  const TelecentricCamera binned = camera_.binned(binning);
  RenderOptions options = description_.render;
  options.threads = renderThreads_;
  options.progress = renderProgress_;
  const auto t0 = std::chrono::steady_clock::now();
  cv::Mat image = render(*scene_, binned, options);
  if (const cv::Mat& response = pattern(binning).response; !response.empty()) image = image.mul(response);
  spdlog::debug("sim camera '{}': rendered {} x {} (binning {}) in {:.2f} s", sceneFile_.string(), binned.width,
                binned.height, binning, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return radiance_.emplace(key, std::move(image)).first->second;
}

void SimImager::capture(const CameraSettings& s, std::uint64_t frameId, cv::Mat& out,
                        const SimBench::DisplayState* display) {
  const CameraSensorModel model = sensorModel(s);
  const cv::Mat& full = radiance(s.binning, display);
  const cv::Mat roi = full(cv::Rect(s.roiX_px, s.roiY_px, s.roiWidth_px, s.roiHeight_px));
  const cv::Mat dn = model.capture(roi, frameNoiseSeed(seed(), frameId), renderThreads_);
  // The ADC's bit_depth bits, aligned to the format's most significant bits.
  const int shift = model.bitDepth - significantBits(s.pixelFormat);
  const int type = s.pixelFormat == PixelFormat::Mono8 ? CV_8UC1 : CV_16UC1;
  if (!out.empty() && (out.u == nullptr || out.u->refcount > 1 || !out.isContinuous() || out.isSubmatrix()))
    out.release();  // a caller still holds the previous image: do not overwrite it
  out.create(dn.rows, dn.cols, type);
  for (int r = 0; r < dn.rows; ++r) {
    const auto* in = dn.ptr<std::uint16_t>(r);
    if (type == CV_8UC1) {
      auto* o = out.ptr<std::uint8_t>(r);
      for (int c = 0; c < dn.cols; ++c) o[c] = static_cast<std::uint8_t>(in[c] >> shift);  // bit depth >= 8
    } else {
      auto* o = out.ptr<std::uint16_t>(r);
      for (int c = 0; c < dn.cols; ++c)
        o[c] = static_cast<std::uint16_t>(shift >= 0 ? in[c] >> shift : in[c] << -shift);
    }
  }
}

namespace {

using Clock = std::chrono::steady_clock;

class SimCamera final : public Camera {
 public:
  explicit SimCamera(fs::path sceneFile) : sceneFile_(std::move(sceneFile)) { open(); }
  ~SimCamera() override { close(); }

  State state() const override { return state_; }

  void open() override {
    requireCameraState(state_, {State::Closed}, "open", name());
    imager_ = std::make_unique<SimImager>(sceneFile_);
    nextFrameId_ = 1;
    const TelecentricCamera& cam = imager_->camera();
    info_ = CameraInfo{
        .vendor = "lfi",
        .model = "SimCamera",
        .serial = imager_->sceneName(),
        .deviceId = percentEncodeUriPart(sceneFile_.string()),  // (reopens it after "sim:")
        .sensorWidth_px = cam.width,
        .sensorHeight_px = cam.height,
        .pixelSize_um = cam.pixelPitch_mm * 1000,
    };
    settings_ = imager_->resolve(CameraSettings{}, name());
    state_ = State::Open;
  }

  void close() noexcept override {
    displayChanges_.reset();
    queue_.clear();
    imager_.reset();
    state_ = State::Closed;
  }

  CameraInfo info() const override {
    requireCameraState(state_, {State::Open, State::Configured, State::Streaming}, "info", name());
    return info_;
  }

  void configure(const CameraSettings& s) override {
    requireCameraState(state_, {State::Open, State::Configured}, "configure", name());
    state_ = State::Open;  // until every field is accepted
    settings_ = imager_->resolve(s, name());
    state_ = State::Configured;
  }

  CameraSettings settings() const override {
    requireCameraState(state_, {State::Configured, State::Streaming}, "settings", name());
    return settings_;
  }

  void start(int bufferCount) override {
    requireCameraState(state_, {State::Configured}, "start", name());
    if (bufferCount < 1 || bufferCount > 1024)
      fail(Errc::InvalidArgument, "camera '{}': start(bufferCount = {}) needs 1..1024 buffers", name(), bufferCount);
    imager_->radiance(settings_.binning);  // render now, not in the first grab
    // Before the display changes, the frames exposed until then are taken with
    // it as it was. Listening before the stream starts, so that no change falls
    // between the two (one before the start concerns no frame).
    listening_ = false;  // (no listener yet: an earlier stream's was removed by stop() or close())
    displayChanges_ = imager_->bench().onDisplayChange([this] {
      std::lock_guard lock(mutex_);
      if (listening_) produceDueFrames(Clock::now());
    });
    {
      std::lock_guard lock(mutex_);
      bufferCount_ = static_cast<std::size_t>(bufferCount);
      queue_.clear();
      statistics_ = {};
      produced_ = 0;
      start_ = Clock::now();
      freeRun_ = settings_.trigger == TriggerMode::FreeRun;
      frameRate_hz_ = settings_.frameRate_hz;
      listening_ = true;
    }
    state_ = State::Streaming;
  }

  void stop() override {
    requireCameraState(state_, {State::Streaming}, "stop", name());
    displayChanges_.reset();
    queue_.clear();
    state_ = State::Configured;
  }

  void softwareTrigger() override {
    requireCameraState(state_, {State::Streaming}, "softwareTrigger", name());
    if (settings_.trigger != TriggerMode::Software)
      fail(Errc::InvalidArgument, "camera '{}': softwareTrigger() needs TriggerMode::Software, the camera is in {}",
           name(), toString(settings_.trigger));
    std::lock_guard lock(mutex_);
    enqueue(nextFrameId_++, Clock::now());
  }

  void grabInto(Frame& frame, std::chrono::milliseconds timeout) override {
    requireCameraState(state_, {State::Streaming}, "grab", name());
    timeout = checkedGrabTimeout(timeout, name());
    const Clock::time_point deadline = Clock::now() + timeout;
    std::unique_lock lock(mutex_);
    produceDueFrames(Clock::now());
    if (queue_.empty() && freeRun_) {
      const Clock::time_point due = dueTime(produced_);
      if (due <= deadline) {
        lock.unlock();
        std::this_thread::sleep_until(due);
        lock.lock();
        produceDueFrames(due);
      }
    }
    if (queue_.empty()) {
      lock.unlock();
      std::this_thread::sleep_until(deadline);
      frame.status = FrameStatus::Timeout;
      frame.frameId = 0;
      frame.timestamp_ns = 0;
      return;
    }
    const Queued next = queue_.front();
    queue_.pop_front();
    lock.unlock();
    CameraSettings exposed = settings_;
    exposed.exposure_us = next.exposure_us, exposed.gain = next.gain;
    imager_->capture(exposed, next.frameId, frame.image, next.display.get());
    frame.frameId = next.frameId;
    frame.timestamp_ns = static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(next.time.time_since_epoch()).count());
    frame.status = FrameStatus::Complete;
    lock.lock();
    ++statistics_.completed;
  }

  StreamStatistics statistics() const override {
    requireCameraState(state_, {State::Configured, State::Streaming}, "statistics", name());
    std::lock_guard lock(mutex_);
    return statistics_;
  }

  // A few SFNC features, mapped on the settings. ExposureTime and Gain can be
  // changed at any time (they act on the frames exposed after the change, as
  // on a real camera: frames waiting in the buffers keep theirs); the rest is
  // read-only here (configure() sets it).
  std::string getFeature(const std::string& feature) override {
    requireFeatureState("getFeature");
    const CameraSettings& s = settings_;
    if (feature == "DeviceVendorName") return info_.vendor;
    if (feature == "DeviceModelName") return info_.model;
    if (feature == "DeviceSerialNumber") return info_.serial;
    if (feature == "SensorWidth") return std::to_string(info_.sensorWidth_px);
    if (feature == "SensorHeight") return std::to_string(info_.sensorHeight_px);
    if (feature == "Width") return std::to_string(s.roiWidth_px);
    if (feature == "Height") return std::to_string(s.roiHeight_px);
    if (feature == "OffsetX") return std::to_string(s.roiX_px);
    if (feature == "OffsetY") return std::to_string(s.roiY_px);
    if (feature == "BinningHorizontal" || feature == "BinningVertical") return std::to_string(s.binning);
    if (feature == "PixelFormat") return toString(s.pixelFormat);
    if (feature == "ExposureTime") return fmt::format("{}", s.exposure_us);
    if (feature == "Gain") return fmt::format("{}", s.gain);
    if (feature == "TriggerMode") return s.trigger == TriggerMode::FreeRun ? "Off" : "On";
    if (feature == "TriggerSource") return "Software";
    if (feature == "AcquisitionFrameRate") return fmt::format("{}", s.frameRate_hz);
    fail(Errc::NotFound, "camera '{}': getFeature('{}'): the sim camera has no such feature", name(), feature);
  }

  void setFeature(const std::string& feature, const std::string& value) override {
    requireFeatureState("setFeature");
    requireWritable(feature);  // the name before the value
    setFloatFeature(feature, parseNumber(feature, value));
  }

  std::int64_t getIntegerFeature(const std::string& feature) override {
    return static_cast<std::int64_t>(std::llround(parseNumber(feature, getFeature(feature))));
  }

  void setIntegerFeature(const std::string& feature, std::int64_t value) override {
    setFloatFeature(feature, static_cast<double>(value));
  }

  double getFloatFeature(const std::string& feature) override { return parseNumber(feature, getFeature(feature)); }

  void setFloatFeature(const std::string& feature, double value) override {
    requireFeatureState("setFloatFeature");
    requireWritable(feature);
    CameraSettings s = settings_;
    (feature == "ExposureTime" ? s.exposure_us : s.gain) = value;
    s = imager_->resolve(s, name());
    // The frames exposed until now keep the old exposure and gain (the bench's
    // display-change listener reads settings_ too: under the lock).
    std::lock_guard lock(mutex_);
    if (state_ == State::Streaming) produceDueFrames(Clock::now());
    settings_ = s;
  }

  void executeCommand(const std::string& feature) override {
    requireFeatureState("executeCommand");
    if (feature == "TriggerSoftware") return softwareTrigger();
    fail(Errc::NotFound, "camera '{}': executeCommand('{}'): the sim camera has no such command", name(), feature);
  }

 private:
  struct Queued {
    std::uint64_t frameId;
    Clock::time_point time;
    std::shared_ptr<const SimBench::DisplayState> display;  // as it was when the frame was exposed
    double exposure_us, gain;  // likewise: a frame exposed before ExposureTime or Gain changed keeps the old ones
  };

  std::string name() const { return DeviceUri{.scheme = "sim", .path = sceneFile_.string()}.text(); }  // (reopens it)

  // ExposureTime and Gain are written; other features are NotFound or read-only.
  void requireWritable(const std::string& feature) {
    if (feature == "ExposureTime" || feature == "Gain") return;
    getFeature(feature);  // NotFound for unknown names
    fail(Errc::InvalidArgument, "camera '{}': feature '{}' is read-only on the sim camera (use configure())", name(),
         feature);
  }

  void requireFeatureState(const char* method) const {
    requireCameraState(state_, {State::Open, State::Configured, State::Streaming}, method, name());
  }

  double parseNumber(const std::string& feature, const std::string& text) const {
    try {
      std::size_t used = 0;
      const double value = std::stod(text, &used);
      if (used == text.size()) return value;
    } catch (const std::exception&) {
    }
    fail(Errc::InvalidArgument, "camera '{}': feature '{}': '{}' is not a number", name(), feature, text);
  }

  Clock::time_point dueTime(std::uint64_t index) const {
    return start_ + std::chrono::duration_cast<Clock::duration>(
                        std::chrono::duration<double>(static_cast<double>(index) / frameRate_hz_));
  }

  // A frame the device produced: into a free buffer, or lost (underrun). Under mutex_.
  void enqueue(std::uint64_t frameId, Clock::time_point time) {
    if (queue_.size() < bufferCount_)
      queue_.push_back({frameId, time, imager_->bench().displayState(), settings_.exposure_us, settings_.gain});
    else
      ++statistics_.underruns;
  }

  // The free-running clock: frame k is due at start + k / rate. Under mutex_;
  // also called by the bench just before the display changes.
  void produceDueFrames(Clock::time_point now) {
    if (!freeRun_ || now < start_) return;
    // Frames 0 .. due - 1 are due: those with dueTime(k) <= now. The quotient
    // only guesses `due`; dueTime, the one definition, settles it (it rounds
    // to whole clock ticks, so a wait until dueTime(k) must produce frame k).
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    auto due = static_cast<std::uint64_t>(std::floor(elapsed * frameRate_hz_)) + 1;
    while (due > 0 && dueTime(due - 1) > now) --due;
    while (dueTime(due) <= now) ++due;
    if (due <= produced_) return;
    const std::uint64_t count = due - produced_;
    const std::uint64_t room = bufferCount_ - queue_.size();
    const auto display = imager_->bench().displayState();
    for (std::uint64_t k = 0; k < std::min(count, room); ++k)
      queue_.push_back({nextFrameId_ + k, dueTime(produced_ + k), display, settings_.exposure_us, settings_.gain});
    if (count > room) statistics_.underruns += count - room;
    nextFrameId_ += count;
    produced_ = due;
  }

  fs::path sceneFile_;
  State state_ = State::Closed;
  std::unique_ptr<SimImager> imager_;
  CameraInfo info_;
  CameraSettings settings_;
  // The stream, shared with the bench's change listener (another thread): under mutex_.
  mutable std::mutex mutex_;
  StreamStatistics statistics_;
  std::deque<Queued> queue_;
  std::size_t bufferCount_ = 1;
  std::uint64_t nextFrameId_ = 1;
  std::uint64_t produced_ = 0;  // free-running frames produced since start()
  Clock::time_point start_;
  bool freeRun_ = false;  // settings_ at start(), for the listener
  double frameRate_hz_ = 25;
  std::shared_ptr<void> displayChanges_;  // the bench's change listener while streaming
  bool listening_ = false;                // the stream has started: the listener produces its due frames
};

}  // namespace

std::unique_ptr<Camera> openSimCamera(const fs::path& sceneFile) {
  return std::make_unique<SimCamera>(sceneFile);
}

void registerSimBackends() {
  registerSimDisplayBackend();
  registerSimLightFieldCapture();
  backendRegistry<Camera>().addOnce(CameraBackend{
      .scheme = "sim",
      .keys = {},
      .description = "sim:<scene-file>  ray-traced camera (the scene file's [camera] and [camera_sensor])",
      .factory = [](const DeviceUri& uri) { return openSimCamera(uri.path); },
  });
}

}  // namespace lfi::sim
