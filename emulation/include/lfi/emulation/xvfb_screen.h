// SPDX-License-Identifier: Apache-2.0
#pragma once
// A monitor for the window: display that a test or the simulated bench can
// read: a real X server, Xvfb, with one screen of the given mode at 24 bits,
// its framebuffer in a memory-mapped XWD file (-fbdir) read back here. The
// server picks its display number when first started (-displayfd) and keeps
// it across a stop and a start, so that a client that names it finds the
// server that comes back. Clients reach it through DISPLAY=display(); this
// class does not touch the environment.

#include <opencv2/core.hpp>

#include <sys/types.h>

#include <filesystem>
#include <string>

namespace lfi::emulation {

class XvfbScreen {
 public:
  // Starts Xvfb. Throws Errc::NotFound when Xvfb is not installed, Errc::Device when it does not come up
  // within 10 s (its log's last line in the message).
  XvfbScreen(int width_px, int height_px);
  ~XvfbScreen();  // stops the server, removes its folder
  XvfbScreen(const XvfbScreen&) = delete;
  XvfbScreen& operator=(const XvfbScreen&) = delete;

  const std::string& display() const { return display_; }  // ":<number>"
  int width() const { return width_; }
  int height() const { return height_; }
  bool running() const { return pid_ > 0; }

  // Ends the server: politely (SIGTERM), or at once (SIGKILL: a crash, a lost session). Idempotent.
  void stop(bool kill = false);
  // Starts it again on the same display number. Idempotent. Throws as the constructor.
  void start();

  // The screen as the server holds it now: CV_8UC3 in red, green, blue order. Throws Errc::Device when the
  // server is not running or its framebuffer file is not the XWD layout Xvfb writes.
  cv::Mat screen() const;

 private:
  void launch(const std::string& displayArgument);

  int width_, height_;
  std::filesystem::path folder_;  // the framebuffer file and the server's log
  pid_t pid_ = -1;
  std::string display_;
};

}  // namespace lfi::emulation
