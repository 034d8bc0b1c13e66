// SPDX-License-Identifier: Apache-2.0
#pragma once
// The `lfi` executable run as a user runs it (LFI_EXECUTABLE, set by the test's
// CMake entry): its exit status and what it printed.

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace lfi::testing_support {

struct LfiResult {
  int status = -1;     // the exit status; -1 when it did not exit normally
  std::string output;  // stdout, and stderr unless `stderrToo` is false
};

// `s` quoted for /bin/sh.
inline std::string shellQuoted(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs `lfi <arguments>` (arguments as the shell reads them), after `prefix`
// (e.g. "timeout --foreground --signal=INT 2 ").
inline LfiResult runLfi(const std::string& arguments, bool stderrToo = true, const std::string& prefix = {}) {
  const std::string command =
      prefix + shellQuoted(LFI_EXECUTABLE) + " " + arguments + (stderrToo ? " 2>&1" : " 2>/dev/null");
  LfiResult run;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return run;
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) run.output.append(buffer, n);
  const int status = pclose(pipe);
  run.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

}  // namespace lfi::testing_support
