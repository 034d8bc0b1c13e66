// SPDX-License-Identifier: Apache-2.0
#include "sim_bench_control.h"

#include "lfi/core/error.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <thread>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

constexpr std::size_t kMaxLine = 4096;
constexpr int kRequestTimeout_ms = 2000;  // a client that connects and says nothing

sockaddr_un socketAddress(const fs::path& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  const std::string text = path.string();
  if (text.empty() || text.size() >= sizeof(address.sun_path))
    fail(Errc::Io, "control socket '{}': a socket path has 1..{} bytes", text, sizeof(address.sun_path) - 1);
  std::memcpy(address.sun_path, text.c_str(), text.size() + 1);
  return address;
}

class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

// Reads up to a newline within `timeout_ms`; false on timeout, end of stream without a line, or a line too long.
bool readLine(int fd, std::string& line, int timeout_ms) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  line.clear();
  char buffer[512];
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::max<long>(0, left.count())));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) return false;
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    line.append(buffer, static_cast<std::size_t>(n));
    if (const auto end = line.find('\n'); end != std::string::npos) {
      line.resize(end);
      return true;
    }
    if (line.size() > kMaxLine) return false;
  }
}

void writeAll(int fd, const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::send(fd, text.data() + done, text.size() - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;  // (the client went away: its loss)
    done += static_cast<std::size_t>(n);
  }
}

}  // namespace

struct ControlServer::Impl {
  fs::path path;
  Handler handle;
  int listener = -1;
  int wake[2] = {-1, -1};  // the destructor writes to wake[1]
  std::thread thread;

  void serve() {
    for (;;) {
      pollfd p[2] = {{listener, POLLIN, 0}, {wake[0], POLLIN, 0}};
      if (::poll(p, 2, -1) < 0) {
        if (errno == EINTR) continue;
        return;
      }
      if (p[1].revents != 0) return;
      const Fd client(::accept4(listener, nullptr, nullptr, SOCK_CLOEXEC));
      if (client.get() < 0) continue;
      std::string request;
      if (!readLine(client.get(), request, kRequestTimeout_ms)) {
        writeAll(client.get(), "error no request line within 2 s (at most 4096 bytes, ending in a newline)\n");
        continue;
      }
      std::string reply;
      try {
        reply = handle(request);
      } catch (const std::exception& e) {
        reply = std::string("error ") + e.what();
      }
      for (char& c : reply)
        if (c == '\n') c = ' ';
      writeAll(client.get(), reply + "\n");
    }
  }
};

ControlServer::ControlServer(fs::path path, Handler handle) : impl_(new Impl) {
  impl_->path = std::move(path);
  impl_->handle = std::move(handle);
  const sockaddr_un address = socketAddress(impl_->path);
  impl_->listener = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (impl_->listener < 0) fail(Errc::Io, "control socket: socket() failed: {}", std::strerror(errno));
  if (::bind(impl_->listener, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 ||
      ::listen(impl_->listener, 8) != 0 || ::pipe2(impl_->wake, O_CLOEXEC) != 0) {
    const int error = errno;
    ::close(impl_->listener);
    fail(Errc::Io, "control socket '{}' cannot be made: {}{}", impl_->path.string(), std::strerror(error),
         error == EADDRINUSE ? " (the path exists: another sim-bench's socket, or one a killed one left)" : "");
  }
  impl_->thread = std::thread([this] { impl_->serve(); });
}

ControlServer::~ControlServer() {
  const char byte = 0;
  if (::write(impl_->wake[1], &byte, 1) < 0) {
    // (a full pipe is already a wake-up)
  }
  impl_->thread.join();
  ::close(impl_->listener);
  ::close(impl_->wake[0]);
  ::close(impl_->wake[1]);
  std::error_code ec;
  fs::remove(impl_->path, ec);
}

const fs::path& ControlServer::path() const {
  return impl_->path;
}

std::string sendControl(const fs::path& path, const std::string& request, int timeout_ms) {
  const sockaddr_un address = socketAddress(path);
  const Fd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (fd.get() < 0) fail(Errc::Io, "control socket: socket() failed: {}", std::strerror(errno));
  if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const int error = errno;
    fail(error == ENOENT || error == ECONNREFUSED ? Errc::NotFound : Errc::Io,
         "control socket '{}': {} (is `lfi sim-bench` running?)", path.string(), std::strerror(error));
  }
  writeAll(fd.get(), request + "\n");
  std::string reply;
  if (!readLine(fd.get(), reply, timeout_ms))
    fail(Errc::Timeout, "control socket '{}': no reply to '{}' within {} ms", path.string(), request, timeout_ms);
  return reply;
}

}  // namespace lfi::cli
