// SPDX-License-Identifier: Apache-2.0
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
#include <sys/file.h>
#include <sys/prctl.h>
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
  // (Read-only: flock needs no write access, so the file another user created, 0644, locks as well.)
  LoopbackGigeLock() : fd_(::open("/tmp/lfi-fake-gv-camera.lock", O_RDONLY | O_CREAT | O_CLOEXEC, 0666)) {
    if (fd_ < 0 || ::flock(fd_, LOCK_EX) != 0)
      throw std::runtime_error(std::string("cannot lock /tmp/lfi-fake-gv-camera.lock: ") + std::strerror(errno));
  }
  ~LoopbackGigeLock() { ::close(fd_); }  // releases the lock
  LoopbackGigeLock(const LoopbackGigeLock&) = delete;
  LoopbackGigeLock& operator=(const LoopbackGigeLock&) = delete;

 private:
  int fd_;
};

// Sends one GVCP command (a 12- or 16-byte packet) to `address`:3956 and waits
// up to `timeoutMs` for its acknowledgement; returns the ack's size (0: none).
inline size_t gvcpCommand(const std::string& address, const std::uint8_t* packet, size_t size, std::uint8_t* reply,
                          size_t replySize, int timeoutMs) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return 0;
  sockaddr_in device{};
  device.sin_family = AF_INET;
  device.sin_port = htons(3956);
  ssize_t n = 0;
  if (::inet_pton(AF_INET, address.c_str(), &device.sin_addr) == 1 &&
      ::connect(fd, reinterpret_cast<const sockaddr*>(&device), sizeof device) == 0 &&
      ::send(fd, packet, size, 0) == static_cast<ssize_t>(size)) {
    pollfd pfd{.fd = fd, .events = POLLIN, .revents = 0};
    if (::poll(&pfd, 1, timeoutMs) > 0) n = ::recv(fd, reply, replySize, 0);
  }
  ::close(fd);
  return n > 0 ? static_cast<size_t>(n) : 0;
}

// A GVCP READREG of the control channel privilege register (0x0A00) on
// `address`:3956 gets an answer within `timeoutMs`.
inline bool gigeDeviceAnswers(int timeoutMs = 100, const std::string& address = "127.0.0.1") {
  const std::uint8_t packet[12] = {0x42, 0x01, 0x00, 0x80, 0x00, 0x04, 0x00, 0x01, 0x00, 0x00, 0x0a, 0x00};
  std::uint8_t reply[64];
  return gvcpCommand(address, packet, sizeof packet, reply, sizeof reply, timeoutMs) >= 8;
}

// A GVCP WRITEREG of `value` to bootstrap register `reg` on `address`:3956,
// acknowledged with success. (A device with no controller takes it from anyone.)
inline bool gigeWriteRegister(std::uint32_t reg, std::uint32_t value, const std::string& address = "127.0.0.1",
                              int timeoutMs = 1000) {
  const std::uint8_t packet[16] = {0x42,
                                   0x01,
                                   0x00,
                                   0x82,
                                   0x00,
                                   0x08,
                                   0x00,
                                   0x02,
                                   static_cast<std::uint8_t>(reg >> 24),
                                   static_cast<std::uint8_t>(reg >> 16),
                                   static_cast<std::uint8_t>(reg >> 8),
                                   static_cast<std::uint8_t>(reg),
                                   static_cast<std::uint8_t>(value >> 24),
                                   static_cast<std::uint8_t>(value >> 16),
                                   static_cast<std::uint8_t>(value >> 8),
                                   static_cast<std::uint8_t>(value)};
  std::uint8_t reply[64];
  // WRITEREG_ACK: status 0 (success), ack 0x0083.
  return gvcpCommand(address, packet, sizeof packet, reply, sizeof reply, timeoutMs) >= 8 && reply[0] == 0 &&
         reply[1] == 0 && reply[2] == 0x00 && reply[3] == 0x83;
}

// Block ids missing between two received frames. GigE Vision block ids are 16
// bits here: 65535 is followed by 1 (0 is never used).
inline std::uint64_t missingBlockIds(std::uint64_t previous, std::uint64_t id) {
  if (id == previous) return 0;  // (the same frame twice: nothing missing)
  return id > previous ? id - previous - 1 : id + 65534 - previous;
}

// GigE Vision bootstrap register: how long a device keeps its controller without a heartbeat (ms).
constexpr std::uint32_t kHeartbeatTimeoutRegister = 0x0938;

// The device's process: started with `args` (args[0] is the executable's path),
// stdout (and with quietStderr stderr) to /dev/null; waits until the device
// answers GVCP on `address` or the process exits. Killed with SIGKILL on
// destruction, and when the thread that started it dies (a crashed test must
// not leave a device that answers the next test's GVCP requests in its place).
class GigeDeviceProcess {
 public:
  GigeDeviceProcess(std::vector<std::string> args, std::chrono::milliseconds startTimeout, bool quietStderr = true,
                    const std::string& address = "127.0.0.1") {
    if (gigeDeviceAnswers(100, address))
      throw std::runtime_error("a GigE Vision device already answers on " + address + ":3956 before " + args[0] +
                               " starts (one left running? `ss -ulpn 'sport = :3956'` names its process)");
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    int execError[2];  // the child's exec errno, or end of file when exec succeeded (close on exec)
    if (::pipe2(execError, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe2: ") + std::strerror(errno));
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ == 0) {  // the child: async-signal-safe calls only
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(127);                     // the parent died before prctl
      const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);  // (the dup2 copies stay open)
      if (null >= 0) {
        ::dup2(null, STDOUT_FILENO);
        if (quietStderr) ::dup2(null, STDERR_FILENO);
      }
      ::execve(argv[0], argv.data(), environ);
      const int error = errno;
      (void)!::write(execError[1], &error, sizeof error);
      ::_exit(127);
    }
    const int forkError = errno;
    ::close(execError[1]);
    int error = 0;
    ssize_t got = 0;
    while (pid_ > 0 && (got = ::read(execError[0], &error, sizeof error)) < 0 && errno == EINTR) {
    }
    const bool execFailed = got == sizeof error;
    ::close(execError[0]);
    if (pid_ < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(forkError));
    if (execFailed) {
      ::waitpid(pid_, nullptr, 0);
      pid_ = -1;
      throw std::runtime_error("cannot run " + args[0] + ": " + std::strerror(error));
    }
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
