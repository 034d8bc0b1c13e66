// SPDX-License-Identifier: Apache-2.0
#pragma once
// The `lfi` executable run as a user runs it (LFI_EXECUTABLE, set by the test's
// CMake entry): its exit status and what it printed.

#include "run_command.h"

#include <string>

namespace lfi::testing_support {

using LfiResult = CommandResult;

// Runs `lfi <arguments>` (arguments as the shell reads them), after `prefix`
// (e.g. "timeout --foreground --signal=INT 2 ").
inline LfiResult runLfi(const std::string& arguments, bool stderrToo = true, const std::string& prefix = {}) {
  return runCommand(prefix + shellQuoted(LFI_EXECUTABLE) + " " + arguments + (stderrToo ? " 2>&1" : " 2>/dev/null"));
}

}  // namespace lfi::testing_support
