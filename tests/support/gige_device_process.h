#pragma once
// A GigE Vision device served on 127.0.0.1 by a child process — Aravis's fake
// camera (arv-fake-gv-camera-0.8) or `lfi serve-camera` — for the loopback
// tests and the camera benchmark (one test serves on eth0's address instead,
// while its fixture's device runs on 127.0.0.1). Two devices on 127.0.0.1 answer
// each other's GVCP requests (both listen on UDP 3956), so whoever runs one holds
// LoopbackGigeLock for as long as it runs; that makes `ctest -j` safe.
// No GoogleTest here: the benchmark uses it too. Failures throw std::runtime_error.

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace lfi::testing_support {

// Exclusive use of 127.0.0.1:3956 among cooperating processes.
class LoopbackGigeLock {
public:
  LoopbackGigeLock() : fd_(::open("/tmp/lfi-fake-gv-camera.lock", O_RDWR | O_CREAT | O_CLOEXEC, 0666)) {
    if (fd_ < 0 || ::flock(fd_, LOCK_EX) != 0)
      throw std::runtime_error(std::string("cannot lock /tmp/lfi-fake-gv-camera.lock: ") + std::strerror(errno));
  }
  ~LoopbackGigeLock() { ::close(fd_); }  // releases the lock
  LoopbackGigeLock(const LoopbackGigeLock&) = delete;
  LoopbackGigeLock& operator=(const LoopbackGigeLock&) = delete;

private:
  int fd_;
};

// A GVCP READREG of the control channel privilege register (0x0A00) on
// `address`:3956 gets an answer within `timeoutMs`.
inline bool gigeDeviceAnswers(int timeoutMs = 100, const std::string& address = "127.0.0.1") {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  sockaddr_in device{};
  device.sin_family = AF_INET;
  device.sin_port = htons(3956);
  if (::inet_pton(AF_INET, address.c_str(), &device.sin_addr) != 1) {
    ::close(fd);
    return false;
  }
  const std::uint8_t packet[12] = {0x42, 0x01, 0x00, 0x80, 0x00, 0x04, 0x00, 0x01, 0x00, 0x00, 0x0a, 0x00};
  bool answered = false;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&device), sizeof device) == 0 &&
      ::send(fd, packet, sizeof packet, 0) == sizeof packet) {
    pollfd pfd{.fd = fd, .events = POLLIN, .revents = 0};
    std::uint8_t reply[64];
    answered = ::poll(&pfd, 1, timeoutMs) > 0 && ::recv(fd, reply, sizeof reply, 0) >= 8;
  }
  ::close(fd);
  return answered;
}

// The device's process: started with `args` (args[0] is the executable's path),
// stdout (and with quietStderr stderr) to /dev/null; waits until the device
// answers GVCP on `address` or the process exits. Killed with SIGKILL on destruction.
class GigeDeviceProcess {
public:
  GigeDeviceProcess(std::vector<std::string> args, std::chrono::milliseconds startTimeout, bool quietStderr = true,
                    const std::string& address = "127.0.0.1") {
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    if (quietStderr) posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
    const int rc = posix_spawn(&pid_, args[0].c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) throw std::runtime_error("posix_spawn " + args[0] + ": " + std::strerror(rc));
    const auto deadline = std::chrono::steady_clock::now() + startTimeout;
    while (!gigeDeviceAnswers(100, address)) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error(args[0] + " exited (status " + std::to_string(status) + ") before serving");
      }
      if (std::chrono::steady_clock::now() > deadline) {
        signal(SIGKILL);
        throw std::runtime_error(args[0] + " did not answer on " + address + ":3956 in time");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  ~GigeDeviceProcess() { signal(SIGKILL); }
  GigeDeviceProcess(const GigeDeviceProcess&) = delete;
  GigeDeviceProcess& operator=(const GigeDeviceProcess&) = delete;

  // Sends `sig` and reaps the process; returns its wait status (-1 if it was gone).
  int signal(int sig) {
    if (pid_ <= 0) return -1;
    ::kill(pid_, sig);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return status;
  }
  pid_t pid() const { return pid_; }

private:
  pid_t pid_ = -1;
};

}  // namespace lfi::testing_support
