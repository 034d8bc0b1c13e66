// SPDX-License-Identifier: Apache-2.0
// lfi serve-camera: the ray-traced camera of a scene file served as a GigE
// Vision device until SIGINT or SIGTERM.

#include "cli_util.h"
#include "commands.h"

#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/log.h"
#include "lfi/emulation/gv_camera_server.h"
#include "lfi/sim/devices/sim_camera.h"

#include <fmt/format.h>

#include <pthread.h>
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

// lfi serve-camera: SimImager frames through Aravis's device-side GigE Vision
// implementation until SIGINT or SIGTERM. The radiance of every binning is
// rendered before the device appears (a render inside a frame would stall the
// device's only thread, which also answers control requests).
void serveCamera(const fs::path& sceneFile, lfi::emulation::GvCameraServerOptions options, int threads,
                 double packetLoss, bool quiet) {
  // Blocked before any thread starts (the renders' workers, Aravis's device
  // thread inherit the mask), so that SIGINT and SIGTERM reach sigwait() below
  // and not a worker's default action. One that comes during the first
  // renders stops the server as soon as it is up.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  lfi::emulation::GvCameraServer::validate(options);  // (before the renders: the serial's length, the interface)
  lfi::sim::SimImager imager(sceneFile);
  ProgressBar bar;
  imager.setRenderOptions(
      threads, quiet ? std::function<void(double)>() : [&bar](double f) { bar("rendering", f); });
  const int binnings =
      std::min({lfi::sim::SimImager::limits().maxBinning, imager.camera().width, imager.camera().height});
  for (int b = 1; b <= binnings; ++b) imager.radiance(b);
  bar.finish();
  imager.setRenderOptions(threads, {});
  options.sensorWidth_px = imager.camera().width;
  options.sensorHeight_px = imager.camera().height;
  const std::string device = "lfi-served:" + sceneFile.string();
  cv::Mat frame;
  lfi::emulation::GvCameraServer server(
      options, [&](const lfi::emulation::ServedFrameRequest& request, cv::Mat& image) {
        imager.capture(imager.resolve(request.settings(), device), request.frameId, frame);
        lfi::emulation::writeServedFrame(frame, image);
      });
  server.setPacketLoss(packetLoss);
  fmt::print("{}\n", server.deviceId());
  std::fflush(stdout);
  spdlog::info("serving '{}' as GigE Vision device '{}' on {} ({} x {} px); SIGINT/SIGTERM stops", sceneFile.string(),
               server.deviceId(), options.interfaceAddress, options.sensorWidth_px, options.sensorHeight_px);
  int signal = 0;
  sigwait(&signals, &signal);
  spdlog::info("serve-camera: {} received, stopping", signal == SIGINT ? "SIGINT" : "SIGTERM");
}

struct ServeArgs {
  fs::path scene;
  lfi::emulation::GvCameraServerOptions options;
  int threads = 0;
  double packetLoss = 0;
};

}  // namespace

Command addServeCameraCommand(CLI::App& app) {
  auto* serve = app.add_subcommand(
      "serve-camera", "Serve the ray-traced camera of a scene file as a GigE Vision device (Ctrl-C stops)");
  auto a = std::make_shared<ServeArgs>();
  serve->add_option("scene", a->scene, "Scene file with a [camera] (TOML, docs/scene-files.md)")
      ->required()
      ->check(CLI::ExistingFile);
  serve->add_option("--interface", a->options.interfaceAddress, "IPv4 address or network interface to serve on")
      ->capture_default_str();
  serve->add_option("--serial", a->options.serial, "Serial number (device id: lfi-SimCamera-<serial>)")
      ->capture_default_str();
  serve->add_option("--threads", a->threads, "Render threads (0 = all cores)")->transform(threadCount());
  serve
      ->add_option("--packet-loss", a->packetLoss,
                   "Drop each GVSP packet with this probability: a lossy network for the client's tests")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  return {serve, [a](const GlobalOptions& global) {
            lfi::setExrThreads(a->threads);
            serveCamera(a->scene, a->options, a->threads, a->packetLoss, global.quiet);
            return 0;
          }};
}

}  // namespace lfi::cli
