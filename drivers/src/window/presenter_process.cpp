// SPDX-License-Identifier: Apache-2.0
#include "presenter_process.h"

#include "lfi/core/error.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <optional>
#include <thread>
#include <utility>

extern char** environ;

namespace lfi::window {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

std::vector<char*> argv(const fs::path& exe, const std::vector<std::string>& args, std::string& exeText) {
  exeText = exe.string();
  std::vector<char*> v{exeText.data()};
  for (const std::string& a : args) v.push_back(const_cast<char*>(a.c_str()));
  v.push_back(nullptr);
  return v;
}

// Starts `presenter` with `args` and the child's descriptors (to) made of the child's ends (from), which are
// closed here then; on failure the parent's ends `ours` are closed as well. Throws Errc::Device after `prefix`.
pid_t spawn(const fs::path& presenter, const std::vector<std::string>& args,
            std::initializer_list<std::pair<int, int>> childEnds, std::initializer_list<int> ours,
            const std::string& prefix) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  for (const auto& [from, to] : childEnds) posix_spawn_file_actions_adddup2(&actions, from, to);
  std::string exe;
  std::vector<char*> v = argv(presenter, args, exe);
  pid_t pid = 0;
  const int rc = ::posix_spawn(&pid, exe.c_str(), &actions, nullptr, v.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  for (const auto& end : childEnds) ::close(end.first);
  if (rc != 0) {
    for (int fd : ours) ::close(fd);
    fail(Errc::Device, "{}cannot start {}: {}", prefix, presenter.string(), std::strerror(rc));
  }
  return pid;
}

std::string describeStatus(int status) {
  if (WIFEXITED(status)) return "exit status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return std::string("killed by signal ") + ::strsignal(WTERMSIG(status));
  return "status " + std::to_string(status);
}

// Waits up to `limit` for the child; its status, or none while it runs.
std::optional<int> waitFor(pid_t pid, std::chrono::milliseconds limit) {
  const auto end = Clock::now() + limit;
  for (;;) {
    int status = 0;
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) return status;
    if (r < 0 || Clock::now() >= end) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

// Reads what is there on a non-blocking descriptor; false at its end.
bool drain(int fd, std::string& into) {
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n > 0) {
      into.append(buffer, static_cast<std::size_t>(n));
      if (into.size() > 16384) into.erase(0, into.size() - 16384);
      continue;
    }
    return n < 0 && (errno == EAGAIN || errno == EINTR);
  }
}

std::string lastLine(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  const std::size_t nl = text.rfind('\n');
  return nl == std::string::npos ? text : text.substr(nl + 1);
}

}  // namespace

fs::path findPresenter(const fs::path& given) {
  if (!given.empty()) {
    if (::access(given.c_str(), X_OK) != 0)
      fail(Errc::NotFound, "window display presenter {} is not there", given.string());
    return given;
  }
  if (const char* env = std::getenv("LFI_WINDOW_PRESENTER"); env && *env) {
    if (::access(env, X_OK) != 0) fail(Errc::NotFound, "LFI_WINDOW_PRESENTER={} is not an executable", env);
    return env;
  }
  const fs::path built = LFI_WINDOW_PRESENTER_BUILT, installed = LFI_WINDOW_PRESENTER_INSTALLED;
  std::error_code ignored;
  const fs::path self = fs::read_symlink("/proc/self/exe", ignored);
  const bool fromBuildTree = self.string().starts_with(LFI_BINARY_DIR "/");
  for (const fs::path& p : fromBuildTree ? std::vector{built, installed} : std::vector{installed, built})
    if (::access(p.c_str(), X_OK) == 0) return p;
  fail(Errc::NotFound, "the window display's presenter is neither at {} nor at {} (set LFI_WINDOW_PRESENTER)",
       installed.string(), built.string());
}

std::string runPresenter(const fs::path& presenter, const std::vector<std::string>& args,
                         std::chrono::milliseconds timeout) {
  int out[2], err[2];
  if (::pipe2(out, O_CLOEXEC) != 0) fail(Errc::Device, "cannot make a pipe: {}", std::strerror(errno));
  if (::pipe2(err, O_CLOEXEC) != 0) {
    ::close(out[0]);
    ::close(out[1]);
    fail(Errc::Device, "cannot make a pipe: {}", std::strerror(errno));
  }
  const pid_t pid = spawn(presenter, args, {{out[1], 1}, {err[1], 2}}, {out[0], err[0]}, "");
  ::fcntl(out[0], F_SETFL, O_NONBLOCK);
  ::fcntl(err[0], F_SETFL, O_NONBLOCK);
  std::string output, errors;
  bool outOpen = true, errOpen = true;
  const auto end = Clock::now() + timeout;
  while ((outOpen || errOpen) && Clock::now() < end) {
    pollfd p[2] = {{outOpen ? out[0] : -1, POLLIN, 0}, {errOpen ? err[0] : -1, POLLIN, 0}};
    ::poll(p, 2, 20);
    if (outOpen) outOpen = drain(out[0], output);
    if (errOpen) errOpen = drain(err[0], errors);
  }
  ::close(out[0]);
  ::close(err[0]);
  std::optional<int> status = waitFor(pid, std::chrono::milliseconds(outOpen || errOpen ? 0 : 2000));
  if (!status) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
    fail(Errc::Timeout, "{} did not answer within {} ms", presenter.string(), timeout.count());
  }
  if (!WIFEXITED(*status) || WEXITSTATUS(*status) != 0)
    fail(Errc::NotFound, "no display outputs: {} ({})", lastLine(errors), describeStatus(*status));
  return output;
}

std::unique_ptr<PresenterProcess> PresenterProcess::start(const fs::path& given, const std::vector<std::string>& args,
                                                          std::string device) {
  const fs::path presenter = findPresenter(given);
  int pair[2], err[2];
  if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, pair) != 0)
    fail(Errc::Device, "{}: cannot make a socket pair: {}", device, std::strerror(errno));
  if (::pipe2(err, O_CLOEXEC) != 0) {
    ::close(pair[0]);
    ::close(pair[1]);
    fail(Errc::Device, "{}: cannot make a pipe: {}", device, std::strerror(errno));
  }
  const pid_t pid =
      spawn(presenter, args, {{pair[1], kPresenterSocketFd}, {err[1], 2}}, {pair[0], err[0]}, device + ": ");
  ::fcntl(err[0], F_SETFL, O_NONBLOCK);
  return std::unique_ptr<PresenterProcess>(new PresenterProcess(pid, pair[0], err[0], std::move(device)));
}

PresenterProcess::~PresenterProcess() {
  ::close(socket_);
  if (pid_ > 0 && !waitFor(pid_, std::chrono::milliseconds(2000))) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
  ::close(errors_);
}

void PresenterProcess::send(const PresenterMessage& message) {
  if (::send(socket_, &message, sizeof message, MSG_NOSIGNAL) != static_cast<ssize_t>(sizeof message)) gone();
}

PresenterMessage PresenterProcess::receive(std::chrono::milliseconds timeout, const char* what, int* fd) {
  const auto end = Clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now());
    if (left.count() <= 0)
      fail(Errc::Timeout, "{}: the presenter did not {} within {} ms (the display server does not answer){}", device_,
           what, timeout.count(), lastWords());
    pollfd p[2] = {{socket_, POLLIN, 0}, {errors_, POLLIN, 0}};
    ::poll(p, 2, static_cast<int>(std::min<long long>(left.count(), 100)));
    drain(errors_, stderr_);
    if (!(p[0].revents & (POLLIN | POLLHUP | POLLERR))) continue;
    PresenterMessage m;
    iovec part{&m, sizeof m};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
    msghdr header{};
    header.msg_iov = &part;
    header.msg_iovlen = 1;
    header.msg_control = control;
    header.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(socket_, &header, MSG_CMSG_CLOEXEC);
    if (n < 0 && errno == EINTR) continue;
    int received = -1;
    for (cmsghdr* c = CMSG_FIRSTHDR(&header); c; c = CMSG_NXTHDR(&header, c))
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_RIGHTS)
        std::memcpy(&received, CMSG_DATA(c), sizeof received);
    if (received >= 0 && !fd) ::close(received);
    if (fd) *fd = received;
    if (n <= 0) gone();
    if (n != static_cast<ssize_t>(sizeof m))
      fail(Errc::Device, "{}: the presenter sent a message of {} bytes, not {}", device_, n, sizeof m);
    return m;
  }
}

std::string PresenterProcess::lastWords() {
  drain(errors_, stderr_);
  const std::string line = lastLine(stderr_);
  return line.empty() ? std::string() : ": it said \"" + line + "\"";
}

void PresenterProcess::gone() {
  const std::optional<int> status = waitFor(pid_, std::chrono::milliseconds(1000));
  if (status) pid_ = -1;  // (reaped: the destructor has nothing to wait for)
  fail(Errc::Device, "{}: the presenter ended ({}){}: the display server went away or the output is gone", device_,
       status ? describeStatus(*status) : "its socket closed", lastWords());
}

}  // namespace lfi::window
