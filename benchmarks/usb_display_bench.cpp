// SPDX-License-Identifier: Apache-2.0
// lfi-usb-display-bench: host-side upload throughput of the usb: display
// backend (libusb, asynchronous bulk transfers) into the emulated USB display
// (umockdev), 1 transfer in flight against 4, next to the memcpy time of the
// same bytes in the same run. The emulation has no USB bus timing: the figure
// is the host stack's own cost per frame (libusb, usbdevfs emulation, CRC),
// the floor under what a real 480 Mb/s link adds.
//
// Run through the umockdev launcher:
//   tests/drivers/run_with_umockdev.sh build/release/bench/lfi-usb-display-bench [frames]

#include "lfi/core/error.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/usb/usb_display.h"

#include "bench_util.h"
#include "lfi/emulation/emulated_usb_display.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include <chrono>
#include <cstring>
#include <vector>

using lfi::bench::bestSeconds;

static int run(int argc, char** argv) {
  int frames = 5;
  CLI::App app("lfi-usb-display-bench: upload through the usb: backend into the emulated display");
  app.add_option("frames", frames, "Frames per setting")->check(CLI::Range(1, 100000));
  CLI11_PARSE(app, argc, argv);
  lfi::emulation::usePrivateTmpDir();
  if (!lfi::emulation::umockdevPreloadActive()) {
    fmt::print(stderr, "lfi-usb-display-bench: run it through tests/drivers/run_with_umockdev.sh\n");
    return 2;
  }
  lfi::emulation::EmulatedDisplayConfig config;
  config.panelWidth_px = 3840;
  config.panelHeight_px = 2160;
  config.subpixels = lfi::usbdisplay::SubpixelCode::RgbStripe;
  lfi::emulation::EmulatedUsbDisplay device(config);
  device.plug();
  cv::Mat panel(config.panelHeight_px, config.panelWidth_px, CV_8UC3);
  cv::randu(panel, 0, 256);
  const double megabytes = static_cast<double>(panel.total() * panel.elemSize()) / 1e6;
  std::vector<unsigned char> copy(panel.total() * panel.elemSize());
  const double copySeconds = bestSeconds(20, [&] { std::memcpy(copy.data(), panel.data, copy.size()); });
  fmt::print("lfi-usb-display-bench: {}x{} RGB panel, {:.1f} MB per frame, best of {} frames\n", panel.cols, panel.rows,
             megabytes, frames);
  fmt::print("  memcpy of the same bytes:     {:8.2f} ms  ({:.0f} MB/s)\n", copySeconds * 1e3, megabytes / copySeconds);
  for (int inFlight : {1, 4}) {
    lfi::UsbDisplayOptions options;
    options.transfersInFlight = inFlight;
    options.transferTimeout = std::chrono::seconds(20);
    auto display = lfi::openUsbDisplay(lfi::parseUsbDisplayPath("1209:4c46", "usb:1209:4c46"), options);
    const double seconds = bestSeconds(frames, [&] {
      const auto r = display->show(panel);
      // (a frame that failed fast must not pass for a fast upload)
      if (r.status != lfi::PresentStatus::Presented)
        lfi::fail(lfi::Errc::Device, "frame not presented ({}): {}", lfi::toString(r.status), r.message);
    });
    fmt::print("  upload, {} transfer(s) in flight: {:8.2f} ms  ({:.0f} MB/s, {:.0f}x memcpy)\n", inFlight,
               seconds * 1e3, megabytes / seconds, seconds / copySeconds);
  }
  return 0;
}

int main(int argc, char** argv) {
  return lfi::bench::runGuarded("lfi-usb-display-bench", [&] { return run(argc, argv); });
}
