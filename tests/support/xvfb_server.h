// SPDX-License-Identifier: Apache-2.0
#pragma once
// A real X server for the window: display's tests: Xvfb on a display number it
// picks itself (-displayfd), one screen of the given mode at 24 bits, its
// framebuffer in a memory-mapped XWD file (-fbdir) that the test reads back.
// The server's DISPLAY is set in this process's environment while it runs, so
// the presenters the display starts talk to it.

#include "lfi_test_support.h"
#include "test_folder.h"

#include <opencv2/core.hpp>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace lfi::testing_support {

class XvfbServer {
 public:
  // Starts Xvfb with one screen of width x height; throws std::runtime_error when it does not come up.
  XvfbServer(int width, int height) : folder_("lfi-xvfb-" + std::to_string(++count())) {
    int ready[2];
    if (::pipe(ready) != 0) throw std::runtime_error("xvfb: no pipe");
    const std::string fd = std::to_string(ready[1]),
                      screen = std::to_string(width) + "x" + std::to_string(height) + "x24";
    const std::string fbdir = folder_.path().string();
    std::vector<std::string> args = {"Xvfb",   "-displayfd", fd,          "-screen", "0",       screen,
                                     "-fbdir", fbdir,        "-nolisten", "tcp",     "-noreset"};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 2, (fbdir + "/xvfb.log").c_str(), O_WRONLY | O_CREAT, 0644);
    const int rc = ::posix_spawnp(&pid_, "Xvfb", &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(ready[1]);
    if (rc != 0) {
      ::close(ready[0]);
      throw std::runtime_error("xvfb: cannot start Xvfb (Debian package xvfb)");
    }
    std::string number;
    pollfd p{ready[0], POLLIN, 0};
    for (char c = 0; ::poll(&p, 1, 10'000) > 0 && ::read(ready[0], &c, 1) == 1 && c != '\n';) number += c;
    ::close(ready[0]);
    if (number.empty()) {
      stop();
      throw std::runtime_error("xvfb: the server did not start within 10 s; see " + fbdir + "/xvfb.log");
    }
    display_ = ":" + number;
    ::setenv("DISPLAY", display_.c_str(), 1);
  }
  ~XvfbServer() {
    stop();
    ::unsetenv("DISPLAY");
  }
  XvfbServer(const XvfbServer&) = delete;
  XvfbServer& operator=(const XvfbServer&) = delete;

  const std::string& display() const { return display_; }

  // Ends the server at once, as a crash or a lost session would.
  void kill() {
    if (pid_ > 0) ::kill(pid_, SIGKILL);
    stop();
  }

  // The screen as the server holds it: CV_8UC3 in red, green, blue order, read from Xvfb's XWD file.
  cv::Mat screen() const {
    std::ifstream in(folder_.path() / "Xvfb_screen0", std::ios::binary);
    const std::vector<unsigned char> file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto field = [&](int i) {  // the header's CARD32 fields, big-endian
      const unsigned char* b = file.data() + 4 * i;
      return static_cast<std::uint32_t>(b[0]) << 24 | static_cast<std::uint32_t>(b[1]) << 16 |
             static_cast<std::uint32_t>(b[2]) << 8 | b[3];
    };
    if (file.size() < 100) throw std::runtime_error("xvfb: no framebuffer file");
    const std::uint32_t headerSize = field(0), width = field(4), height = field(5), byteOrder = field(7),
                        bitsPerPixel = field(11), bytesPerLine = field(12), red = field(14), green = field(15),
                        blue = field(16), colours = field(19);
    const std::size_t offset = headerSize + 12 * static_cast<std::size_t>(colours);
    if (bitsPerPixel != 32 || byteOrder != 0 || offset + bytesPerLine * height > file.size())
      throw std::runtime_error("xvfb: a framebuffer layout this reader does not know");
    cv::Mat rgb(static_cast<int>(height), static_cast<int>(width), CV_8UC3);
    const auto channel = [](std::uint32_t pixel, std::uint32_t mask) {
      int shift = 0;
      while (!((mask >> shift) & 1)) ++shift;
      return static_cast<unsigned char>((pixel & mask) >> shift);
    };
    for (std::uint32_t y = 0; y < height; ++y)
      for (std::uint32_t x = 0; x < width; ++x) {
        const unsigned char* b = file.data() + offset + y * bytesPerLine + 4 * x;
        const std::uint32_t pixel = b[0] | b[1] << 8 | b[2] << 16 | static_cast<std::uint32_t>(b[3]) << 24;
        rgb.at<cv::Vec3b>(static_cast<int>(y), static_cast<int>(x)) =
            cv::Vec3b(channel(pixel, red), channel(pixel, green), channel(pixel, blue));
      }
    return rgb;
  }

 private:
  static int& count() {  // (servers this process started: each its own folder)
    static int n = 0;
    return n;
  }
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

  TestFolder folder_;
  pid_t pid_ = -1;
  std::string display_;
};

}  // namespace lfi::testing_support
