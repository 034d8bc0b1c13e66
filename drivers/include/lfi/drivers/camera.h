// SPDX-License-Identifier: Apache-2.0
#pragma once
// The bench camera as the rest of the stack sees it: a GenICam-style area-scan
// camera delivering monochrome frames. Backends (Aravis, the ray-traced `sim:`
// camera) implement this interface and are opened by URI (camera_registry.h).
//
// State machine (every backend follows it; docs/camera.md draws it):
//
//            open()             configure()             start()
//   Closed ─────────► Open ─────────────► Configured ─────────► Streaming
//      ▲                │   ◄─ configure() ─┘   ▲                  │
//      │                │                       └───── stop() ─────┘
//      └──── close() from any state; a device that vanishes also ends in Closed
//
// A camera returned by openCamera() is Open. Calling a method in a state it does
// not list throws lfi::Error(Errc::InvalidArgument) naming the method and the
// state. Units: exposure in microseconds, timestamps in nanoseconds, sizes in
// pixels of the sensor (after binning where said), pixel size in micrometres.

#include <opencv2/core.hpp>

#include <chrono>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>

namespace lfi {

// What the camera is. Sizes are the full sensor, unbinned.
struct CameraInfo {
  std::string vendor;
  std::string model;
  std::string serial;
  std::string deviceId;  // the backend's id, the part after "<scheme>:" that reopens this camera
  int sensorWidth_px = 0;
  int sensorHeight_px = 0;
  std::optional<double> pixelSize_um;  // sensor pixel pitch, when the device reports it
};

// Pixel formats the stack uses. Mono8 → CV_8UC1; Mono12 and Mono16 → CV_16UC1
// (Mono12 in the low 12 bits, whatever the wire format: unpacked, Mono12Packed or
// Mono12p). Values are raw digital numbers, never rescaled.
enum class PixelFormat { Mono8, Mono12, Mono16 };

// FreeRun: frames at frameRate_hz. Software: one frame per softwareTrigger().
// Line: one frame per edge on the hardware input settings.triggerLine.
enum class TriggerMode { FreeRun, Software, Line };

const char* toString(PixelFormat format);
// The bits of a pixel's value: 8, 12 or 16 (full scale 2^bits − 1 DN).
int significantBits(PixelFormat format);
const char* toString(TriggerMode mode);

// Acquisition settings. The region of interest is in binned pixels, relative to
// the top-left of the binned sensor; width/height 0 mean "to the sensor edge".
struct CameraSettings {
  double exposure_us = 10'000;
  double gain = 0;  // in the device's gain unit (SFNC: dB); auto gain and auto exposure are switched off
  PixelFormat pixelFormat = PixelFormat::Mono8;
  int roiX_px = 0;
  int roiY_px = 0;
  int roiWidth_px = 0;
  int roiHeight_px = 0;
  int binning = 1;  // same factor horizontally and vertically
  TriggerMode trigger = TriggerMode::FreeRun;
  std::string triggerLine = "Line0";  // only for TriggerMode::Line
  double frameRate_hz = 0;            // FreeRun only; 0 leaves the device's rate
};

// Per-frame outcome, a value (docs/contributing.md). Incomplete: packets were lost and
// not recovered; the image has the right size but the lost parts are undefined.
// Timeout: nothing arrived in time; the image is not meaningful.
enum class FrameStatus { Complete, Incomplete, Timeout };

const char* toString(FrameStatus status);

struct Frame {
  cv::Mat image;                   // CV_8UC1 or CV_16UC1, see PixelFormat
  std::uint64_t timestamp_ns = 0;  // device clock when the device has one, else host clock at arrival
  std::uint64_t frameId = 0;       // device's frame (block) counter; consecutive frames differ by 1
  FrameStatus status = FrameStatus::Timeout;
};

// Counters since the last start(); kept after stop() until the next start().
struct StreamStatistics {
  std::uint64_t completed = 0;  // frames delivered complete
  std::uint64_t failed = 0;     // frames delivered incomplete or dropped by the transport
  // Lost because no buffer was free (the caller grabbed too slowly, or buffers held frames waiting for
  // resends): frames for sim:, packets for aravis: (Aravis counts each packet of a frame it had no buffer for).
  std::uint64_t underruns = 0;
  std::uint64_t resentPackets = 0;   // packets recovered by resend requests (GigE Vision)
  std::uint64_t missingPackets = 0;  // packets never recovered (GigE Vision)
};

// A camera device. Non-copyable, non-movable: one object owns one device.
// Methods are not thread-safe; drive a camera from one thread.
class Camera {
 public:
  enum class State { Closed, Open, Configured, Streaming };

  Camera() = default;
  Camera(const Camera&) = delete;
  Camera& operator=(const Camera&) = delete;
  Camera(Camera&&) = delete;
  Camera& operator=(Camera&&) = delete;
  virtual ~Camera() = default;

  // Any state.
  virtual State state() const = 0;

  // Closed → Open: (re)connects to the device named at creation. Throws
  // Errc::NotFound when the device is not there.
  virtual void open() = 0;

  // Any state → Closed: stops streaming, releases the device. Never throws.
  virtual void close() noexcept = 0;

  // Open, Configured, Streaming.
  virtual CameraInfo info() const = 0;

  // Open, Configured → Configured. Applies every field; a value the device
  // refuses (out of range, not a multiple of its increment, format not offered)
  // throws naming the field and the device's limits; the state is then Open.
  virtual void configure(const CameraSettings& settings) = 0;

  // Configured, Streaming: the settings as the device applied them (exposure and
  // frame rate may be rounded by the device). While streaming, a backend may read
  // them from the device once per stream: they change only through this object.
  virtual CameraSettings settings() const = 0;

  // Configured → Streaming with a pool of `bufferCount` (>= 1) frame buffers,
  // allocated here once and reused for every frame.
  virtual void start(int bufferCount) = 0;

  // Streaming → Configured. Frames not yet grabbed are dropped.
  virtual void stop() = 0;

  // Streaming, with TriggerMode::Software: asks for exactly one frame.
  virtual void softwareTrigger() = 0;

  // Streaming: waits up to `timeout` for the next frame and writes it into
  // `frame`, reusing frame.image's memory when its size and type fit (no
  // allocation per frame). Timeouts and incomplete frames are frame.status
  // values. A device that stopped answering throws Errc::Device (the camera is
  // then Closed); how long detecting that may add beyond `timeout` is backend
  // specific and documented there.
  virtual void grabInto(Frame& frame, std::chrono::milliseconds timeout) = 0;

  // Streaming: grabInto() into a fresh Frame.
  Frame grab(std::chrono::milliseconds timeout) {
    Frame frame;
    grabInto(frame, timeout);
    return frame;
  }

  // Configured, Streaming.
  virtual StreamStatistics statistics() const = 0;

  // Any GenICam feature by name (Open, Configured, Streaming). The string forms
  // work for every feature type (enumerations by entry name, booleans as
  // "true"/"false"). An unknown feature throws Errc::NotFound; a value the device
  // refuses throws Errc::InvalidArgument or Errc::Device.
  virtual std::string getFeature(const std::string& name) = 0;
  virtual void setFeature(const std::string& name, const std::string& value) = 0;
  virtual std::int64_t getIntegerFeature(const std::string& name) = 0;
  virtual void setIntegerFeature(const std::string& name, std::int64_t value) = 0;
  virtual double getFloatFeature(const std::string& name) = 0;
  virtual void setFloatFeature(const std::string& name, double value) = 0;
  virtual void executeCommand(const std::string& name) = 0;
};

const char* toString(Camera::State state);

// For backends: throws Errc::InvalidArgument "<device>: <method> is not allowed in
// state <state> (allowed: ...)" unless `current` is one of `allowed`.
void requireCameraState(Camera::State current, std::initializer_list<Camera::State> allowed, const char* method,
                        const std::string& device);

// For backends' configure, before their own ranges: throws Errc::InvalidArgument
// naming the device and the field unless the exposure is finite and > 0, the
// gain finite, the binning >= 1, no ROI value negative, the frame rate finite
// and >= 0 (whatever the trigger mode) and TriggerMode::Line names a line.
void requireSaneSettings(const CameraSettings& settings, const std::string& device);

// For backends' grabInto: throws Errc::InvalidArgument for a negative timeout;
// returns it at most a year, so that "forever" (milliseconds::max()) added to
// a clock does not overflow.
std::chrono::milliseconds checkedGrabTimeout(std::chrono::milliseconds timeout, const std::string& device);

}  // namespace lfi
