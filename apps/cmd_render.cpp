// SPDX-License-Identifier: Apache-2.0
// lfi render: a scene file rendered to a camera image (EXR and PNG) or a light
// field (EXR); Ctrl-C cancels the render between tiles.

#include "cli_util.h"
#include "commands.h"

#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/image.h"
#include "lfi/core/log.h"
#include "lfi/core/output_folder.h"
#include "lfi/sim/scene_file.h"

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <utility>
#include <variant>
#include <vector>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

constexpr long long kMostSpp = lfi::sim::kMostSamplesPerPixel;

// Ctrl-C asks long work to stop cleanly (renders check it between tiles).
std::atomic<bool> gCancel{false};
extern "C" void onInterrupt(int) {
  gCancel = true;
}

struct RenderArgs {
  fs::path sceneFile, out;
  int spp = 0;
  bool force = false;
  int threads = 0;
  std::optional<std::uint64_t> seed;
};

int runRenderCommand(const RenderArgs& a, const GlobalOptions& global) {
  lfi::sim::SceneDescription d = lfi::sim::loadSceneFile(a.sceneFile);
  if (a.spp > 0) d.render.samplesPerPixel = a.spp;
  if (a.seed) d.render.seed = *a.seed;
  d.render.threads = a.threads;
  lfi::setExrThreads(a.threads);
  d.render.cancel = &gCancel;
  ProgressBar bar;
  if (!global.quiet) d.render.progress = [&bar](double f) { bar("rendering", f); };
  // (A run started with SIGINT ignored, as a background job is, keeps it ignored.)
  const auto previousSigint = std::signal(SIGINT, SIG_IGN);
  if (previousSigint != SIG_IGN) std::signal(SIGINT, onInterrupt);
  // Where the images go must take them before the render, not after.
  const auto overwrite = a.force ? lfi::Overwrite::Allow : lfi::Overwrite::Refuse;
  const bool lightField = std::holds_alternative<lfi::sim::LightFieldSensor>(d.sensor);
  const std::vector<fs::path> outputs =
      lightField ? std::vector<fs::path>{a.out / (d.name + "_lightfield.exr")}
                 : std::vector<fs::path>{a.out / (d.name + ".exr"), a.out / (d.name + ".png")};
  requireOutputFolder(a.out, "render", "--out");
  refuseExisting(outputs, overwrite, "render");
  const lfi::sim::Scene scene(std::move(d.objects), d.ambientIor);
  const auto start = std::chrono::steady_clock::now();
  cv::Mat image;
  try {
    image = lfi::sim::render(scene, d.sensor, d.render);
  } catch (const lfi::Error& e) {  // the scene cannot be traced (e.g. too deeply nested): name its file
    if (e.code() != lfi::Errc::Config) throw;
    throw lfi::Error(e.code(), fmt::format("{}: {}", a.sceneFile.string(), e.what()));
  }
  // From here Ctrl-C does what it did before (by default: ends the process; a write in progress removes its
  // temporary): the render it would have cancelled is done.
  std::signal(SIGINT, previousSigint == SIG_ERR ? SIG_DFL : previousSigint);
  if (gCancel) lfi::fail(lfi::Errc::Cancelled, "render: interrupted");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  bar.finish();
  if (const auto* lfs = std::get_if<lfi::sim::LightFieldSensor>(&d.sensor)) {
    lfi::writeLightFieldExr(outputs[0], lfi::LightField(lfs->geometry, image), overwrite);
    fmt::print("{}\n", outputs[0].string());
  } else {
    const auto& cam = std::get<lfi::sim::TelecentricCamera>(d.sensor);
    lfi::writeRadianceExr(outputs[0], image, {cam.objectPixel_mm(), "rendered radiance of scene " + d.name}, overwrite);
    lfi::writePngAtomically(outputs[1], lfi::toneMapForDisplay(image), overwrite);
    fmt::print("{}\n{}\n", outputs[0].string(), outputs[1].string());
  }
  const double samples = static_cast<double>(image.total()) * d.render.samplesPerPixel;
  spdlog::info("{:.0f} samples in {:.3f} s: {:.2f} M samples/s", samples, seconds, samples / seconds / 1e6);
  return 0;
}

}  // namespace

Command addRenderCommand(CLI::App& app) {
  auto* render = app.add_subcommand("render", "Render a scene file (camera image or light field)");
  auto a = std::make_shared<RenderArgs>();
  render->add_option("scene", a->sceneFile, "Scene file (TOML, docs/scene-files.md)")
      ->required()
      ->check(CLI::ExistingFile);
  render->add_option("--out", a->out, "Output folder")->required();
  render->add_option("--spp", a->spp, "Samples per pixel (overrides the scene file)")
      ->transform(wholeNumberIn(1LL, kMostSpp));
  render->add_option("--threads", a->threads, "Worker threads (0 = all cores)")->transform(threadCount());
  render->add_option("--seed", a->seed, "Random seed (overrides the scene file)")->transform(seedValue());
  render->add_flag("--force", a->force, "Replace existing output files");
  return {render, [a](const GlobalOptions& global) { return runRenderCommand(*a, global); }};
}

}  // namespace lfi::cli
