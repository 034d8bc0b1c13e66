// SPDX-License-Identifier: Apache-2.0
// lfi-window-presenter: the process that holds the `window:` display's
// full-screen window (SDL2: X11, Wayland or KMS/DRM, whichever SDL finds) and
// presents the frames the display hands it (presenter_protocol.h).
//
//   lfi-window-presenter --list
//       one line per output: index, name, width, height, refresh (mHz), x, y,
//       tab-separated
//   lfi-window-presenter --output <name|index> --vsync 0|1 [--mode <w>x<h>]
//       the window, on the socket at fd 3
//
// A frame is shown 1:1: an RGB24 texture of the mode's size copied onto a
// drawable of that size with nearest sampling, so no pixel is scaled,
// filtered, converted or dithered. The presenter refuses a window it cannot
// make so: a mode other than the one asked for, or a window or drawable of
// another size than the mode (a scaled output, a window manager that did not
// make it full screen).
#include "presenter_protocol.h"

#include <SDL.h>
#include <poll.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

// Under LeakSanitizer (the sanitizer builds): what SDL2, Xlib and the drivers under them keep until the process
// ends is theirs, not a leak of this program's.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libSDL2\nleak:libX11\nleak:libxcb\nleak:libdbus\nleak:libwayland\nleak:libGLX\nleak:libGL\n"
         "leak:libEGL\nleak:libdrm\nleak:libgbm\nleak:dri.so\nleak:libLLVM\n";
}

namespace {

using lfi::window::kPresenterSocketFd;
using lfi::window::PresenterErrc;
using lfi::window::PresenterMessage;
using lfi::window::PresenterOp;

std::string describeOutput(int index) {
  SDL_DisplayMode mode{};
  SDL_GetCurrentDisplayMode(index, &mode);
  const char* name = SDL_GetDisplayName(index);
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, "%d '%s' %dx%d at %.3g Hz", index, name ? name : "", mode.w, mode.h,
                static_cast<double>(mode.refresh_rate));
  return buffer;
}

std::string outputList() {
  std::string list;
  for (int i = 0; i < SDL_GetNumVideoDisplays(); ++i) list += (i ? ", " : "") + describeOutput(i);
  return list.empty() ? "none" : list;
}

void send(const PresenterMessage& m, int fd = -1) {
  msghdr header{};
  iovec part{const_cast<PresenterMessage*>(&m), sizeof m};
  header.msg_iov = &part;
  header.msg_iovlen = 1;
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
  if (fd >= 0) {
    header.msg_control = control;
    header.msg_controllen = sizeof control;
    cmsghdr* c = CMSG_FIRSTHDR(&header);
    c->cmsg_level = SOL_SOCKET;
    c->cmsg_type = SCM_RIGHTS;
    c->cmsg_len = CMSG_LEN(sizeof(int));
    std::memcpy(CMSG_DATA(c), &fd, sizeof fd);
  }
  (void)::sendmsg(kPresenterSocketFd, &header, MSG_NOSIGNAL);
}

[[noreturn]] void finish(PresenterOp op, PresenterErrc errc, const std::string& text) {
  PresenterMessage m;
  m.op = op;
  m.errc = errc;
  m.setText(text);
  send(m);
  SDL_Quit();
  std::exit(op == PresenterOp::Lost ? 3 : 2);
}

[[noreturn]] void fail(PresenterErrc errc, const std::string& text) {
  finish(PresenterOp::Failed, errc, text);
}

std::string sdlError(const char* what) {
  return std::string(what) + ": " + SDL_GetError();
}

// SDL2 with a driver that shows on an output (X11, Wayland, KMS/DRM), or the reason there is none: SDL falls
// back to drivers that show nothing (offscreen, dummy) when it finds no display server.
std::string startVideo() {
  if (SDL_Init(SDL_INIT_VIDEO) != 0)
    return sdlError(
        "SDL2 finds no display server and no KMS/DRM device (DISPLAY, WAYLAND_DISPLAY; the video "
        "group for /dev/dri)");
  const std::string_view driver = SDL_GetCurrentVideoDriver();
  if (driver == "x11" || driver == "wayland" || driver == "kmsdrm") return {};
  SDL_Quit();
  return "SDL2 finds no display server and no KMS/DRM device, only its '" + std::string(driver) +
         "' driver, which shows nothing (set DISPLAY or WAYLAND_DISPLAY; the video group for /dev/dri)";
}

int findOutput(std::string_view output) {
  const int count = SDL_GetNumVideoDisplays();
  bool number = !output.empty();
  for (const char c : output) number = number && c >= '0' && c <= '9';
  if (number) {
    const int index = std::atoi(std::string(output).c_str());
    if (index < count) return index;
  } else {
    for (int i = 0; i < count; ++i)
      if (const char* name = SDL_GetDisplayName(i); name && output == name) return i;
  }
  fail(PresenterErrc::NotFound, "no output '" + std::string(output) + "' on the " +
                                    std::string(SDL_GetCurrentVideoDriver()) +
                                    " display server; outputs: " + outputList());
}

std::int64_t monotonicNanoseconds() {
  timespec t{};
  ::clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

// What ends the presenter, in words, or empty: the events since the last look (the window closed, the output
// gone, the server quitting) and the window's state after them (hidden or minimised: no longer full screen).
std::string lossInEvents(SDL_Window* window, int output) {
  const Uint32 id = SDL_GetWindowID(window);
  SDL_Event e;
  while (SDL_PollEvent(&e)) {
    if (e.type == SDL_QUIT) return "the display server asked the window to close";
    if (e.type == SDL_DISPLAYEVENT && e.display.event == SDL_DISPLAYEVENT_DISCONNECTED &&
        static_cast<int>(e.display.display) == output)
      return "the output was disconnected (cable pulled, monitor off)";
    if (e.type == SDL_WINDOWEVENT && e.window.windowID == id && e.window.event == SDL_WINDOWEVENT_CLOSE)
      return "the window was closed";
  }
  const Uint32 flags = SDL_GetWindowFlags(window);
  if (flags & SDL_WINDOW_MINIMIZED) return "the window was minimised: it is no longer full screen";
  if (flags & SDL_WINDOW_HIDDEN) return "the window was hidden: it is no longer on the output";
  return {};
}

// Lets the window come up: a window manager (or SDL2 itself, without one) may unmap and map it again while
// making it full screen. Gives up after a second.
void settleWindow(SDL_Window* window) {
  for (int i = 0; i < 100; ++i) {
    SDL_PumpEvents();
    if (!(SDL_GetWindowFlags(window) & (SDL_WINDOW_HIDDEN | SDL_WINDOW_MINIMIZED))) return;
    SDL_Delay(10);
  }
}

int list() {
  if (const std::string problem = startVideo(); !problem.empty()) {
    std::fprintf(stderr, "%s\n", problem.c_str());
    return 2;
  }
  for (int i = 0; i < SDL_GetNumVideoDisplays(); ++i) {
    SDL_DisplayMode mode{};
    SDL_Rect bounds{};
    SDL_GetCurrentDisplayMode(i, &mode);
    SDL_GetDisplayBounds(i, &bounds);
    std::string name = SDL_GetDisplayName(i) ? SDL_GetDisplayName(i) : "";
    for (char& c : name)
      if (c == '\t' || c == '\n') c = ' ';
    std::printf("%d\t%s\t%d\t%d\t%d\t%d\t%d\t%s\n", i, name.c_str(), mode.w, mode.h, mode.refresh_rate * 1000, bounds.x,
                bounds.y, SDL_GetCurrentVideoDriver());
  }
  SDL_Quit();
  return 0;
}

int present(std::string_view output, bool vsync, int wantWidth, int wantHeight) {
  // Full screen on an output stays up when another window takes the focus; no scaling filter.
  SDL_SetHint(SDL_HINT_VIDEO_MINIMIZE_ON_FOCUS_LOSS, "0");
  SDL_SetHint(SDL_HINT_RENDER_SCALE_QUALITY, "nearest");
  if (const std::string problem = startVideo(); !problem.empty()) fail(PresenterErrc::NotFound, problem);
  const int index = findOutput(output);
  SDL_DisplayMode mode{};
  SDL_Rect bounds{};
  if (SDL_GetCurrentDisplayMode(index, &mode) != 0 || SDL_GetDisplayBounds(index, &bounds) != 0)
    fail(PresenterErrc::Device, sdlError("cannot read the output's mode"));
  char modes[160];
  std::snprintf(modes, sizeof modes, "output %s is in mode %dx%d; the panel needs %dx%d", describeOutput(index).c_str(),
                mode.w, mode.h, wantWidth, wantHeight);
  if (wantWidth > 0 && (mode.w != wantWidth || mode.h != wantHeight))
    fail(PresenterErrc::Config, std::string(modes) +
                                    ": set the panel's native mode on the output (xrandr, the desktop's display "
                                    "settings, or video=<connector>:<w>x<h> on the kernel command line)");
  SDL_Window* window = SDL_CreateWindow(
      "lfi panel", bounds.x, bounds.y, mode.w, mode.h,
      SDL_WINDOW_FULLSCREEN_DESKTOP | SDL_WINDOW_BORDERLESS | SDL_WINDOW_ALLOW_HIGHDPI | SDL_WINDOW_SHOWN);
  if (!window) fail(PresenterErrc::Device, sdlError("cannot open a full-screen window"));
  SDL_Renderer* renderer = SDL_CreateRenderer(window, -1, vsync ? SDL_RENDERER_PRESENTVSYNC : 0);
  if (!renderer) fail(PresenterErrc::Device, sdlError("cannot render to the window"));
  int windowW = 0, windowH = 0, drawableW = 0, drawableH = 0, x = 0, y = 0;
  SDL_GetWindowSize(window, &windowW, &windowH);
  SDL_GetWindowPosition(window, &x, &y);
  SDL_GetRendererOutputSize(renderer, &drawableW, &drawableH);
  if (windowW != mode.w || windowH != mode.h || drawableW != mode.w || drawableH != mode.h) {
    char text[320];
    std::snprintf(text, sizeof text,
                  "the window on output %s is %dx%d points and %dx%d pixels, not the mode's %dx%d pixels: the "
                  "output is scaled (a HiDPI factor other than 1) or the window manager did not make the window "
                  "full screen",
                  describeOutput(index).c_str(), windowW, windowH, drawableW, drawableH, mode.w, mode.h);
    fail(PresenterErrc::Config, text);
  }
  SDL_Texture* texture =
      SDL_CreateTexture(renderer, SDL_PIXELFORMAT_RGB24, SDL_TEXTUREACCESS_STREAMING, mode.w, mode.h);
  if (!texture) fail(PresenterErrc::Device, sdlError("cannot make the frame's texture"));
  SDL_SetTextureBlendMode(texture, SDL_BLENDMODE_NONE);
  SDL_SetTextureScaleMode(texture, SDL_ScaleModeNearest);

  const std::size_t bytes = static_cast<std::size_t>(mode.w) * static_cast<std::size_t>(mode.h) * 3;
  const int frameFd = ::memfd_create("lfi-window-frame", MFD_CLOEXEC);
  void* frame = MAP_FAILED;
  if (frameFd >= 0 && ::ftruncate(frameFd, static_cast<off_t>(bytes)) == 0)
    frame = ::mmap(nullptr, bytes, PROT_READ, MAP_SHARED, frameFd, 0);
  if (frame == MAP_FAILED) fail(PresenterErrc::Device, std::string("cannot map the frame: ") + std::strerror(errno));

  SDL_RendererInfo rendererInfo{};
  SDL_GetRendererInfo(renderer, &rendererInfo);
  const auto draw = [&](bool black) {
    SDL_SetRenderDrawColor(renderer, 0, 0, 0, 255);
    SDL_RenderClear(renderer);
    if (!black) {
      if (SDL_UpdateTexture(texture, nullptr, frame, mode.w * 3) != 0 ||
          SDL_RenderCopy(renderer, texture, nullptr, nullptr) != 0)
        fail(PresenterErrc::Device, sdlError("cannot draw the frame"));
    }
    SDL_RenderPresent(renderer);
    return monotonicNanoseconds();
  };
  draw(true);
  settleWindow(window);
  if (const std::string loss = lossInEvents(window, index); !loss.empty())
    finish(PresenterOp::Lost, PresenterErrc::Device, loss);

  PresenterMessage ready;
  ready.op = PresenterOp::Ready;
  ready.width_px = mode.w;
  ready.height_px = mode.h;
  ready.refresh_mHz = mode.refresh_rate * 1000;
  ready.vsync = (rendererInfo.flags & SDL_RENDERER_PRESENTVSYNC) != 0;
  std::snprintf(ready.driver, sizeof ready.driver, "%s", SDL_GetCurrentVideoDriver());
  ready.setText(SDL_GetDisplayName(index) ? SDL_GetDisplayName(index) : "");
  send(ready, frameFd);

  for (;;) {
    pollfd p{kPresenterSocketFd, POLLIN, 0};
    const int ready_ = ::poll(&p, 1, 50);
    if (const std::string loss = lossInEvents(window, index); !loss.empty())
      finish(PresenterOp::Lost, PresenterErrc::Device, loss);
    if (ready_ <= 0) continue;
    PresenterMessage request;
    const ssize_t n = ::recv(kPresenterSocketFd, &request, sizeof request, 0);
    if (n <= 0) break;  // the display closed its end: done
    if (n != sizeof request ||
        (request.op != PresenterOp::Show && request.op != PresenterOp::Blank && request.op != PresenterOp::Status))
      fail(PresenterErrc::Device, "the display sent a message the presenter does not know");
    if (request.op == PresenterOp::Status) {  // (the events pumped ask the server: a dead one ends this process)
      if (const std::string loss = lossInEvents(window, index); !loss.empty())
        finish(PresenterOp::Lost, PresenterErrc::Device, loss);
      PresenterMessage reply;
      reply.op = PresenterOp::Status;
      send(reply);
      continue;
    }
    const std::int64_t at = draw(request.op == PresenterOp::Blank);
    if (const std::string loss = lossInEvents(window, index); !loss.empty())
      finish(PresenterOp::Lost, PresenterErrc::Device, loss);
    PresenterMessage reply;
    reply.op = PresenterOp::Presented;
    reply.sequence = request.sequence;
    reply.presentTime_ns = at;
    send(reply);
  }
  SDL_DestroyTexture(texture);
  SDL_DestroyRenderer(renderer);
  SDL_DestroyWindow(window);
  SDL_Quit();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string_view output;
  int vsync = 1, width = 0, height = 0;
  bool listOutputs = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const bool hasValue = i + 1 < argc;
    if (arg == "--list") {
      listOutputs = true;
    } else if (arg == "--output" && hasValue) {
      output = argv[++i];
    } else if (arg == "--vsync" && hasValue) {
      vsync = std::atoi(argv[++i]);
    } else if (arg == "--mode" && hasValue) {
      if (std::sscanf(argv[++i], "%dx%d", &width, &height) != 2) width = height = 0;
    } else {
      std::fprintf(stderr, "lfi-window-presenter: unknown argument '%s' (it is run by lfi's window: display)\n",
                   argv[i]);
      return 2;
    }
  }
  if (listOutputs) return list();
  return present(output, vsync != 0, width, height);
}
