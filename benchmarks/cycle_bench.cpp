// SPDX-License-Identifier: Apache-2.0
// lfi-cycle-bench: the controller's capture → emit → inspect cycle on the
// simulated bench (sim: camera, display and light field capture on one scene
// file), step by step, next to the simulation's own work measured in the same
// run: what the one code path that also drives the physical bench (the
// controller, the device interfaces, the display's encoding, the frame
// transport) costs on top of the ray tracing and the sensor model.
//
//   step      what is timed (one turn each)                 bound (same turn)
//   capture   Controller::captureReference                  the capture backend's capture() alone (its render)
//   emit      Controller::emit (the light field encoded     -
//             for the panel, shown, the panel's levels)
//   inspect   Controller::inspect: the stream restarted,    SimImager alone on the same bench: the camera's
//             a software-triggered frame rendered with      render of the shown panel and the sensor model
//             the panel shown, noised, transported, averaged
//   cycle     the three steps                               the two bounds
//
// A ratio is the median of the turns' ratios, with their range; a time the
// best turn's (bench_util.h); each step and its bound run in alternating
// order. Self-check after the turns: the inspection image and the bound's frame
// (the same radiance and sensor model, other noise) have the same size and mean,
// and are lit.
//
// Usage: lfi-cycle-bench [--scene FILE] [--capture-query Q] [--turns N] [--quick]
//   --scene          a scene file with [camera], [display] and a part (default:
//                    data/scenes/inspection_bench.toml, the bench of lfi inspect)
//   --capture-query  the sim: capture URI's query (default: its defaults)
//   --quick          2 turns and a small light field (a smoke run)

#include "lfi/controller/controller.h"
#include "lfi/drivers/camera.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/light_field_capture.h"
#include "lfi/sim/devices/sim_bench.h"
#include "lfi/sim/devices/sim_camera.h"

#include "bench_util.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace lfi;
using lfi::bench::spreadOf;

namespace {

double secondsOf(const std::function<void()>& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int run(int argc, char** argv) {
  std::string scene = (fs::path(LFI_SOURCE_DIR) / "data" / "scenes" / "inspection_bench.toml").string();
  std::string captureQuery;
  int turns = 7;
  bool quick = false;
  CLI::App app("lfi-cycle-bench: the controller's cycle on the simulated bench against the simulation's own work");
  app.add_option("--scene", scene, "Scene file with [camera], [display] and a part")->check(CLI::ExistingFile);
  app.add_option("--capture-query", captureQuery, "Query of the sim: light field capture URI (e.g. spatial=40&spp=4)");
  app.add_option("--turns", turns, "Turns; a ratio is the median of theirs")->check(CLI::Range(1, 1000));
  app.add_flag("--quick", quick, "2 turns and a small light field (a smoke run)");
  CLI11_PARSE(app, argc, argv);
  if (quick) {
    if (app.count("--turns") == 0) turns = 2;
    if (captureQuery.empty()) captureQuery = "spatial=16&angular=8&spp=2";
  }
  spdlog::set_level(spdlog::level::warn);  // (the controller logs each step at info)

  sim::registerSimBackends();
  const std::string uri = DeviceUri{.scheme = "sim", .path = scene}.text();
  auto camera = openCamera(uri);
  auto display = openDisplay(uri);
  auto capture = openLightFieldCapture(captureQuery.empty() ? uri : uri + "?" + captureQuery);  // (the user's query)
  CameraSettings settings;
  settings.pixelFormat = PixelFormat::Mono12;
  settings.trigger = TriggerMode::Software;
  camera->configure(settings);
  const CameraSettings resolved = camera->settings();

  // The bound's imager: the same scene file, so the same bench and the panel the display shows.
  sim::SimImager imager(scene);
  const CameraSettings imagerSettings = imager.resolve(resolved, "bound");
  cv::Mat boundFrame;

  Controller controller(*capture, *display, *camera);
  std::vector<double> captureTime, emitTime, inspectTime, captureBound, inspectBound;
  std::vector<double> captureRatio, inspectRatio, cycleRatio;
  cv::Mat image;
  // A step and its bound, in alternating order from turn to turn (the first of the two may pay for caches).
  auto inTurn = [](bool boundFirst, const std::function<void()>& step, const std::function<void()>& bound) {
    double s = 0, b = 0;
    if (boundFirst) b = secondsOf(bound);
    s = secondsOf(step);
    if (!boundFirst) b = secondsOf(bound);
    return std::pair{s, b};
  };
  for (int turn = 0; turn < turns; ++turn) {
    LightField reference;
    const auto [c, cb] = inTurn(
        turn % 2 == 1, [&] { reference = controller.captureReference(); }, [&] { (void)capture->capture({}); });
    emitTime.push_back(secondsOf([&] { controller.emit(reference); }));
    // The display's version changed with this emit: the camera and the bound's imager each render it anew.
    const auto [i, ib] = inTurn(
        turn % 2 == 1, [&] { image = controller.inspect(); },
        [&] { imager.capture(imagerSettings, 1000 + turn, boundFrame); });
    captureTime.push_back(c), captureBound.push_back(cb), inspectTime.push_back(i), inspectBound.push_back(ib);
    captureRatio.push_back(c / cb);
    inspectRatio.push_back(i / ib);
    cycleRatio.push_back((c + emitTime.back() + i) / (cb + ib));
  }
  // Self-check: the bound rendered what the camera saw. The same radiance and sensor model with other noise
  // draws: the two images' means agree to their noise, and they are lit (a dark panel reads about 0.4 DN).
  const double inspected = cv::mean(image)[0], bound = cv::mean(boundFrame)[0];
  if (image.size() != boundFrame.size() || !(bound > 2) || !(std::abs(inspected - bound) < 0.02 * bound + 0.5))
    throw std::runtime_error(
        fmt::format("self-check: the inspection image ({} x {}, mean {:.2f} DN) is not the "
                    "bound's frame ({} x {}, mean {:.2f} DN)",
                    image.cols, image.rows, inspected, boundFrame.cols, boundFrame.rows, bound));

  auto best = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
  const LightFieldGeometry g = capture->geometry();
  fmt::print("lfi-cycle-bench: {}, {} turns\n", scene, turns);
  fmt::print("  light field {} x {} x {}^2 ({}); camera {} x {} Mono12, software trigger\n", g.spatialX, g.spatialY,
             g.angular, capture->description(), resolved.roiWidth_px, resolved.roiHeight_px);
  fmt::print("  capture   {:9.2f} ms   bound: the capture backend alone   {:9.2f} ms\n", 1e3 * best(captureTime),
             1e3 * best(captureBound));
  fmt::print("  emit      {:9.2f} ms   (encode for the panel, show, panel levels)\n", 1e3 * best(emitTime));
  fmt::print("  inspect   {:9.2f} ms   bound: SimImager render + sensor   {:9.2f} ms\n", 1e3 * best(inspectTime),
             1e3 * best(inspectBound));
  auto ratio = [&](const char* label, const std::vector<double>& v) {
    const auto r = spreadOf(v);
    fmt::print("  ratio {:<40} {:6.2f}  (turns {:.2f}-{:.2f})\n", label, r.median, r.low, r.high);
  };
  ratio("capture / its bound", captureRatio);
  ratio("inspect / its bound", inspectRatio);
  ratio("cycle / the bounds' sum", cycleRatio);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return lfi::bench::runGuarded("lfi-cycle-bench", [&] { return run(argc, argv); });
}
