// SPDX-License-Identifier: Apache-2.0
#pragma once
// The `window:` display backend: a panel connected as a monitor (HDMI,
// DisplayPort, a USB display adapter) driven through the graphics stack with
// SDL2, which runs under an X11 or Wayland desktop and, with none, on KMS/DRM.
// SDL2 is private to lfi_drivers and lives in a process of its own, the
// presenter (lfi-window-presenter): a display server that goes away ends that
// process, and this side reports it as a Device error.
//
// Behaviour:
//   - open() starts the presenter, which opens a borderless full-screen window
//     on the output, checks that the output is in the mode the panel needs and
//     that the window and its drawable are that mode's size (no scaling), and
//     hands over a shared frame buffer of the mode's size.
//   - show() writes the panel image into the frame buffer in the output's
//     pixel layout (WindowLayout), has the presenter present it 1:1, and
//     returns when the present returned: after the vertical blank with vsync
//     on. DisplayStatus::lastPresent holds that moment (CLOCK_MONOTONIC,
//     measured: SDL2 does not pass on the driver's own time stamp).
//   - status() asks the presenter, which asks its display server, whether
//     the window is still up on the output.
//   - The output disconnected, the window closed, hidden or minimised, or the
//     display server gone: Errc::Device naming the output, from the next
//     show(), blank() or status(); the presenter not answering within the
//     timeout: Errc::Timeout. The display is then Closed; open() starts a new
//     presenter.
//   - A monitor cannot state the optics on it or its pixel pitch: the URI
//     gives the pitch (pitch_mm) and may name a display calibration file for
//     the optics (calibration=), as usb: does; a bench file's [display.optics]
//     gives them in its place. Until something does, info().opticsStated is
//     false and DisplayInfo::validate() says so.
//   - Messages name the display as "window:<output>".

#include "lfi/drivers/display.h"

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lfi {

// How the panel's pixels sit on the output's RGB pixels.
enum class WindowLayout {
  Rgb,            // one colour panel pixel per output pixel, subpixels red, green, blue left to right
  Bgr,            // the same, subpixels blue, green, red left to right
  Mono,           // one grey panel pixel per output pixel: red, green and blue all carry its level
  MonoSubpixels,  // three mono panel pixels per output pixel (a resin printer's mono LCD): red, green and
                  // blue carry the left, middle and right one; the panel is three times the mode's width
};
const char* toString(WindowLayout layout);  // "rgb", "bgr", "mono", "mono_subpixels"
// Throws Errc::Config naming `uriForMessages` and the layouts for another word.
WindowLayout parseWindowLayout(std::string_view word, const std::string& uriForMessages);

struct WindowDisplayOptions {
  std::string output;  // the output's name as `lfi devices` lists it, or its index
  bool vsync = true;   // a present waits for the vertical blank
  WindowLayout layout = WindowLayout::Rgb;
  std::optional<int> modeWidth_px;  // the mode the panel needs, output pixels; none: the output's current one
  std::optional<int> modeHeight_px;
  double pixelPitch_mm = 0;                 // the panel's (square) pixel pitch; 0: not stated
  std::filesystem::path opticsFile;         // a display calibration file with the optics (display_calibration_file.h)
  std::chrono::milliseconds timeout{5000};  // the presenter's start and each present
  // The presenter executable; empty: $LFI_WINDOW_PRESENTER, else the one built beside this library or installed
  // with it (libexec/lfi/lfi-window-presenter).
  std::filesystem::path presenter;

  std::string uri() const;  // "window:<output>"
};

// One output of the graphics stack, as the presenter's SDL2 sees it.
struct WindowOutput {
  int index = 0;
  std::string name;
  int width_px = 0;  // the current mode
  int height_px = 0;
  double refresh_hz = 0;    // 0: the driver does not say
  int x = 0, y = 0;         // the output's place on the desktop
  std::string driver;       // SDL2's video driver: x11, wayland, kmsdrm
  std::string uri() const;  // "window:<index>"
};

// The outputs the display server (or KMS/DRM) has. Throws Errc::NotFound when
// SDL2 finds no display server or device, naming what it tried.
std::vector<WindowOutput> listWindowOutputs(const std::filesystem::path& presenter = {});

// Returns an Open display. Throws Errc::NotFound for an output that is not
// there (listing those that are), Errc::Config for a mode other than the one
// needed or a scaled output (naming the output, the mode found and the mode
// needed), Errc::Device when the window cannot be made, Errc::Timeout when the
// presenter does not answer.
std::unique_ptr<Display> openWindowDisplay(const WindowDisplayOptions& options);

// Adds the window: scheme to the display registry (registerDriverBackends() calls it). Idempotent.
void registerWindowBackend();

}  // namespace lfi
