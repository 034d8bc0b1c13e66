// SPDX-License-Identifier: Apache-2.0
#pragma once
// The ray-traced camera: "sim:<scene-file>" (docs/camera.md). It renders the
// scene file's [camera] view with the path tracer and turns it into digital
// numbers with the camera sensor model (camera_sensor_model.h, parameters from
// the file's [camera_sensor] table).
//
//   setting        units       range (SimImager::limits)    effect
//   exposure_us    µs          1 .. 10 000 000              electrons = electronsPerUnitPerUs * exposure_us * radiance
//   gain           dB          0 .. 24                      signal x 10^(gain / 20) before quantisation
//   pixelFormat    -           Mono8, Mono12, Mono16        ADC value (bit_depth bits) shifted to the format's bits
//   binning        factor      1 .. 8                       b x b pixels: radiance averaged (rendered at pitch b p),
//                                                           charge summed into a b^2 deeper well, so the DN level
//                                                           stays and shot noise drops by b
//   ROI            binned px   inside the binned sensor     crop of the binned image
//   trigger        -           FreeRun, Software            no hardware lines
//   frameRate_hz   Hz          0 (= 25) .. 1000             FreeRun frame period
//
// Frames are reproducible: frame `frameId` draws its noise from
// frameNoiseSeed(scene seed, frameId), whatever was grabbed before. The scene
// is static between display changes, so its radiance is rendered once per
// binning and per bench version (the expensive part, at the first frame after a
// new binning or after a SimDisplay on the same scene file showed, blanked or
// changed brightness: sim_bench.h) and every frame is a new noise draw on that
// radiance; a ROI is a crop of the binned radiance. A frame shows the display
// as it was when the frame was exposed (at its due time, or its software
// trigger), as a real camera's buffered frames do: frames exposed before a
// show() or blank() and grabbed after it show the old panel. Frame ids start at 1
// when the camera is opened and grow by 1 per frame the "device" produces, across
// stop() and start() (frames the caller was too slow for count as underruns, and
// their ids are skipped): a restarted stream draws new noise, as a real sensor's
// does, instead of repeating the last stream's.
// Timestamps are the host's steady clock in ns at the frame's due time.
// Units and frames: the scene's (mm, world +z towards the camera); image row 0
// is camera -y (sensors.h).

#include "lfi/drivers/camera.h"
#include "lfi/sim/devices/camera_sensor_model.h"
#include "lfi/sim/devices/sensor_pattern.h"
#include "lfi/sim/devices/sim_bench.h"
#include "lfi/sim/scene_file.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>

namespace lfi::sim {

class Scene;

// The per-frame noise seed: a hash of the scene's render seed and the frame id.
std::uint64_t frameNoiseSeed(std::uint64_t sceneSeed, std::uint64_t frameId);

// Scene + sensor → frames for any settings; shared by SimCamera and
// `lfi serve-camera`. Not thread-safe.
class SimImager {
 public:
  struct Limits {
    double minExposure_us = 1, maxExposure_us = 10'000'000;
    double minGain_dB = 0, maxGain_dB = 24;
    int maxBinning = 8;
    double minFrameRate_hz = 1e-3, maxFrameRate_hz = 1000, defaultFrameRate_hz = 25;  // (a frame per 1000 s at least)
  };

  // Opens the scene file's bench (sim_bench.h: shared with a SimDisplay on the same
  // file in this process); throws Errc::NotFound for a missing file, Errc::Config
  // for a bad one or one without [camera].
  explicit SimImager(const std::filesystem::path& sceneFile);
  ~SimImager();
  SimImager(const SimImager&) = delete;
  SimImager& operator=(const SimImager&) = delete;

  static Limits limits() { return {}; }
  const std::string& sceneName() const { return description_.name; }
  const std::filesystem::path& sceneFile() const { return sceneFile_; }
  const TelecentricCamera& camera() const { return camera_; }
  const CameraSensorParameters& sensorParameters() const { return description_.cameraSensor; }
  std::uint64_t seed() const { return description_.render.seed; }

  // The settings with ROI width/height 0 resolved and frameRate_hz 0 set to the
  // default. Throws Errc::InvalidArgument naming `device`, the field and its limits.
  CameraSettings resolve(const CameraSettings& settings, const std::string& device) const;

  // The sensor model for these (resolved) settings: exposure, gain and binning
  // applied, offset_dn the fixed pattern's over the settings' region.
  CameraSensorModel sensorModel(const CameraSettings& settings);

  // The sensor's fixed pattern at a binning (sensor_pattern.h), made at the first call per binning.
  const SensorPattern& pattern(int binning);

  // Relative radiance of the whole binned sensor (CV_32FC1, times the fixed
  // pattern's response) with the display as it is now, or as `display` was, rendered at the first call per binning and
  // display version (this version's and the newest other one's stay cached). The
  // reference is valid until the next call.
  const cv::Mat& radiance(int binning, const SimBench::DisplayState* display = nullptr);

  // Frame `frameId` for resolved `settings`, exposed while the display was in
  // `display` (null: now): CV_8UC1 for Mono8, else CV_16UC1, ROI-sized. Reuses
  // out's memory when it fits.
  void capture(const CameraSettings& settings, std::uint64_t frameId, cv::Mat& out,
               const SimBench::DisplayState* display = nullptr);

  SimBench& bench() const { return *bench_; }

  // Render threads (0 = all cores) and a progress callback for the radiance renders.
  void setRenderOptions(int threads, std::function<void(double)> progress);

 private:
  std::filesystem::path sceneFile_;
  SceneDescription description_;
  TelecentricCamera camera_;
  std::shared_ptr<SimBench> bench_;
  std::unique_ptr<Scene> scene_;
  std::map<std::pair<std::uint64_t, int>, cv::Mat> radiance_;  // by display version and binning
  std::map<int, SensorPattern> patterns_;                      // by binning
  int renderThreads_ = 0;
  std::function<void(double)> renderProgress_;
};

// Opens "sim:<scene-file>" (state Open). Throws Errc::NotFound for a missing
// file, Errc::Config for a bad one.
std::unique_ptr<Camera> openSimCamera(const std::filesystem::path& sceneFile);

// Adds the "sim" scheme to the camera, display (sim_display.h) and light field
// capture (sim_light_field_capture.h) registries. Idempotent.
void registerSimBackends();

}  // namespace lfi::sim
