// SPDX-License-Identifier: Apache-2.0
#pragma once
// The simulated bench behind the real drivers: the ray-traced camera of a
// scene file served as a GigE Vision device (GvCameraServer) or as a USB3
// Vision device (EmulatedU3vCamera), and its display emulated as an lfi USB
// display (EmulatedUsbDisplay), so that the `aravis:` and `usb:` backends
// drive the simulation exactly as they drive a physical bench. `lfi
// sim-bench` runs one for a program started under it.
//
// What the display is sent drives what the camera sees: every frame the USB
// device presents, every brightness it is set to and every blank go to the
// scene's SimBench (sim_bench.h), and the served camera renders each frame from
// the bench as it is when the frame is made, after its software trigger (a
// frame shows the panel presented before the trigger, since PRESENT is
// answered only after the bench has the panel). The radiance is rendered again
// after each change of the display or the part, on Aravis's device thread,
// which also answers control requests: a scene whose render takes more than a
// few hundred ms makes clients time out.
//
// The part under the camera is a scene file: the bench's own (the intact part)
// or another one with the same camera sensor and display panel (the same
// bench with a defect part in place). putPart() changes it while serving; the
// display's state goes with it. As on a line, a part in place fires the
// camera's input line Line0 (its part sensor): a camera acquiring with
// TriggerSource Line0 exposes one frame of it.
//
// The display may be served as a monitor instead (ServedDisplay::Window): a
// real X server, Xvfb, with the panel's mode (xvfb_screen.h), which the
// `window:` backend shows its panels on. The served camera reads the server's
// screen as it makes each frame, and the panel it holds goes to the bench:
// what the X server shows is what the tracer emits.
//
// Faults for tests: the camera off the network and back (its process killed
// and restarted, as a client sees it; a USB3 Vision camera unplugged and
// plugged in again), the display unplugged and plugged in
// again (dark while unplugged; a monitor's X server killed and started again
// on the same display number), GVSP packet loss, and every fault the emulated
// USB display knows (display()).
//
// Thread-safe. The USB display and the USB3 Vision camera need umockdev's
// testbed (their clients run with its preload library: emulated_usb_display.h). Units: the scene's
// (mm).

#include "lfi/emulation/emulated_u3v_camera.h"
#include "lfi/emulation/emulated_usb_display.h"
#include "lfi/emulation/gv_camera_server.h"
#include "lfi/emulation/xvfb_screen.h"

#include "lfi/drivers/device_uri.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace lfi::emulation {

// How the bench's display is served: as an lfi USB display (usb:) or as a monitor on an X server (window:).
enum class ServedDisplay { Usb, Window };
// How the bench's camera is served: as a GigE Vision device on the network or a USB3 Vision device on umockdev.
enum class ServedCamera { GigE, U3v };

struct ServedBenchOptions {
  std::filesystem::path scene;  // the bench with its intact part: [camera], [display] and the part
  ServedCamera cameraKind = ServedCamera::GigE;
  GvCameraServerOptions camera;  // GigE Vision: interface and identity; the sensor size is the scene's
  EmulatedU3vCameraConfig u3v;   // USB3 Vision: identity and bus position; the sensor size is the scene's
  ServedDisplay displayKind = ServedDisplay::Usb;
  EmulatedDisplayConfig display;  // USB identity and bus position; panel, optics and brightness the scene's
  int renderThreads = 0;          // 0: all cores
};

// What the bench has done since it started.
struct ServedBenchCounters {
  std::uint64_t framesServed = 0;     // frames the camera made
  double frameSeconds = 0;            // time spent making them (renders included)
  std::uint64_t panelsPresented = 0;  // frames the display presented
  std::uint64_t partChanges = 0;
  std::uint64_t cameraRestarts = 0;
  std::uint64_t displayReplugs = 0;
};

class ServedBench {
 public:
  // Loads the scene and starts serving both devices. Throws Errc::NotFound
  // for a missing scene, Errc::Config for one without [camera] or [display]
  // or with a display the USB protocol cannot describe, and the servers'
  // errors (Errc::Device for a taken port or interface).
  explicit ServedBench(ServedBenchOptions options);
  ~ServedBench();
  ServedBench(const ServedBench&) = delete;
  ServedBench& operator=(const ServedBench&) = delete;

  // The URIs a bench file names the devices by: "aravis:<id>", "usb:<vid>:<pid>/<serial>" or
  // "window:0?pitch_mm=<pitch>&mode=<w>x<h>&layout=<layout>" (the panel's pitch, mode and layout).
  DeviceUri cameraUri() const;
  DeviceUri displayUri() const;
  // The X server a window: client talks to (its DISPLAY), or empty for a USB display.
  std::string xDisplay() const;

  // Puts the part of `scene` under the camera, then fires the line; returns
  // whether that triggered a frame. Throws Errc::Config naming the file when
  // its camera sensor or display panel differ from the bench's, and the scene
  // loader's errors; the part in place stays then, and the line does not fire.
  bool putPart(const std::filesystem::path& scene);
  // An edge on the camera's Line0 (GvCameraServer::fireLine); false when the camera is off.
  bool fireLine();
  std::filesystem::path part() const;
  // The GigE Vision camera's outputs as the client set them (GvCameraServer::userOutput, lineSource).
  // Errc::InvalidArgument for a USB3 Vision camera, Errc::Device while the camera is off.
  bool cameraUserOutput(int index) const;
  std::string cameraLineSource(int line) const;

  // The camera leaves the network (no answer to anything, the stream stops) and comes back as a freshly
  // started device. Idempotent.
  void stopCamera();
  void startCamera();
  bool cameraServing() const;
  // As GvCameraServer::setPacketLoss; kept across a restart. Errc::InvalidArgument for a USB3 Vision camera.
  void setPacketLoss(double ratio);

  // The display unplugged (its panel goes dark) and plugged in again. Idempotent.
  void unplugDisplay();
  void plugDisplay();
  bool displayPlugged() const;
  // The emulated device, for its own faults (stalls, corrupt or short transfers, silence). Throws
  // Errc::InvalidArgument for a display served as a monitor.
  EmulatedUsbDisplay& display();

  ServedBenchCounters counters() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace lfi::emulation
