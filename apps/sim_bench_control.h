// SPDX-License-Identifier: Apache-2.0
#pragma once
// The control socket of `lfi sim-bench` (docs/hardware-in-the-loop.md): a Unix
// stream socket that takes one command per connection, one line each way.
//   request   words separated by spaces ("part /abs/scene.toml", "camera off")
//   reply     "ok[ <what was done>]" or "error <why>"
// `lfi bench-control` is its client; a shell can use any other (socat, nc -U).

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

namespace lfi::cli {

// The variable that names the control socket in the environment of the
// program `lfi sim-bench` runs (and in `lfi sim-bench`'s attach text).
inline constexpr const char* kControlSocketVariable = "LFI_SIM_BENCH_CONTROL";

// Serves the socket at `path` on a thread of its own until destroyed: each
// request line goes to `handle`, whose return is the reply ("ok ..." or
// "error ..."; an lfi::Error it throws becomes "error <message>"). Throws
// Errc::Io when the socket cannot be made (the path exists, is too long, or
// its folder cannot be written).
class ControlServer {
 public:
  using Handler = std::function<std::string(const std::string& request)>;
  ControlServer(std::filesystem::path path, Handler handle);
  ~ControlServer();
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;
  const std::filesystem::path& path() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Sends one request and returns the reply line (without its newline). Throws
// Errc::NotFound when nothing listens at `path`, Errc::Timeout when no reply
// comes within `timeout_ms`, Errc::Io for other socket errors.
std::string sendControl(const std::filesystem::path& path, const std::string& request, int timeout_ms);

}  // namespace lfi::cli
