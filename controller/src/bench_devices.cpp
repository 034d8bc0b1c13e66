#include "lfi/controller/bench_devices.h"

#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"

#include <fmt/format.h>

namespace lfi {

std::unique_ptr<Camera> openBenchCamera(const BenchFile& bench) {
  auto camera = openCamera(bench.cameraUri);
  camera->configure(bench.camera);
  return camera;
}

std::unique_ptr<Display> openBenchDisplay(const BenchFile& bench) { return openDisplay(bench.displayUri); }

std::unique_ptr<LightFieldCapture> openBenchCapture(const BenchFile& bench) {
  if (!bench.captureUri.empty()) return openLightFieldCapture(bench.captureUri);
  return std::make_unique<StoredLightField>(readLightFieldExr(bench.lightFieldFile),
                                            "file " + bench.lightFieldFile.string());
}

ControllerOptions controllerOptions(const BenchFile& bench, int frames) {
  ControllerOptions o;
  o.grabTimeout = std::chrono::milliseconds(bench.grabTimeout_ms);
  o.frames = frames;
  o.retries = bench.retries;
  o.white = bench.white;
  o.settle = std::chrono::milliseconds(bench.settle_ms);
  return o;
}

std::string describeCamera(Camera& camera, const std::string& uri) {
  const CameraInfo info = camera.info();
  return fmt::format("{} {} {} ({})", info.vendor, info.model, info.serial, uri);
}

}  // namespace lfi
