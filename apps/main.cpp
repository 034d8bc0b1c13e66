// SPDX-License-Identifier: Apache-2.0
// lfi: the command line front end. Every subcommand reports progress on long
// work to stderr, prints results to stdout, and exits non-zero with one clear
// message on error. Each subcommand is one cmd_<name>.cpp (commands.h).

#include "commands.h"

#include "lfi/controller/coded_capture.h"
#include "lfi/core/error.h"
#include "lfi/core/log.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/sim/devices/sim_camera.h"

#include <CLI/CLI.hpp>

#include <exception>
#include <vector>

namespace {

// The subcommands, in the order `lfi --help` lists them.
constexpr lfi::cli::Command (*kCommands[])(CLI::App&) = {
    lfi::cli::addStudyCommand,    lfi::cli::addRenderCommand,       lfi::cli::addServeCameraCommand,
    lfi::cli::addSimBenchCommand, lfi::cli::addBenchControlCommand, lfi::cli::addCaptureCommand,
    lfi::cli::addTrainCommand,    lfi::cli::addInspectCommand,      lfi::cli::addRunCommand,
    lfi::cli::addEmitCommand,     lfi::cli::addCalibrateCommand,    lfi::cli::addLfInfoCommand,
    lfi::cli::addDevicesCommand,
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"lfi: inverse schlieren inspection bench (drivers and ray-traced simulation)"};
  app.set_version_flag("--version", LFI_VERSION);
  app.require_subcommand(1);
  int verbosity = 0;
  auto* verbose = app.add_flag("-v,--verbose", verbosity, "More log output (repeat for more)");
  lfi::cli::GlobalOptions global;
  app.add_flag("-q,--quiet", global.quiet, "Only errors on stderr")->excludes(verbose);
  std::vector<lfi::cli::Command> commands;
  for (const auto add : kCommands) commands.push_back(add(app));

  CLI11_PARSE(app, argc, argv);
  lfi::initLogging(global.quiet ? -1 : verbosity);

  try {
    // Every device URI scheme a subcommand may be given (aravis:, usb:, sim:, coded:).
    lfi::registerDriverBackends();
    lfi::sim::registerSimBackends();
    lfi::registerControllerBackends();
    for (const lfi::cli::Command& command : commands)
      if (*command.subcommand) return command.run(global);
  } catch (const lfi::Error& e) {
    spdlog::error("{}", e.what());
    return e.code() == lfi::Errc::Cancelled ? 130 : 1;
  } catch (const std::exception& e) {
    spdlog::error("unexpected failure: {}", e.what());
    return 2;
  }
  return 0;
}
