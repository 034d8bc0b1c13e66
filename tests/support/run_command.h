// SPDX-License-Identifier: Apache-2.0
#pragma once
// A program run through /bin/sh as a user runs it: its exit status and what it printed.

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace lfi::testing_support {

struct CommandResult {
  int status = -1;     // the exit status; -1 when it did not exit normally
  std::string output;  // stdout, and stderr where the command sends it there
};

// `s` quoted for /bin/sh.
inline std::string shellQuoted(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs `command` with /bin/sh and reads its standard output to the end.
inline CommandResult runCommand(const std::string& command) {
  CommandResult run;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return run;
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) run.output.append(buffer, n);
  const int status = pclose(pipe);
  run.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

}  // namespace lfi::testing_support
