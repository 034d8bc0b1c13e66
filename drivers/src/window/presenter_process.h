// SPDX-License-Identifier: Apache-2.0
#pragma once
// lfi-window-presenter as a child process: found, started with its socket on
// fd 3 and its stderr on a pipe, talked to (presenter_protocol.h) and ended.

#include "presenter_protocol.h"

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace lfi::window {

// The presenter executable: `given` when not empty, else $LFI_WINDOW_PRESENTER, else the one built beside
// this library (for a program that runs from the build tree) or installed with it. Throws Errc::NotFound
// naming the places looked at.
std::filesystem::path findPresenter(const std::filesystem::path& given);

// What a presenter run with `args` wrote to stdout, for --list. Throws Errc::NotFound with its stderr when it
// fails (no display server), Errc::Timeout when it does not end within `timeout`.
std::string runPresenter(const std::filesystem::path& presenter, const std::vector<std::string>& args,
                         std::chrono::milliseconds timeout);

class PresenterProcess {
 public:
  // Starts it. `device` names the display in messages. Throws Errc::NotFound or Errc::Device.
  static std::unique_ptr<PresenterProcess> start(const std::filesystem::path& presenter,
                                                 const std::vector<std::string>& args, std::string device);
  // Closes the socket (the presenter's cue to end), waits a moment for it, then kills it.
  ~PresenterProcess();
  PresenterProcess(const PresenterProcess&) = delete;
  PresenterProcess& operator=(const PresenterProcess&) = delete;

  // Throws Errc::Device when the presenter is gone.
  void send(const PresenterMessage& message);
  // The next message, and the file descriptor it carries into *fd when fd is given. Throws Errc::Timeout
  // naming `what` when none comes within `timeout`, Errc::Device (with how the presenter ended and the last
  // line it wrote to stderr) when the presenter is gone.
  PresenterMessage receive(std::chrono::milliseconds timeout, const char* what, int* fd = nullptr);

 private:
  PresenterProcess(pid_t pid, int socket, int errors, std::string device)
      : pid_(pid), socket_(socket), errors_(errors), device_(std::move(device)) {}
  [[noreturn]] void gone();
  std::string lastWords();

  pid_t pid_;
  int socket_;
  int errors_;  // read end of its stderr
  std::string device_;
  std::string stderr_;
};

}  // namespace lfi::window
