// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to the Aravis backend: the Camera implementation's class and the helpers its
// files share (error checking, the wire pixel formats, discovery under Aravis's lock).

#include "lfi/drivers/aravis/aravis_camera.h"

#include "lfi/core/error.h"

#include <arv.h>
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace lfi::detail {

// Not in Aravis 0.8's arvenums.h; PFNC value.
constexpr ArvPixelFormat kPixelFormatMono12p = 0x010C0047u;

// The wire formats that give each of our pixel formats, in order of
// preference: GenICam name and PFNC code.
struct WireFormat {
  const char* name;
  ArvPixelFormat code;
};
std::vector<WireFormat> wireFormats(PixelFormat format);
std::vector<std::string> wireFormatNames(PixelFormat format);

std::string orEmpty(const char* s);

void check(GError* error, const std::string& device, const std::string& call);

// Aravis's process-wide device list is not thread-safe: discovery and opening hold this.
std::mutex& aravisMutex();

// Discovery (aravis_discovery.cpp). The ...Locked ones, and knownToAravis, need aravisMutex() held.
std::vector<AravisDeviceInfo> listDevicesLocked(bool update);
bool knownToAravis(const std::string& id);
bool discoverLocked(const std::string& id);
bool isIpv4Address(const std::string& text);
std::string describe(const std::vector<AravisDeviceInfo>& devices);
// `camera`, or (when it is a GigE Vision device at one of this host's own
// addresses reached through another interface) one reaching it through 127.0.0.1.
ArvCamera* throughLoopbackIfOwnAddress(ArvCamera* camera, const std::string& name);

class AravisCamera final : public Camera {
 public:
  AravisCamera(std::string deviceId, AravisOptions options) : deviceId_(std::move(deviceId)), options_(options) {
    open();
  }

  ~AravisCamera() override { close(); }

  State state() const override { return state_; }

  void open() override;
  void close() noexcept override;
  CameraInfo info() const override;
  void configure(const CameraSettings& s) override;
  void apply(const CameraSettings& s);
  CameraSettings settings() const override;
  void start(int bufferCount) override;
  void startStream(int bufferCount);
  void stop() override;
  void softwareTrigger() override;
  void grabInto(Frame& frame, std::chrono::milliseconds timeout) override;
  StreamStatistics statistics() const override;
  std::string getFeature(const std::string& feature) override;
  void setFeature(const std::string& feature, const std::string& value) override;
  std::int64_t getIntegerFeature(const std::string& feature) override;
  void setIntegerFeature(const std::string& feature, std::int64_t value) override;
  double getFloatFeature(const std::string& feature) override;
  void setFloatFeature(const std::string& feature, double value) override;
  void executeCommand(const std::string& feature) override;

 private:
  void connectDevice();

  static void onControlLost(ArvDevice*, gpointer flag) { static_cast<std::atomic<bool>*>(flag)->store(true); }

  // Aravis hands the buffers to its stream thread and back through GAsyncQueues,
  // which ThreadSanitizer does not see: released before every push, acquired on
  // the stream thread when it takes a buffer, is the hand-over it sees.
  static void onStreamEvent(void* self, ArvStreamCallbackType type, ArvBuffer*) {
    if (type == ARV_STREAM_CALLBACK_TYPE_START_BUFFER)
      static_cast<AravisCamera*>(self)->buffersPushed_.load(std::memory_order_acquire);
  }

  std::string name() const { return deviceId_.empty() ? std::string("(the first camera found)") : deviceId_; }

  void releaseDevice() noexcept;
  [[noreturn]] void declareLost(const std::string& why);

  // Runs a request to the device: a device error from a device that no longer
  // answers at all closes the camera (camera.h: a device that vanishes ends
  // in Closed), as a grab or stop() that finds it gone does.
  template <typename Call>
  auto onDevice(Call&& call) -> decltype(call()) {
    try {
      return call();
    } catch (const Error& e) {
      if (e.code() != Errc::Device || deviceAnswers()) throw;
      declareLost(fmt::format("{} (it does not answer control requests)", e.what()));
    }
  }

  bool deviceAnswers();
  void readInfo();
  void readSensorSize();
  ArvGcFeatureNode* featureNode(const char* method, const std::string& feature);
  std::vector<std::string> availablePixelFormats() const;
  void applyPixelFormat(PixelFormat format);
  void applyBinning(int binning);
  void checkIncrement(const char* field, int value, int increment, int min, int max) const;
  void applyRegion(const CameraSettings& s);

  static bool setsFrameRate(const CameraSettings& s) { return s.trigger == TriggerMode::FreeRun && s.frameRate_hz > 0; }

  std::pair<double, double> exposureBounds() const;
  void applyExposureAndGain(const CameraSettings& s);
  void setFrameRateCap(bool on);
  void applyFrameRate(const CameraSettings& s);
  void applyTrigger(const CameraSettings& s);
  std::optional<std::string> copyImage(ArvBuffer* buffer, cv::Mat& out) const;
  StreamStatistics readStatistics() const;

  std::string deviceId_;
  AravisOptions options_;
  State state_ = State::Closed;
  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  gulong controlLostHandler_ = 0;
  std::atomic<bool> controlLost_ = false;  // set from Aravis's heartbeat thread
  // Released before each buffer is pushed, acquired by onStreamEvent on the stream thread.
  std::atomic<bool> buffersPushed_ = false;
  bool lost_ = false;
  std::string gvcpIp_;
  std::uint16_t gvcpPort_ = 3956;
  CameraInfo info_;
  CameraSettings settings_;
  // What settings() read from the device while streaming: the region is locked then and the
  // automatic controls are off, so it holds until stop() or a feature written through this object
  // (a register read over USB3 Vision takes 0.1-0.2 ms, and the controller asks at every part).
  mutable std::optional<CameraSettings> streamSettings_;
  StreamStatistics statistics_;
  int frameWidth_ = 0, frameHeight_ = 0;  // the region start() found: every frame must be of it
  std::size_t framePayload_ = 0;          // and the bytes of each buffer
  std::uint32_t framePixelFormat_ = 0;    // and the PFNC format the device sends
};

}  // namespace lfi::detail
