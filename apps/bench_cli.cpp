// SPDX-License-Identifier: Apache-2.0
#include "bench_cli.h"

#include <signal.h>

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

}  // namespace

void addBenchArgument(CLI::App& command, fs::path& file) {
  command.add_option("bench", file, "Bench file (docs/inspection.md; data/benches/*.toml)")
      ->required()
      ->check(CLI::ExistingFile);
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
