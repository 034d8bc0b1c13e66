// SPDX-License-Identifier: Apache-2.0
// lfi train BENCH: more good parts (or more frames of one) into the golden
// model of the bench's reference package; the package is rewritten atomically.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/inspection_record.h"
#include "lfi/controller/inspector.h"
#include "lfi/controller/reference_package.h"
#include "lfi/core/error.h"

#include <fmt/format.h>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

struct TrainArgs {
  fs::path bench, part;
  int images = 1;
  bool prompt = false;
};

int runTrain(const TrainArgs& a, const GlobalOptions& global) {
  const lfi::BenchFile bench = lfi::readBenchFile(a.bench);
  // The devices: the bench's, or those of --part's scene on a simulated bench (a bench that cannot take
  // --part is the first thing to say).
  const lfi::BenchFile devices = a.part.empty() ? bench : lfi::withSimulatedPart(bench, a.part);
  ProgressBar bar;
  const int count = lfi::trainGoldenModel(bench, devices, a.images, [&](int i) {
    if (a.prompt) {
      fmt::print(stderr, "Put good part {} of {} in place and press Enter (end of input stops): ", i + 1, a.images);
      std::string line;
      return static_cast<bool>(std::getline(std::cin, line));
    }
    if (!global.quiet) bar("golden model", static_cast<double>(i) / a.images);
    return true;
  });
  if (!a.prompt && !global.quiet) bar("golden model", 1);
  fmt::print("{} ({} images trained)\n", bench.referenceFolder.string(), count);
  return 0;
}

}  // namespace

Command addTrainCommand(CLI::App& app) {
  auto* command = app.add_subcommand("train", "Add images of good parts to the golden model of the bench's reference");
  auto a = std::make_shared<TrainArgs>();
  addBenchArgument(*command, a->bench);
  command->add_option("--images", a->images, "Images to add (each the mean of the bench's inspection frames)")
      ->transform(wholeNumberIn(1LL, 100000LL))
      ->capture_default_str();
  command->add_flag("--prompt", a->prompt, "Wait for Enter before each image (a new good part put in place)");
  command->add_option("--part", a->part, "Simulated bench: the good part of this scene file")->check(CLI::ExistingFile);
  return {command, [a](const GlobalOptions& global) { return runTrain(*a, global); }};
}

}  // namespace lfi::cli
