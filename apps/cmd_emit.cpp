// SPDX-License-Identifier: Apache-2.0
// lfi emit BENCH: the bench's display shows the reference package's
// reference (its panel image, or its light field at the package's drive
// scale) or a given light field, until stopped.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/controller.h"
#include "lfi/controller/reference_package.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/drivers/panel_response.h"

#include <fmt/format.h>

#include <optional>

#include <chrono>
#include <memory>
#include <thread>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

struct EmitArgs {
  fs::path bench, lightField;
  double seconds = 0;
};

int runEmit(const EmitArgs& a, const GlobalOptions&) {
  const lfi::BenchFile bench = lfi::readBenchFile(a.bench);
  lfi::LightField lightField;
  cv::Mat panel;  // a reference measured through the display: its panel image
  double white = bench.white;
  if (a.lightField.empty()) {
    const lfi::ReferencePackage package = lfi::readReferencePackage(bench.referenceFolder, &bench);
    lightField = package.lightField;
    panel = package.panel;
    white = package.info.white;
  } else {
    lightField = lfi::readLightFieldExr(a.lightField);
  }
  if (!(white > 0)) white = lfi::Controller::defaultWhite(lightField);
  auto display = lfi::openBenchDisplay(bench);
  std::optional<lfi::PanelResponse> response;  // the panel's measured response, when the bench has it
  if (bench.panelResponse) response.emplace(*bench.panelResponse, display->info());
  const lfi::PanelResponse* drive = response ? &*response : nullptr;
  const lfi::PresentResult r =
      display->show(panel.empty() ? lfi::encodeLightField(lightField, lfi::DisplayOptics(display->info()), white,
                                                          lfi::LightFieldLookup::Interpolated, drive)
                                  : lfi::panelFromLevels(panel, display->info(), drive));
  if (r.status != lfi::PresentStatus::Presented)
    lfi::fail(lfi::Errc::Device, "emit: display '{}' did not show the {} ({}{}{})", bench.displayUri,
              panel.empty() ? "light field" : "reference's panel image", lfi::toString(r.status),
              r.message.empty() ? "" : ": ", r.message);
  StopOnSignal stop;
  fmt::print(stderr, "emit: showing on {} {}; {}\n", bench.displayUri,
             panel.empty() ? fmt::format("the light field (white = {:.4g})", white) : "the reference's panel image",
             a.seconds > 0 ? fmt::format("for {} s", a.seconds) : std::string("Ctrl-C stops"));
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(a.seconds);
  while (!StopOnSignal::stopRequested() && (a.seconds <= 0 || std::chrono::steady_clock::now() < end))
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  display->close();  // (dark again)
  return 0;
}

}  // namespace

Command addEmitCommand(CLI::App& app) {
  auto* command = app.add_subcommand("emit", "Show the bench's reference light field on its display until stopped");
  auto a = std::make_shared<EmitArgs>();
  addBenchArgument(*command, a->bench);
  command->add_option("--light-field", a->lightField, "Show this light field (EXR) instead of the reference's")
      ->check(CLI::ExistingFile);
  command->add_option("--seconds", a->seconds, "Show for this long (default: until Ctrl-C)")
      ->check(CLI::PositiveNumber);
  return {command, [a](const GlobalOptions& global) { return runEmit(*a, global); }};
}

}  // namespace lfi::cli
