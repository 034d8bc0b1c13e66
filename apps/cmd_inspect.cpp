// lfi inspect: the reference light field captured (or read), emitted with the
// display, and the part inspected through the camera.

#include "bench_devices.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/controller/controller.h"
#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/image.h"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <vector>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

struct InspectArgs {
  BenchOptions bench;
  fs::path out;
  bool force = false;
};

int runInspectCommand(const InspectArgs& a, const GlobalOptions& global) {
  const auto overwrite = a.force ? lfi::Overwrite::Allow : lfi::Overwrite::Refuse;
  std::vector<fs::path> outputs{a.out / "inspection.exr", a.out / "inspection.png"};
  if (!a.bench.capture.empty())  // (a given light field is not written)
    outputs.push_back(a.out / "lightfield.exr");
  refuseExisting(outputs, a.force, "inspect");
  OpenBench bench = openBench(a.bench, "inspect");
  lfi::ControllerOptions options;
  options.frames = a.bench.frames;
  options.settle = std::chrono::milliseconds(a.bench.settle_ms);
  ProgressBar bar;
  lfi::Controller controller(*bench.capture, *bench.display, *bench.camera, options);
  requireOutputFolder(a.out, "inspect");  // (once the devices are open: a bad one leaves no folder)
  const lfi::LightField reference = controller.captureReference([&](const char* step, double f) {
    if (!global.quiet) bar(step, f);
  });
  bar.finish();
  if (bench.captured) lfi::writeLightFieldExr(a.out / "lightfield.exr", reference, overwrite);
  try {  // (whatever fails from here on, a captured light field is kept and named)
    controller.emit(reference);
    const cv::Mat image = controller.inspect();
    const auto info = bench.camera->info();
    lfi::writeRadianceExr(a.out / "inspection.exr", image,
                          {0,
                           fmt::format("inspection image (DN, mean of {} frames) from {} {} via {}",
                                       a.bench.frames, info.vendor, info.model, a.bench.camera),
                           lfi::kCameraDigitalNumbers},
                          overwrite);
    double maxValue = 0;
    cv::minMaxLoc(image, nullptr, &maxValue);
    cv::Mat png8;
    image.convertTo(png8, CV_8U, maxValue > 0 ? 255.0 / maxValue : 1.0);
    lfi::writePngAtomically(a.out / "inspection.png", png8, overwrite);
  } catch (const lfi::Error& e) {
    if (!bench.captured) throw;
    throw lfi::Error(e.code(),
                     fmt::format("{} (the captured light field is kept: rerun with --light-field {} to skip the "
                                 "capture)", e.what(), (a.out / "lightfield.exr").string()));
  }
  if (bench.captured) fmt::print("{}\n", (a.out / "lightfield.exr").string());
  fmt::print("{}\n{}\n", (a.out / "inspection.exr").string(), (a.out / "inspection.png").string());
  return 0;
}

}  // namespace

Command addInspectCommand(CLI::App& app) {
  auto* inspect = app.add_subcommand(
      "inspect", "Capture the reference light field, emit it with the display, inspect through the camera");
  auto a = std::make_shared<InspectArgs>();
  addBenchOptions(*inspect, a->bench);
  inspect->add_option("--out", a->out, "Output folder (inspection.exr/.png, lightfield.exr)")->required();
  inspect->add_flag("--force", a->force, "Replace existing output files");
  return {inspect, [a](const GlobalOptions& global) { return runInspectCommand(*a, global); }};
}

}  // namespace lfi::cli
