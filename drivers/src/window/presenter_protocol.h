// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the `window:` display (window_display.cpp) and its presenter process
// (lfi-window-presenter, presenter_main.cpp) say to each other: fixed-size
// messages on a SOCK_SEQPACKET socket pair, one message a packet, and the
// frame in a shared memory file the presenter makes and hands over with its
// Ready message (SCM_RIGHTS). The frame is the output's mode in RGB24: three
// bytes a pixel (red, green, blue), rows top to bottom, no padding.
//
//   presenter → display   Ready (mode, refresh, vsync, the frame's file) | Failed
//   display → presenter   Show n | Blank n          (the frame file holds frame n)
//   presenter → display   Presented n (present time) | Failed | Lost
//   display → presenter   Status
//   presenter → display   Status (the window still up on its server) | Lost
//
// The presenter is a process of its own so that a display server that goes
// away (Xlib ends the process it was talking to) or a driver that hangs takes
// the presenter with it, not the program driving the bench.

#include <cstdint>
#include <cstring>
#include <string_view>

namespace lfi::window {

enum class PresenterOp : std::uint32_t {
  Ready = 1,      // presenter: the window is up; the fields say its mode; the frame file comes with it
  Show = 2,       // display: present the frame file's content as frame `sequence`
  Blank = 3,      // display: present black
  Presented = 4,  // presenter: frame `sequence` was presented at presentTime_ns (CLOCK_MONOTONIC)
  Failed = 5,     // presenter: it cannot do what was asked; `errc` and `text` say why; it exits
  Lost = 6,       // presenter: the output, the window or the server went away; it exits
  Status = 7,     // display: is the window still up? presenter: it is, having asked its server
};

// Why a Failed message failed, as lfi::Errc names it (the display throws it).
enum class PresenterErrc : std::int32_t { NotFound = 1, Config = 2, Device = 3 };

struct PresenterMessage {
  PresenterOp op = PresenterOp::Failed;
  std::uint32_t sequence = 0;
  std::int64_t presentTime_ns = 0;  // Presented: when the present returned, CLOCK_MONOTONIC
  std::int32_t width_px = 0;        // Ready: the output's mode
  std::int32_t height_px = 0;
  std::int32_t refresh_mHz = 0;  // Ready: the mode's refresh rate (0: the driver does not say)
  std::int32_t vsync = 0;        // Ready: whether a present waits for the vertical blank
  PresenterErrc errc = PresenterErrc::Device;
  char driver[32] = {};  // Ready: SDL's video driver (x11, wayland, kmsdrm)
  char text[480] = {};   // Failed, Lost: the reason in words; Ready: the output's name

  void setText(std::string_view s) {
    const std::size_t n = s.size() < sizeof text - 1 ? s.size() : sizeof text - 1;
    std::memcpy(text, s.data(), n);
    text[n] = '\0';
  }
  std::string_view textView() const { return {text, ::strnlen(text, sizeof text)}; }
};

// File descriptor of the presenter's end of the socket pair.
constexpr int kPresenterSocketFd = 3;

}  // namespace lfi::window
