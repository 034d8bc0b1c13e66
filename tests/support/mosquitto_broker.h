// SPDX-License-Identifier: Apache-2.0
#pragma once
// A real MQTT broker for the tests: Debian's `mosquitto`, started on a free
// port of 127.0.0.1 with a configuration of the test's (persistence in the
// test's folder, so that a restart keeps the subscriptions and what waits for
// them, as a plant's broker does), stopped and started again at will; and a
// listener on it (libmosquitto), subscribed with a session the broker keeps,
// that collects every message it receives.

#include "free_port.h"

#include <mosquitto.h>
#include <pwd.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace lfi::testing_support {

// Where Debian's mosquitto is, or empty.
inline std::string mosquittoProgram() {
  for (const char* p : {"/usr/sbin/mosquitto", "/usr/bin/mosquitto"})
    if (::access(p, X_OK) == 0) return p;
  return "";
}

class MosquittoBroker {
 public:
  // `config`: lines added to the listener's ("password_file ...", "allow_anonymous false").
  MosquittoBroker(std::filesystem::path folder, const std::string& config = "allow_anonymous true")
      : folder_(std::move(folder)), port_(freeLoopbackPort()) {
    std::filesystem::create_directories(folder_);
    // (as root it would drop to the user "mosquitto", who cannot write the test's folder)
    const passwd* user = ::getpwuid(::geteuid());
    std::ofstream(folder_ / "mosquitto.conf")
        << "user " << (user ? user->pw_name : "root") << "\n"
        << "per_listener_settings false\n"
        << "listener " << port_ << " 127.0.0.1\n"
        << config << "\npersistence true\npersistence_location " << (folder_ / "").string() << "\nlog_dest file "
        << (folder_ / "mosquitto.log").string() << "\n";
    start();
  }
  ~MosquittoBroker() { stop(); }
  MosquittoBroker(const MosquittoBroker&) = delete;
  MosquittoBroker& operator=(const MosquittoBroker&) = delete;

  int port() const { return port_; }
  std::string url() const { return "mqtt://127.0.0.1:" + std::to_string(port_); }
  const std::filesystem::path& folder() const { return folder_; }

  // Starts the broker and waits until it listens (10 s at most).
  void start() {
    if (pid_ > 0) return;
    const std::string program = mosquittoProgram(), conf = (folder_ / "mosquitto.conf").string();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::execl(program.c_str(), program.c_str(), "-c", conf.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    if (pid_ < 0) throw std::runtime_error("cannot fork the broker");
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (!acceptsConnections(port_)) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("mosquitto exited at its start; see " + (folder_ / "mosquitto.log").string());
      }
      if (std::chrono::steady_clock::now() > deadline) throw std::runtime_error("mosquitto did not listen in 10 s");
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }

  // Stops it as a service stop does (SIGTERM: it saves its persistence) and waits for it.
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }

 private:
  std::filesystem::path folder_;
  int port_;
  pid_t pid_ = -1;
};

struct MqttMessage {
  std::string topic, payload;
  bool retain = false;
  std::chrono::steady_clock::time_point arrival;  // when the listener received it
};

// A subscriber to `filter` at QoS 1 with a session the broker keeps (clean
// session off, a fixed client id): what is published while it is away from a
// broker that restarts waits for it there.
class MqttListener {
 public:
  MqttListener(int port, const std::string& filter, const std::string& id, bool keepSession = true,
               const std::string& username = "", const std::string& password = "")
      : filter_(filter) {
    mosquitto_lib_init();
    client_ = mosquitto_new(id.c_str(), !keepSession, this);
    if (!username.empty()) mosquitto_username_pw_set(client_, username.c_str(), password.c_str());
    mosquitto_connect_callback_set(client_, [](mosquitto* m, void* self, int rc) {
      if (rc == 0) mosquitto_subscribe(m, nullptr, static_cast<MqttListener*>(self)->filter_.c_str(), 1);
    });
    mosquitto_subscribe_callback_set(client_, [](mosquitto*, void* data, int, int, const int*) {
      auto* self = static_cast<MqttListener*>(data);
      std::lock_guard lock(self->mutex_);
      self->subscribed_ = true;
      self->changed_.notify_all();
    });
    mosquitto_message_callback_set(client_, [](mosquitto*, void* data, const mosquitto_message* m) {
      auto* self = static_cast<MqttListener*>(data);
      std::lock_guard lock(self->mutex_);
      self->messages_.push_back({m->topic, std::string(static_cast<const char*>(m->payload), m->payloadlen), m->retain,
                                 std::chrono::steady_clock::now()});
      self->changed_.notify_all();
    });
    mosquitto_reconnect_delay_set(client_, 1, 1, false);
    mosquitto_connect(client_, "127.0.0.1", port, 10);
    mosquitto_loop_start(client_);
    std::unique_lock lock(mutex_);
    if (!changed_.wait_for(lock, std::chrono::seconds(10), [&] { return subscribed_; }))
      throw std::runtime_error("the listener did not subscribe in 10 s");
  }
  ~MqttListener() {
    mosquitto_disconnect(client_);
    mosquitto_loop_stop(client_, false);
    mosquitto_destroy(client_);
  }
  MqttListener(const MqttListener&) = delete;
  MqttListener& operator=(const MqttListener&) = delete;

  std::vector<MqttMessage> messages() const {
    std::lock_guard lock(mutex_);
    return messages_;
  }
  // Waits up to `timeout` until `done` holds for the messages so far; returns whether it did.
  bool waitFor(const std::function<bool(const std::vector<MqttMessage>&)>& done, std::chrono::seconds timeout) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return done(messages_); });
  }

 private:
  std::string filter_;
  mosquitto* client_ = nullptr;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool subscribed_ = false;
  std::vector<MqttMessage> messages_;
};

}  // namespace lfi::testing_support
