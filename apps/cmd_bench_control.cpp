// SPDX-License-Identifier: Apache-2.0
// lfi bench-control REQUEST...: one request to a running `lfi sim-bench`
// (sim_bench_control.h): put another part under the camera, inject a fault,
// or ask its status. Prints the reply; exits 0 for "ok", 1 for an error.

#include "commands.h"
#include "sim_bench_control.h"

#include "lfi/core/error.h"

#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

struct BenchControlArgs {
  fs::path socket;
  std::vector<std::string> request;
  int timeout_ms = 30'000;
};

int runBenchControl(const BenchControlArgs& a) {
  fs::path socket = a.socket;
  if (socket.empty()) {
    const char* fromEnvironment = std::getenv(kControlSocketVariable);
    if (!fromEnvironment || !*fromEnvironment)
      fail(Errc::InvalidArgument,
           "bench-control: no --socket, and {} is not set (`lfi sim-bench` sets it for the "
           "program it runs, and prints it)",
           kControlSocketVariable);
    socket = fromEnvironment;
  }
  std::vector<std::string> words = a.request;
  // A part's scene as this process sees it: the bench resolves no relative path of ours.
  if (words.size() == 2 && words[0] == "part") words[1] = fs::absolute(words[1]).lexically_normal().string();
  std::string request;
  for (const std::string& w : words) request += (request.empty() ? "" : " ") + w;
  const std::string reply = sendControl(socket, request, a.timeout_ms);
  if (reply.rfind("ok", 0) == 0) {
    fmt::print("{}\n", reply.size() > 3 ? reply.substr(3) : "ok");
    return 0;
  }
  fail(Errc::InvalidArgument, "bench-control: {}", reply.rfind("error ", 0) == 0 ? reply.substr(6) : reply);
}

}  // namespace

Command addBenchControlCommand(CLI::App& app) {
  auto* command =
      app.add_subcommand("bench-control",
                         "Send a request to a running `lfi sim-bench`: part [SCENE], trigger, camera off|on, display "
                         "unplug|plug|stall|corrupt|short|hang|answer, packet-loss R, status");
  auto a = std::make_shared<BenchControlArgs>();
  command->add_option("request", a->request, "The request's words")->required();
  command->add_option("--socket", a->socket, fmt::format("Control socket (default: ${})", kControlSocketVariable));
  command->add_option("--timeout-ms", a->timeout_ms, "How long to wait for the reply")->capture_default_str();
  return {command, [a](const GlobalOptions&) { return runBenchControl(*a); }};
}

}  // namespace lfi::cli
