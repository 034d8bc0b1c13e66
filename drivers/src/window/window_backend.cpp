// SPDX-License-Identifier: Apache-2.0
// The window: scheme in the display registry:
// window:<output>?pitch_mm=<mm>[&mode=<w>x<h>&layout=<layout>&vsync=0|1&calibration=<file>&timeout_ms=<ms>].
#include "lfi/core/error.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/window/window_display.h"
#include "presenter_process.h"

#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lfi {
namespace {

const UriKey kPitch{.name = "pitch_mm",
                    .value = UriValue::Number,
                    .unit = "mm",
                    .lo = 1e-4,
                    .hi = 10,
                    .meaning = "the panel's pixel pitch (a monitor cannot state it): required"};
const UriKey kMode{.name = "mode",
                   .value = UriValue::Text,
                   .meaning = "<width>x<height>: the output mode the panel needs (default: the output's current one)"};
const UriKey kLayout{.name = "layout",
                     .value = UriValue::Text,
                     .meaning =
                         "rgb | bgr | mono | mono_subpixels: how panel pixels sit on the output's RGB pixels "
                         "(default rgb)"};
const UriKey kVsync{.name = "vsync",
                    .value = UriValue::Integer,
                    .lo = 0,
                    .hi = 1,
                    .fallback = 1,
                    .meaning = "1: a present waits for the vertical blank; 0: it does not"};
const UriKey kCalibration{.name = "calibration",
                          .value = UriValue::Text,
                          .meaning = "a display calibration file with the optics in front of the panel"};
const UriKey kTimeout{.name = "timeout_ms",
                      .value = UriValue::Integer,
                      .unit = "ms",
                      .lo = 100,
                      .hi = 600'000,
                      .fallback = 5000,
                      .meaning = "how long the window may take to open and each frame to present"};

std::unique_ptr<Display> openWindowFromUri(const DeviceUri& uri) {
  WindowDisplayOptions o;
  o.output = uri.path;
  if (o.output.empty()) fail(Errc::Config, "display URI '{}': name an output (window:<name or index>)", uri.text());
  const auto pitch = uriNumber(uri, kPitch);
  if (!pitch)
    fail(Errc::Config, "display URI '{}': pitch_mm is required: a monitor cannot state its panel's pixel pitch",
         uri.text());
  o.pixelPitch_mm = *pitch;
  if (const std::string* mode = uri.find(kMode.name)) {
    int w = 0, h = 0;
    char end = 0;
    if (std::sscanf(mode->c_str(), "%dx%d%c", &w, &h, &end) != 2 || w < 1 || h < 1 || w > 16384 || h > 16384)
      fail(Errc::Config, "display URI '{}': mode '{}' is not <width>x<height> in 1..16384", uri.text(), *mode);
    o.modeWidth_px = w;
    o.modeHeight_px = h;
  }
  if (const std::string* layout = uri.find(kLayout.name)) o.layout = parseWindowLayout(*layout, uri.text());
  o.vsync = uriNumber<int>(uri, kVsync).value_or(1) != 0;
  if (const std::string* file = uri.find(kCalibration.name)) o.opticsFile = *file;
  o.timeout = std::chrono::milliseconds(uriNumber<int>(uri, kTimeout).value_or(5000));
  return openWindowDisplay(o);
}

}  // namespace

void registerWindowBackend() {
  backendRegistry<Display>().addOnce(DisplayBackend{
      .scheme = "window",
      .keys = {kPitch, kMode, kLayout, kVsync, kCalibration, kTimeout},
      .description = "window:<output>?pitch_mm=<mm>[&mode=<w>x<h>&layout=<layout>&vsync=0|1&calibration=<file>]  "
                     "a panel connected as a monitor (HDMI, DisplayPort, USB display adapter), full screen on the "
                     "output through SDL2 (X11, Wayland or KMS/DRM)",
      .factory = openWindowFromUri,
  });
}

std::vector<WindowOutput> listWindowOutputs(const std::filesystem::path& presenter) {
  const std::filesystem::path exe = window::findPresenter(presenter);
  std::istringstream lines(window::runPresenter(exe, {"--list"}, std::chrono::milliseconds(10'000)));
  std::vector<WindowOutput> outputs;
  for (std::string line; std::getline(lines, line);) {
    std::vector<std::string> f;
    std::istringstream fields(line);
    for (std::string field; std::getline(fields, field, '\t');) f.push_back(field);
    if (f.size() != 8) fail(Errc::Device, "{} --list wrote '{}', not eight fields", exe.string(), line);
    WindowOutput o;
    try {
      o.index = std::stoi(f[0]);
      o.name = f[1];
      o.width_px = std::stoi(f[2]);
      o.height_px = std::stoi(f[3]);
      o.refresh_hz = std::stoi(f[4]) / 1000.0;
      o.x = std::stoi(f[5]);
      o.y = std::stoi(f[6]);
      o.driver = f[7];
    } catch (const std::logic_error&) {
      fail(Errc::Device, "{} --list wrote '{}': not numbers where they belong", exe.string(), line);
    }
    outputs.push_back(std::move(o));
  }
  return outputs;
}

}  // namespace lfi
