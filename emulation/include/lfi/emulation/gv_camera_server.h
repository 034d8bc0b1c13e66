// SPDX-License-Identifier: Apache-2.0
#pragma once
// The device side of GigE Vision: serves images made by this process as a
// GigE Vision camera, with Aravis's own device implementation (ArvGvFakeCamera:
// GVCP discovery and register access on UDP port 3956, GVSP streaming,
// Aravis's fake-camera GenICam description). `lfi serve-camera` uses it to put
// the ray-traced camera on the network, so that the Aravis backend and any
// GenICam client can be tested against it. Aravis types stay in the .cpp.
//
// The GenICam features are Aravis's fake camera's (GigE Vision 1.x names):
// Width/Height/OffsetX/OffsetY (binned pixels; their ranges do not shrink with
// binning), BinningHorizontal/Vertical 1..16, PixelFormat Mono8/Mono16 (the
// description also lists Bayer8/RGB8, which are served black), ExposureTimeAbs
// (µs, integer, 10..10 000 000), GainRaw (0..10, integer), AcquisitionFrameRate
// (1..1000 Hz), TriggerMode/TriggerSource (Software, Line0: fireLine()). The
// sensor size is ours.
// A software trigger is seen within 5 ms (Aravis's device looks for one once
// per trigger period, set to 200 Hz here).
//
// Frames are made on Aravis's device thread, which also answers control
// requests: a filler slower than a few hundred ms makes clients time out.

#include "lfi/drivers/camera.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace lfi::emulation {

// One frame as the client configured the device, read from its registers.
struct ServedFrameRequest {
  std::uint64_t frameId = 0;  // the GVSP block id the client receives for this frame
  int offsetX_px = 0;         // binned pixels
  int offsetY_px = 0;
  int width_px = 0;
  int height_px = 0;
  int binning = 1;                         // BinningHorizontal (BinningVertical is expected equal)
  std::optional<PixelFormat> pixelFormat;  // unset for a format we do not serve
  double exposure_us = 0;
  double gain = 0;  // GainRaw

  // As camera settings (exposure, gain, format, binning, region; the rest
  // default). Requires pixelFormat: the filler is called only with one.
  CameraSettings settings() const;
};

// Copies a frame made for a request into the outgoing buffer `image`. Throws
// Errc::Device for another size or type (copyTo would reallocate the buffer's
// wrapper, and a black frame go out).
void writeServedFrame(const cv::Mat& frame, cv::Mat& image);

// Writes one frame: `image` is height x width, CV_8UC1 (Mono8) or CV_16UC1
// (Mono16), and wraps the outgoing buffer (zeroed). Runs on Aravis's device
// thread; an exception is logged and the frame goes out black.
using ServedFrameFiller = std::function<void(const ServedFrameRequest& request, cv::Mat& image)>;

struct GvCameraServerOptions {
  std::string interfaceAddress = "127.0.0.1";  // IPv4 address or interface name to serve on
  std::string serial = "LFISIM01";             // < 16 characters
  std::string vendor = "lfi";                  // < 32 characters
  std::string model = "SimCamera";             // < 32 characters
  int sensorWidth_px = 512;
  int sensorHeight_px = 512;
};

class GvCameraServer {
 public:
  // Starts serving. Throws Errc::InvalidArgument for bad options and
  // Errc::Device when Aravis cannot bind the interface (e.g. port 3956 taken).
  GvCameraServer(const GvCameraServerOptions& options, ServedFrameFiller filler);
  ~GvCameraServer();
  GvCameraServer(const GvCameraServer&) = delete;
  GvCameraServer& operator=(const GvCameraServer&) = delete;

  // "<vendor>-<model>-<serial>", what Aravis's discovery reports.
  std::string deviceId() const;

  // Drops each GVSP packet (leader, payload, trailer) with this probability,
  // from the next packet on: a lossy network for fault tests. 0 (the start)
  // drops none. Throws Errc::InvalidArgument outside 0..1.
  void setPacketLoss(double ratio);

  // A rising edge on the camera's input line Line0 (a part sensor's): while
  // the client acquires with TriggerMode On and TriggerSource Line0, the
  // device exposes one frame, as a camera's hardware trigger does; in any
  // other mode, or when the device does not take it within `timeout_ms`,
  // nothing happens. Returns whether a frame was triggered. (Aravis's device
  // knows software triggers only: the edge reaches it as one, and its
  // TriggerSource reads Software for the instant until it takes it, at most
  // one trigger period, 5 ms.)
  bool fireLine(int timeout_ms = 200);
  // The camera's outputs as a client left them in its registers (SFNC's
  // DigitalIOControl, which the served camera's description adds to
  // Aravis's): whether UserOutput<index> is set, and what drives Line<line>
  // ("Input" for a line not in LineMode Output, else "Off" or
  // "UserOutput<n>"). Lines and user outputs 0 to 2; others throw
  // Errc::InvalidArgument.
  bool userOutput(int index) const;
  std::string lineSource(int line) const;

  // The constructor's checks of `options` that need no frame filler nor
  // sensor size, for a check before slow work that precedes serving: the
  // identity's lengths, and the interface. Throws Errc::InvalidArgument; for
  // an interface, listing those Aravis could serve on (up, not
  // point-to-point, with an IPv4 address) when `interfaceAddress` names none
  // of them by name or address (the constructor's own failure cannot tell it
  // from a taken port).
  static void validate(const GvCameraServerOptions& options);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lfi::emulation
