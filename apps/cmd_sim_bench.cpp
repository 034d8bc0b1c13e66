// SPDX-License-Identifier: Apache-2.0
// lfi sim-bench BENCH [-- COMMAND ...]: the simulated bench of a bench file
// behind the real drivers (served_bench.h): its camera as a GigE Vision device
// (or a USB3 Vision one), its display as an emulated lfi USB display (or a
// monitor), and a control socket that puts
// another part under the camera and injects faults. With COMMAND, runs it with
// the emulation in its environment (as umockdev-run does) and exits with its
// status; without, prints how to attach and serves until SIGINT or SIGTERM.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"
#include "sim_bench_control.h"

#include "lfi/core/error.h"
#include "lfi/core/log.h"
#include "lfi/drivers/backend_registry.h"
#include "lfi/emulation/bench_control.h"
#include "lfi/emulation/served_bench.h"

#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

extern char** environ;

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

struct SimBenchArgs {
  fs::path bench, part, control;
  lfi::emulation::ServedBenchOptions options;
  std::vector<std::string> command;
};

// The scene of a bench whose camera and display are sim: on one scene file.
fs::path benchScene(const BenchFile& bench) {
  const DeviceUri& camera = bench.cameraUri;
  const DeviceUri& display = bench.displayUri;
  std::error_code ec;
  if (camera.scheme != "sim" || display.scheme != "sim" || !fs::equivalent(camera.path, display.path, ec))
    fail(Errc::Config,
         "sim-bench: '{}' is not a simulated bench: its camera ('{}') and display ('{}') must be sim: "
         "on one scene file (data/benches/inspection_sim.toml is one)",
         bench.file.string(), bench.cameraUri, bench.displayUri);
  return camera.path;
}

std::string status(lfi::emulation::ServedBench& bench) {
  const auto c = bench.counters();
  return fmt::format(
      "part {}; camera {}; display {}; {} frames served ({:.1f} ms each); {} panels presented; {} part "
      "changes, {} camera restarts, {} display re-plugs",
      bench.part().string(), bench.cameraServing() ? "serving" : "off",
      bench.displayPlugged() ? "plugged" : "unplugged", c.framesServed,
      c.framesServed ? 1e3 * c.frameSeconds / static_cast<double>(c.framesServed) : 0.0, c.panelsPresented,
      c.partChanges, c.cameraRestarts, c.displayReplugs);
}

// One control request (docs/hardware-in-the-loop.md lists them; an lfi::Error becomes the reply "error <why>").
std::string control(lfi::emulation::ServedBench& bench, const fs::path& intact, const std::string& line) {
  using Action = lfi::emulation::BenchControlRequest::Action;
  const lfi::emulation::BenchControlRequest request = lfi::emulation::parseBenchControlRequest(line);
  const std::string& what = request.argument;
  std::string done;
  const auto edge = [](bool triggered) {
    return triggered ? "; Line0 triggered a frame"
                     : "; Line0 fired (no frame: the camera does not acquire with TriggerSource Line0)";
  };
  switch (request.action) {
    case Action::Part: {
      const bool triggered = bench.putPart(what.empty() ? intact : fs::path(what));
      done = "part " + bench.part().string() + edge(triggered);
      break;
    }
    case Action::Trigger:
      done = std::string("trigger") + edge(bench.fireLine());
      break;
    case Action::CameraOff:
      bench.stopCamera();
      done = "camera off";
      break;
    case Action::CameraOn:
      bench.startCamera();
      done = "camera on";
      break;
    case Action::PacketLoss:
      bench.setPacketLoss(request.packetLoss);
      done = "packet loss " + what;
      break;
    case Action::DisplayUnplug:
      bench.unplugDisplay();
      done = "display unplugged";
      break;
    case Action::DisplayPlug:
      bench.plugDisplay();
      done = "display plugged";
      break;
    case Action::DisplayStall:
      bench.display().stallNextFrame();
      done = "the display's next frame stalls its endpoint";
      break;
    case Action::DisplayCorrupt:
      bench.display().corruptNextFrame();
      done = "the display's next frame arrives with a bad payload CRC";
      break;
    case Action::DisplayShort:
      bench.display().shortenNextFrame(0, 512);
      done = "the display takes 512 bytes fewer of the next frame's first transfer";
      break;
    case Action::DisplayHang:
      bench.display().setSilent(true);
      done = "the display takes requests and answers none";
      break;
    case Action::DisplayAnswer:
      bench.display().setSilent(false);
      done = "the display answers again";
      break;
    case Action::Status:
      return "ok " + status(bench);
  }
  spdlog::info("sim-bench: {}", done);
  return "ok " + done;
}

// Runs this process again under umockdev's preload library unless it is: the
// testbed announces a display plugged in or unplugged with a uevent that
// libudev builds from the testbed's /sys, which only the preload library shows
// (COMMAND inherits it, as umockdev-run's program does).
void runUnderPreload() {
  if (lfi::emulation::umockdevPreloadActive()) return;
  std::ifstream file("/proc/self/cmdline", std::ios::binary);
  std::vector<std::string> args;
  for (std::string arg; std::getline(file, arg, '\0');) args.push_back(arg);
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const char* preload = std::getenv("LD_PRELOAD");
  const std::string preloads =
      std::string("libumockdev-preload.so.0") + (preload && *preload ? std::string(":") + preload : "");
  // (an ASan-built program refuses a library loaded before its runtime unless told)
  const char* asan = std::getenv("ASAN_OPTIONS");
  const std::string asanOptions = (asan && *asan ? std::string(asan) + ":" : "") + "verify_asan_link_order=0";
  ::setenv("LD_PRELOAD", preloads.c_str(), 1);
  ::setenv("ASAN_OPTIONS", asanOptions.c_str(), 1);
  ::execv("/proc/self/exe", argv.data());
  fail(Errc::Device, "sim-bench: cannot run itself again under umockdev's preload library: {}", std::strerror(errno));
}

// COMMAND's environment: ours (with umockdev's preload library and its
// testbed), the devices' URIs and the control socket, and the caller's TMPDIR
// (ours is the testbed's private one).
std::vector<std::string> childEnvironment(const lfi::emulation::ServedBench& bench, const fs::path& control,
                                          const std::optional<std::string>& callerTmpDir) {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e)
    if (std::strncmp(*e, "TMPDIR=", 7) != 0 && std::strncmp(*e, "LFI_SIM_BENCH_", 14) != 0) env.emplace_back(*e);
  if (callerTmpDir) env.push_back("TMPDIR=" + *callerTmpDir);
  env.push_back(std::string(kControlSocketVariable) + "=" + control.string());
  env.push_back("LFI_SIM_BENCH_CAMERA=" + bench.cameraUri().text());
  env.push_back("LFI_SIM_BENCH_DISPLAY=" + bench.displayUri().text());
  if (const std::string x = bench.xDisplay(); !x.empty()) {  // (a monitor: its X server, in place of the caller's)
    std::erase_if(env, [](const std::string& e) { return e.starts_with("DISPLAY=") || e.starts_with("WAYLAND_"); });
    env.push_back("DISPLAY=" + x);
  }
  return env;
}

int runSimBench(SimBenchArgs a) {
  runUnderPreload();
  // Blocked before any thread starts (every thread inherits the mask), so that
  // they reach sigwaitinfo() below; COMMAND starts with none blocked.
  sigset_t signals;
  sigemptyset(&signals);
  for (int s : {SIGINT, SIGTERM, SIGCHLD}) sigaddset(&signals, s);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  const BenchFile file = readBenchFile(a.bench);
  const fs::path intact = benchScene(file);
  a.options.scene = intact;
  a.options.u3v.serial = a.options.camera.serial;  // (one --camera-serial for either transport)
  std::optional<std::string> callerTmpDir;
  if (const char* tmp = std::getenv("TMPDIR")) callerTmpDir = tmp;
  lfi::emulation::usePrivateTmpDir();  // (the testbed's files, removed at exit)
  lfi::emulation::ServedBench bench(a.options);
  if (!a.part.empty()) bench.putPart(a.part);
  const fs::path socket = a.control.empty() ? fs::temp_directory_path() / "control.sock" : a.control;
  ControlServer server(socket, [&](const std::string& request) { return control(bench, intact, request); });
  spdlog::info("sim-bench: '{}' served: camera {}, display {}, control {}", a.bench.string(), bench.cameraUri(),
               bench.displayUri(), socket.string());

  pid_t child = 0;
  if (!a.command.empty()) {
    const std::vector<std::string> env = childEnvironment(bench, socket, callerTmpDir);
    std::vector<char*> argv, envp;
    for (const std::string& s : a.command) argv.push_back(const_cast<char*>(s.c_str()));
    argv.push_back(nullptr);
    for (const std::string& s : env) envp.push_back(const_cast<char*>(s.c_str()));
    envp.push_back(nullptr);
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    sigset_t none;
    sigemptyset(&none);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK);
    const int rc = posix_spawnp(&child, argv[0], nullptr, &attr, argv.data(), envp.data());
    posix_spawnattr_destroy(&attr);
    if (rc != 0) fail(Errc::NotFound, "sim-bench: cannot run '{}': {}", a.command[0], std::strerror(rc));
  } else {
    fmt::print(
        "camera   {}\ndisplay  {}\ncontrol  {}\n"
        "Run a program against this bench with its devices in the environment:\n"
        "  UMOCKDEV_DIR={} LD_PRELOAD={} {}={}{} lfi run BENCH\n"
        "(BENCH names the camera and display by the URIs above: data/benches/inspection_hil.toml, or "
        "inspection_window.toml for --display window.)\n"
        "SIGINT or SIGTERM stops.\n",
        bench.cameraUri(), bench.displayUri(), socket.string(), std::getenv("UMOCKDEV_DIR"), std::getenv("LD_PRELOAD"),
        kControlSocketVariable, socket.string(), bench.xDisplay().empty() ? "" : " DISPLAY=" + bench.xDisplay());
    std::fflush(stdout);
  }
  for (;;) {
    siginfo_t info{};
    if (sigwaitinfo(&signals, &info) < 0) continue;
    if (info.si_signo == SIGCHLD) {
      int exit = 0;
      if (child > 0 && ::waitpid(child, &exit, WNOHANG) == child) {
        spdlog::info("sim-bench: {}", status(bench));
        return WIFEXITED(exit) ? WEXITSTATUS(exit) : 128 + WTERMSIG(exit);
      }
      continue;
    }
    if (child > 0) {
      ::kill(child, info.si_signo);  // (COMMAND decides; its end ends the bench)
      continue;
    }
    spdlog::info("sim-bench: {} received, stopping; {}", info.si_signo == SIGINT ? "SIGINT" : "SIGTERM", status(bench));
    return 0;
  }
}

}  // namespace

Command addSimBenchCommand(CLI::App& app) {
  auto* command = app.add_subcommand(
      "sim-bench",
      "Serve a simulated bench to the real drivers (GigE Vision or USB3 Vision camera; USB display or a monitor on an "
      "X server) and run COMMAND against it");
  auto a = std::make_shared<SimBenchArgs>();
  a->options.display.serial = "LFI-SIM-0001";
  addBenchArgument(*command, a->bench);
  command->add_option("--part", a->part, "The part in place at the start: a scene file (default: the bench's)")
      ->check(CLI::ExistingFile);
  command->add_option("--interface", a->options.camera.interfaceAddress, "IPv4 address or interface to serve on")
      ->capture_default_str();
  command
      ->add_option("--camera", a->options.cameraKind,
                   "How the camera is served: gige (a GigE Vision device on the network) or u3v (a USB3 Vision device "
                   "on the emulated USB bus)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, lfi::emulation::ServedCamera>{
          {"gige", lfi::emulation::ServedCamera::GigE}, {"u3v", lfi::emulation::ServedCamera::U3v}}));
  command
      ->add_option("--camera-serial", a->options.camera.serial,
                   "Camera serial (id: lfi-SimCamera-<serial>; over USB3 Vision lfi-<GUID>-<serial>)")
      ->capture_default_str();
  command->add_option("--display-serial", a->options.display.serial, "USB display serial")->capture_default_str();
  command
      ->add_option("--display", a->options.displayKind,
                   "How the display is served: usb (an lfi USB display) or window (a monitor: an X server, Xvfb, "
                   "with the panel's mode, for the window: backend)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, lfi::emulation::ServedDisplay>{
          {"usb", lfi::emulation::ServedDisplay::Usb}, {"window", lfi::emulation::ServedDisplay::Window}}));
  command->add_option("--control", a->control, "Control socket (default: in the bench's private TMPDIR)");
  command->add_option("--threads", a->options.renderThreads, "Render threads (0 = all cores)")
      ->transform(threadCount());
  command->add_option("command", a->command, "Program to run against the bench (after --)");
  return {command, [a](const GlobalOptions&) { return runSimBench(*a); }};
}

}  // namespace lfi::cli
