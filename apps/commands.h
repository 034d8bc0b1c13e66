// SPDX-License-Identifier: Apache-2.0
#pragma once
// The interface every lfi subcommand implements: cmd_<name>.cpp defines
// add<Name>Command, which adds the subcommand and its options to the app and
// returns what runs it; main.cpp lists them in kCommands.

#include <CLI/CLI.hpp>

#include <functional>

namespace lfi::cli {

// The options given before the subcommand.
struct GlobalOptions {
  bool quiet = false;  // only errors on stderr: no progress display
};

// Runs the subcommand once the command line is parsed and returns the exit
// status; errors are thrown (lfi::Error), and main turns them into a message.
using CommandRunner = std::function<int(const GlobalOptions&)>;

struct Command {
  CLI::App* subcommand;  // true once parsed when the command line names it
  CommandRunner run;
};

Command addStudyCommand(CLI::App& app);
Command addRenderCommand(CLI::App& app);
Command addServeCameraCommand(CLI::App& app);
Command addCaptureCommand(CLI::App& app);
Command addTrainCommand(CLI::App& app);
Command addInspectCommand(CLI::App& app);
Command addRunCommand(CLI::App& app);
Command addEmitCommand(CLI::App& app);
Command addCalibrateCommand(CLI::App& app);
Command addLfInfoCommand(CLI::App& app);
Command addDevicesCommand(CLI::App& app);
Command addSimBenchCommand(CLI::App& app);
Command addBenchControlCommand(CLI::App& app);

}  // namespace lfi::cli
