// SPDX-License-Identifier: Apache-2.0
#pragma once
// The inverse schlieren cycle, one code path whatever the backends (docs/architecture.md):
//
//   1. capture  the reference light field of the intact part (LightFieldCapture)
//   2. emit     it with the light field display (encoded through the display's
//               optics, encodeLightField, and shown as a panel image)
//   3. inspect  the part through the telecentric camera (Camera): intact regions
//               bright, defects dark
//
// The same Controller drives the physical bench (aravis:, usb:) and the
// ray-traced one (sim:). It owns none of the devices; it leaves the camera
// streaming after inspect() and stops it in its destructor only if it started it.
//
//   option         default  meaning
//   grabTimeout    5 s      per frame, beyond twice the camera's exposure time
//   frames         1        complete frames averaged into one inspection image
//   retries        3        incomplete or timed-out frames tolerated per inspection
//   white          0        radiance shown at full drive level; 0 = the light
//                           field's 99.9th percentile (so the panel's range is used)
//   settle         0 ms     after a show, before the first frame that counts may
//                           start exposing (a panel's response time; the sim:
//                           and usb: displays answer once the frame is shown)
//   correction     none     the camera's dark and flat frames, applied to every
//                           image inspect() returns (frame_correction.h)
//   panelResponse  none     the panel's measured response: emit() and showPanel()
//                           of CV_32FC1 light drive the levels that emit it
//                           (panel_response.h); none: a linear, uniform panel

#include "lfi/core/light_field.h"
#include "lfi/drivers/camera.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/light_field_capture.h"
#include "lfi/drivers/panel_response.h"

#include <opencv2/core.hpp>

#include <chrono>
#include <functional>
#include <memory>
#include <optional>

namespace lfi {

class FrameCorrection;

struct ControllerOptions {
  std::chrono::milliseconds grabTimeout{5000};
  int frames = 1;
  int retries = 3;
  double white = 0;
  std::chrono::milliseconds settle{0};
  std::shared_ptr<const FrameCorrection> correction;
  std::optional<PanelResponseParams> panelResponse;
};

class Controller {
 public:
  // Progress of the whole cycle: a step label and the fraction done.
  using Progress = std::function<void(const char* step, double fraction)>;

  Controller(LightFieldCapture& capture, Display& display, Camera& camera, ControllerOptions options = {});
  ~Controller();
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

  // Step 1. A capture with a sensor of its own leaves the display and camera
  // untouched; one that measures through the bench (coded:) shows its patterns
  // with the display and takes them with the camera (as emit() and inspect()),
  // and measures the panel image to show besides (referencePanel()).
  LightField captureReference(const Progress& progress = {});
  // The panel image the last captureReference() measured through the bench:
  // CV_32FC1 drive levels in [0, 1]; empty after a capture with its own sensor.
  const cv::Mat& referencePanel() const { return referencePanel_; }
  // Step 2. The display must be Open or Showing; a rejected or timed-out frame
  // throws Errc::Device with the device's reason. `white` (radiance shown at
  // full drive level) replaces the option's, e.g. to show several light fields
  // on one scale.
  void emit(const LightField& reference);
  void emit(const LightField& lightField, double white);
  // Step 2 for a panel image: `levels` CV_8UC1 drive levels or CV_32FC1 in
  // [0, 1] of full light (of full drive on a panel without a measured
  // response), the panel's size, every subpixel of a pixel alike; or a panel
  // image of the display's panel type, shown as it is. Throws as emit().
  void showPanel(const cv::Mat& levels);
  // Step 2 for what captureReference() returned: its panel image when it
  // measured one, else the light field.
  void emitReference(const LightField& reference);
  // The 99.9th percentile of the light field's radiance (1 when that is not
  // positive): the drive scale emit() uses when the option's white is 0.
  static double defaultWhite(const LightField& lightField);
  // Step 3. The camera must be Configured (it is started with a small buffer
  // pool) or Streaming. Every frame is exposed after the last emit(): a camera
  // that was streaming when the display changed is stopped and started again
  // (with the same small pool; its statistics start again, its frame ids go
  // on as the backend numbers them),
  // dropping the frames it had taken of the old panel — unless it is
  // software-triggered on a stream this controller started and every frame
  // it triggered has come (complete or not): such a stream holds no frame,
  // and restarting a GigE camera's acquisition takes tens of milliseconds.
  // (The controller takes a stream it started to stay its own.) Returns the
  // mean of `frames` complete frames, CV_32FC1,
  // in the camera's digital numbers, corrected by the option's dark and flat
  // frames. More than `retries` bad frames throw
  // Errc::Device (Errc::Timeout when nothing arrived at all).
  cv::Mat inspect();
  // Throws Errc::Device naming the display unless it still shows the frame the
  // last emit() or showPanel() showed: a display that lost power, was reset or
  // was sent another frame since shows something else, and an image taken
  // meanwhile is not one of the reference. One status request to the device.
  void requireShowing();
  // Steps 1-3.
  cv::Mat run(const Progress& progress = {});

  // The bench as a measurement through it sees it (light_field_capture.h):
  // take(levels) is showPanel(levels) then inspect().
  BenchProbe& probe();

  // The drive level scale used by the last emit(): radiance shown at full
  // level (1 after showPanel(): the levels are the drive).
  double white() const { return white_; }

 private:
  class Probe;
  // inspect() but the correction.
  cv::Mat meanOfFrames();
  // The option's panel response for this display, made at the first call; null without one.
  const PanelResponse* panelResponse();
  // Throws Errc::Device unless `result` is Presented; returns its sequence.
  std::uint32_t shown(const PresentResult& result, const char* what);
  LightFieldCapture& capture_;
  Display& display_;
  Camera& camera_;
  ControllerOptions options_;
  bool startedCamera_ = false;
  bool staleFrames_ = false;                     // the display changed since the stream inspect() last used started
  bool ownStream_ = false;                       // the camera's stream is one inspect() started
  bool ownSoftware_ = false;                     // ... software-triggered
  int pendingFrames_ = 0;                        // software triggers on it that no frame has answered yet
  std::chrono::steady_clock::time_point shown_;  // when the last emit() returned
  std::optional<std::uint32_t> shownSequence_;   // and the frame it showed
  double white_ = 0;
  cv::Mat referencePanel_;
  std::unique_ptr<Probe> probe_;
  std::unique_ptr<const PanelResponse> panelResponse_;
};

}  // namespace lfi
