// SPDX-License-Identifier: Apache-2.0
#include "lfi/emulation/xvfb_screen.h"

#include "lfi/core/error.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <system_error>
#include <vector>

extern char** environ;

namespace lfi::emulation {

namespace fs = std::filesystem;

namespace {

std::string lastLineOf(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

}  // namespace

XvfbScreen::XvfbScreen(int width_px, int height_px) : width_(width_px), height_(height_px) {
  std::string pattern = (fs::temp_directory_path() / "lfi-xvfb-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) fail(Errc::Io, "cannot make a folder for Xvfb: {}", std::strerror(errno));
  folder_ = pattern;
  try {
    launch({});
  } catch (const Error&) {
    std::error_code ignored;
    fs::remove_all(folder_, ignored);
    throw;
  }
}

XvfbScreen::~XvfbScreen() {
  stop();
  std::error_code ignored;
  fs::remove_all(folder_, ignored);
}

void XvfbScreen::start() {
  if (!running()) launch(display_);
}

void XvfbScreen::stop(bool kill) {
  if (pid_ <= 0) return;
  ::kill(pid_, kill ? SIGKILL : SIGTERM);
  for (int i = 0; i < 200 && ::waitpid(pid_, nullptr, WNOHANG) == 0; ++i) ::usleep(10'000);
  if (::waitpid(pid_, nullptr, WNOHANG) == 0) {  // (a server that ignores SIGTERM for 2 s is ended)
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
  pid_ = -1;
}

void XvfbScreen::launch(const std::string& displayArgument) {
  int ready[2];
  if (::pipe2(ready, O_CLOEXEC) != 0) fail(Errc::Device, "Xvfb: cannot make a pipe: {}", std::strerror(errno));
  const std::string screen = std::to_string(width_) + "x" + std::to_string(height_) + "x24";
  const std::string log = (folder_ / "xvfb.log").string(), fbdir = folder_.string();
  std::vector<std::string> args = {"Xvfb"};
  if (!displayArgument.empty()) args.push_back(displayArgument);
  for (const char* a : {"-displayfd", "3", "-screen", "0"}) args.emplace_back(a);
  for (const std::string& a : {screen, std::string("-fbdir"), fbdir}) args.push_back(a);
  for (const char* a : {"-nolisten", "tcp", "-noreset"}) args.emplace_back(a);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, ready[1], 3);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  // The server starts with no signal blocked and SIGTERM's default action, whatever this thread blocks (lfi
  // sim-bench blocks SIGTERM and SIGCHLD to wait for them).
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  for (int s : {SIGTERM, SIGINT, SIGCHLD, SIGPIPE}) sigaddset(&defaults, s);
  posix_spawnattr_setsigmask(&attributes, &none);
  posix_spawnattr_setsigdefault(&attributes, &defaults);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  const int rc = ::posix_spawnp(&pid_, "Xvfb", &actions, &attributes, argv.data(), environ);
  posix_spawnattr_destroy(&attributes);
  posix_spawn_file_actions_destroy(&actions);
  ::close(ready[1]);
  if (rc != 0) {
    ::close(ready[0]);
    pid_ = -1;
    fail(Errc::NotFound, "cannot start Xvfb (Debian package xvfb): {}", std::strerror(rc));
  }
  std::string number;
  pollfd p{ready[0], POLLIN, 0};
  for (char c = 0; ::poll(&p, 1, 10'000) > 0 && ::read(ready[0], &c, 1) == 1 && c != '\n';) number += c;
  ::close(ready[0]);
  if (number.empty()) {
    stop(true);
    fail(Errc::Device, "Xvfb {}did not start within 10 s: {}", displayArgument.empty() ? "" : displayArgument + " ",
         lastLineOf(log));
  }
  display_ = ":" + number;
}

cv::Mat XvfbScreen::screen() const {
  if (!running()) fail(Errc::Device, "Xvfb {}: the server is not running", display_);
  // (One read of the whole file: the served camera reads the screen at every frame.)
  std::ifstream in(folder_ / "Xvfb_screen0", std::ios::binary | std::ios::ate);
  std::vector<unsigned char> file(in ? static_cast<std::size_t>(in.tellg()) : 0);
  in.seekg(0);
  in.read(reinterpret_cast<char*>(file.data()), static_cast<std::streamsize>(file.size()));
  if (!in) file.clear();
  const auto field = [&](int i) {  // the XWD header's CARD32 fields, big-endian
    const unsigned char* b = file.data() + 4 * i;
    return static_cast<std::uint32_t>(b[0]) << 24 | static_cast<std::uint32_t>(b[1]) << 16 |
           static_cast<std::uint32_t>(b[2]) << 8 | b[3];
  };
  if (file.size() < 100) fail(Errc::Device, "Xvfb {}: no framebuffer file in {}", display_, folder_.string());
  const std::uint32_t headerSize = field(0), width = field(4), height = field(5), byteOrder = field(7),
                      bitsPerPixel = field(11), bytesPerLine = field(12), red = field(14), green = field(15),
                      blue = field(16), colours = field(19);
  const std::size_t offset = headerSize + 12 * static_cast<std::size_t>(colours);
  const auto shiftOf = [](std::uint32_t mask) {
    int shift = 0;
    while (shift < 32 && !((mask >> shift) & 1)) ++shift;
    return shift;
  };
  const int r = shiftOf(red), g = shiftOf(green), b = shiftOf(blue);
  if (bitsPerPixel != 32 || byteOrder != 0 || width != static_cast<std::uint32_t>(width_) ||
      height != static_cast<std::uint32_t>(height_) || r >= 32 || g >= 32 || b >= 32 ||
      offset + static_cast<std::size_t>(bytesPerLine) * height > file.size())
    fail(Errc::Device, "Xvfb {}: its framebuffer file is not the 32-bit XWD layout of a {} x {} screen", display_,
         width_, height_);
  cv::Mat rgb(height_, width_, CV_8UC3);
  for (int y = 0; y < height_; ++y) {
    const unsigned char* row = file.data() + offset + static_cast<std::size_t>(y) * bytesPerLine;
    cv::Vec3b* out = rgb.ptr<cv::Vec3b>(y);
    for (int x = 0; x < width_; ++x) {
      const unsigned char* q = row + 4 * x;
      const std::uint32_t pixel = q[0] | q[1] << 8 | q[2] << 16 | static_cast<std::uint32_t>(q[3]) << 24;
      out[x] =
          cv::Vec3b(static_cast<uchar>(pixel >> r), static_cast<uchar>(pixel >> g), static_cast<uchar>(pixel >> b));
    }
  }
  return rgb;
}

}  // namespace lfi::emulation
