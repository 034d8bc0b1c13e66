// SPDX-License-Identifier: Apache-2.0
// lfi-window-bench: presenting a 3840 x 2160 RGB panel through the window:
// display (the frame written into the presenter's shared buffer, SDL2's
// texture upload and copy, the present) on a real X server, Xvfb, started
// here, next to one memcpy of the same bytes in the same run. Xvfb has no
// vertical blank: the figure is the host's own cost per frame, the floor
// under a monitor's refresh.
//   build/release/benchmarks/lfi-window-bench [--frames N] [--width W --height H]

#include "lfi/core/error.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/emulation/xvfb_screen.h"

#include "bench_util.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include <cstdlib>
#include <cstring>
#include <vector>

using lfi::bench::bestSeconds;

static int run(int argc, char** argv) {
  int frames = 10, width = 3840, height = 2160;
  CLI::App app("lfi-window-bench: presenting through the window: display on Xvfb against a memcpy");
  app.add_option("--frames", frames, "Frames per setting (the best is reported)")->check(CLI::Range(1, 100000));
  app.add_option("--width", width, "The output's width")->check(CLI::Range(64, 7680));
  app.add_option("--height", height, "The output's height")->check(CLI::Range(64, 4320));
  CLI11_PARSE(app, argc, argv);
  lfi::registerDriverBackends();
  lfi::emulation::XvfbScreen server(width, height);
  ::setenv("DISPLAY", server.display().c_str(), 1);
  cv::Mat panel(height, width, CV_8UC3);
  cv::randu(panel, 0, 256);
  const double megabytes = static_cast<double>(panel.total() * panel.elemSize()) / 1e6;
  std::vector<unsigned char> copy(panel.total() * panel.elemSize());
  const double copySeconds = bestSeconds(20, [&] { std::memcpy(copy.data(), panel.data, copy.size()); });
  fmt::print("lfi-window-bench: {}x{} RGB panel on Xvfb {}, {:.1f} MB a frame, best of {} frames\n", width, height,
             server.display(), megabytes, frames);
  fmt::print("  memcpy of the same bytes: {:8.2f} ms  ({:.0f} MB/s)\n", copySeconds * 1e3, megabytes / copySeconds);
  for (const char* vsync : {"0", "1"}) {
    auto display = lfi::openDisplay(fmt::format("window:0?pitch_mm=0.05&vsync={}", vsync));
    const double seconds = bestSeconds(frames, [&] {
      const auto r = display->show(panel);
      if (r.status != lfi::PresentStatus::Presented)
        lfi::fail(lfi::Errc::Device, "frame not presented ({}): {}", lfi::toString(r.status), r.message);
    });
    fmt::print("  present, vsync={}:         {:8.2f} ms  ({:.0f} MB/s, {:.0f}x memcpy)\n", vsync, seconds * 1e3,
               megabytes / seconds, seconds / copySeconds);
  }
  return 0;
}

int main(int argc, char** argv) {
  return lfi::bench::runGuarded("lfi-window-bench", [&] { return run(argc, argv); });
}
