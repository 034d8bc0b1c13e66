// SPDX-License-Identifier: Apache-2.0
// Opens the simulated camera of a scene file through the installed lfi
// libraries and grabs one frame: grab_frame <scene.toml>. Prints the frame's
// size, status and mean; exits non-zero unless the frame is complete.
#include <lfi/core/error.h>
#include <lfi/drivers/camera_registry.h>
#include <lfi/sim/devices/sim_camera.h>

#include <opencv2/core.hpp>

#include <cstdio>
#include <string>

int main(int argc, char** argv) try {
  if (argc != 2) {
    std::fprintf(stderr, "usage: grab_frame <scene.toml>\n");
    return 2;
  }
  lfi::sim::registerSimBackends();
  auto camera = lfi::openCamera(std::string("sim:") + argv[1]);
  camera->configure(lfi::CameraSettings{
      .exposure_us = 1000, .pixelFormat = lfi::PixelFormat::Mono12, .trigger = lfi::TriggerMode::Software});
  camera->start(2);
  camera->softwareTrigger();
  const lfi::Frame frame = camera->grab(std::chrono::seconds(60));
  std::printf("%d x %d %s mean %.1f\n", frame.image.cols, frame.image.rows, lfi::toString(frame.status),
              cv::mean(frame.image)[0]);
  return frame.status == lfi::FrameStatus::Complete ? 0 : 1;
} catch (const lfi::Error& e) {
  std::fprintf(stderr, "grab_frame: %s\n", e.what());
  return 1;
}
