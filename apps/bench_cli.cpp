// SPDX-License-Identifier: Apache-2.0
#include "bench_cli.h"

#include "lfi/sim/scene_part_model.h"

#include "lfi/core/error.h"
#include "lfi/drivers/device_uri.h"

#include <signal.h>

#include <algorithm>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

std::atomic<int> signalsSeen{0};
struct sigaction previousInt {
}, previousTerm{};

void onSignal(int signal) {
  if (signalsSeen.fetch_add(1) > 0) {  // the second: end now, as the default action would
    ::signal(signal, SIG_DFL);
    ::raise(signal);
  }
}

DeviceUri replaceScene(DeviceUri uri, const char* kind, const fs::path& scene) {
  if (uri.scheme != "sim")
    fail(Errc::Config,
         "--part replaces the part of a simulated bench; the {} '{}' is not sim: (a physical bench "
         "inspects the part that is under its camera)",
         kind, uri);
  uri.path = fs::absolute(scene).lexically_normal().string();
  return uri;
}

}  // namespace

void addBenchArgument(CLI::App& command, fs::path& file) {
  command.add_option("bench", file, "Bench file (docs/inspection.md; data/benches/*.toml)")
      ->required()
      ->check(CLI::ExistingFile);
}

std::string timedFolderName(const char* prefix, const std::string& timeUtc) {
  std::string name = std::string(prefix) + "-" + timeUtc;
  name.erase(std::remove(name.begin(), name.end(), ':'), name.end());
  return name;
}

std::shared_ptr<const PartModel> benchPartModel(const BenchFile& bench) {
  if (bench.partModel.empty()) return nullptr;
  return std::make_shared<const sim::ScenePartModel>(bench.partModel);
}

BenchFile withSimulatedPart(BenchFile bench, const fs::path& scene) {
  bench.cameraUri = replaceScene(bench.cameraUri, "camera", scene);
  bench.displayUri = replaceScene(bench.displayUri, "display", scene);
  return bench;
}

StopOnSignal::StopOnSignal() {
  signalsSeen = 0;
  struct sigaction ours {};
  ours.sa_handler = onSignal;
  sigemptyset(&ours.sa_mask);
  ::sigaction(SIGINT, &ours, &previousInt);
  ::sigaction(SIGTERM, &ours, &previousTerm);
}

StopOnSignal::~StopOnSignal() {
  ::sigaction(SIGINT, &previousInt, nullptr);
  ::sigaction(SIGTERM, &previousTerm, nullptr);
}

bool StopOnSignal::stopRequested() {
  return signalsSeen.load() > 0;
}

}  // namespace lfi::cli
