// SPDX-License-Identifier: Apache-2.0
// [output.mqtt] over libmosquitto (mqtt_output.h). MQTT 5, so that a run that
// ends in an error can still have the broker send its last will
// (DISCONNECT with reason 0x04).
#include "lfi/controller/mqtt_output.h"

#include "lfi/core/error.h"
#include "lfi/core/input_file.h"
#include "lfi/core/log.h"

#include <fmt/format.h>
#include <mosquitto.h>
#include <mqtt_protocol.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <utility>

namespace lfi {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

const char* toString(RunState state) {
  switch (state) {
    case RunState::Running:
      return "running";
    case RunState::Waiting:
      return "waiting";
    case RunState::Stopped:
      return "stopped";
  }
  return "?";
}

namespace {

constexpr const char* kWill = "lost";
constexpr int kMaxInflight = 20;  // messages sent and not yet acknowledged at a time; the rest wait in order

void initLibrary() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

// A file the settings name: it exists and can be read, else Errc::NotFound naming it and its key.
void requireReadable(const fs::path& file, const char* key) {
  if (file.empty()) return;
  std::ifstream in(file);
  if (!in) fail(Errc::NotFound, "[output.mqtt] {}: cannot read '{}'", key, file.string());
}

// "<username>:<password>" on the credentials file's first line.
std::pair<std::string, std::string> readCredentials(const fs::path& file) {
  std::ifstream in(file);
  if (!in) fail(Errc::NotFound, "[output.mqtt] credentials_file: cannot read '{}'", file.string());
  std::error_code error;
  const fs::perms mode = fs::status(file, error).permissions();
  if (!error && (mode & fs::perms::others_read) != fs::perms::none)
    spdlog::warn("[output.mqtt] credentials_file '{}' can be read by every user of this machine (chmod 600 it)",
                 file.string());
  std::string line;
  std::getline(in, line);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  const auto colon = line.find(':');
  if (colon == std::string::npos || colon == 0)
    fail(Errc::Config, "{}:1: the MQTT credentials are not '<username>:<password>'", file.string());
  return {line.substr(0, colon), line.substr(colon + 1)};
}

std::string defaultClientId() {
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  return fmt::format("lfi-{}-{}", host, ::getpid());
}

}  // namespace

struct MqttOutput::Impl {
  MqttOutputSettings settings;
  std::string recordTopic, stateTopic;
  mosquitto* client = nullptr;

  mutable std::mutex mutex;
  std::condition_variable changed;
  bool up = false;
  bool everConnected = false;
  bool finished = false;
  std::map<int, bool> pending;  // mids handed to the client, not yet acknowledged → whether a record's
  int pendingRecords = 0;
  std::set<int> ackedEarly;                     // acknowledged before mosquitto_publish returned their mid
  std::map<std::string, std::string> failures;  // the last failure of each kind ("connect", "refused", ...)
  std::string clientError;                      // the client's last error log line (a TLS handshake's failure, say)
  std::uint64_t dropped = 0, firstDropped = 0;
  bool droppingNow = false;

  std::string where() const { return fmt::format("mqtt: broker {}", settings.broker); }

  void failure(const std::string& kind, const std::string& what) {
    bool fresh = false;
    {
      std::lock_guard lock(mutex);
      fresh = failures[kind] != what;
      failures[kind] = what;
    }
    if (fresh) spdlog::error("{}: {}", where(), what);
  }

  static Impl& of(void* data) { return *static_cast<Impl*>(data); }

  static void onConnect(mosquitto*, void* data, int rc, int, const mosquitto_property*) {
    Impl& self = of(data);
    if (rc != 0) {
      self.failure("refused", fmt::format("refused the connection: {} (reason {}){}", mosquitto_reason_string(rc), rc,
                                          rc == MQTT_RC_BAD_USERNAME_OR_PASSWORD || rc == MQTT_RC_NOT_AUTHORIZED
                                              ? self.settings.credentialsFile.empty()
                                                    ? "; the bench gives no credentials_file"
                                                    : fmt::format("; check credentials_file '{}'",
                                                                  self.settings.credentialsFile.string())
                                              : std::string()));
      return;
    }
    bool again = false;
    {
      std::lock_guard lock(self.mutex);
      again = self.everConnected;
      self.up = self.everConnected = true;
      self.failures.erase("connect");
      self.failures.erase("refused");
      self.failures.erase("lost");
    }
    self.changed.notify_all();
    if (again) spdlog::info("{}: connected again", self.where());
  }

  static void onDisconnect(mosquitto*, void* data, int rc, const mosquitto_property*) {
    Impl& self = of(data);
    bool wasUp = false;
    {
      std::lock_guard lock(self.mutex);
      wasUp = std::exchange(self.up, false);
    }
    self.changed.notify_all();
    if (rc != 0 && wasUp && !self.finished)  // (a refused connection is named as such)
      self.failure(
          "lost", fmt::format("connection lost ({}); reconnecting, records wait in the queue", mosquitto_strerror(rc)));
  }

  static void onLog(mosquitto*, void* data, int level, const char* text) {
    if (level != MOSQ_LOG_ERR || !text) return;
    Impl& self = of(data);
    {
      std::lock_guard lock(self.mutex);
      self.clientError = text;
    }
    self.changed.notify_all();
  }

  static void onPublish(mosquitto*, void* data, int mid, int, const mosquitto_property*) {
    Impl& self = of(data);
    {
      std::lock_guard lock(self.mutex);
      const auto it = self.pending.find(mid);
      if (it == self.pending.end()) {
        self.ackedEarly.insert(mid);
      } else {
        self.pendingRecords -= it->second;
        self.pending.erase(it);
      }
    }
    self.changed.notify_all();
  }

  // Hands one message to the client; false when it was not taken.
  bool publish(const std::string& topic, const std::string& payload, int qos, bool retain, bool record,
               std::string* why) {
    int mid = 0;
    const int rc = mosquitto_publish_v5(client, &mid, topic.c_str(), static_cast<int>(payload.size()), payload.data(),
                                        qos, retain, nullptr);
    // QoS 1 and 2: the client queues the message while it is not connected and sends it once it is.
    const bool taken = rc == MOSQ_ERR_SUCCESS || (rc == MOSQ_ERR_NO_CONN && qos > 0);
    if (!taken) {
      if (why) *why = mosquitto_strerror(rc);
      return false;
    }
    std::lock_guard lock(mutex);
    if (!ackedEarly.erase(mid) && qos > 0) {
      pending[mid] = record;
      pendingRecords += record;
    }
    return true;
  }
};

MqttOutput::MqttOutput(const MqttOutputSettings& settings) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.settings = settings;
  m.recordTopic = settings.topic + "/record";
  m.stateTopic = settings.topic + "/state";
  requireReadable(settings.caFile, "ca_file");
  requireReadable(settings.certFile, "cert_file");
  requireReadable(settings.keyFile, "key_file");
  std::pair<std::string, std::string> credentials;
  if (!settings.credentialsFile.empty()) credentials = readCredentials(settings.credentialsFile);

  initLibrary();
  const std::string id = settings.clientId.empty() ? defaultClientId() : settings.clientId;
  m.client = mosquitto_new(id.c_str(), true, &m);
  if (!m.client) fail(Errc::Io, "{}: cannot make an MQTT client: {}", m.where(), std::strerror(errno));
  const auto check = [&](int rc, const char* what) {
    if (rc != MOSQ_ERR_SUCCESS) {
      mosquitto_destroy(m.client);
      m.client = nullptr;
      fail(Errc::Config, "{}: {}: {}", m.where(), what, mosquitto_strerror(rc));
    }
  };
  check(mosquitto_int_option(m.client, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5), "MQTT 5");
  check(mosquitto_int_option(m.client, MOSQ_OPT_SEND_MAXIMUM, kMaxInflight), "the in-flight bound");
  check(mosquitto_reconnect_delay_set(m.client, 1, 8, true), "the reconnect delay");
  if (!settings.credentialsFile.empty())
    check(mosquitto_username_pw_set(m.client, credentials.first.c_str(), credentials.second.c_str()),
          fmt::format("the credentials of '{}'", settings.credentialsFile.string()).c_str());
  if (settings.tls) {
    const std::string ca = settings.caFile.string(), cert = settings.certFile.string(), key = settings.keyFile.string();
    check(mosquitto_tls_set(m.client, ca.empty() ? nullptr : ca.c_str(), ca.empty() ? "/etc/ssl/certs" : nullptr,
                            cert.empty() ? nullptr : cert.c_str(), key.empty() ? nullptr : key.c_str(), nullptr),
          "TLS (ca_file, cert_file, key_file)");
  }
  check(mosquitto_will_set_v5(m.client, m.stateTopic.c_str(), static_cast<int>(std::strlen(kWill)), kWill, 1, true,
                              nullptr),
        "the last will");
  mosquitto_connect_v5_callback_set(m.client, &Impl::onConnect);
  mosquitto_disconnect_v5_callback_set(m.client, &Impl::onDisconnect);
  mosquitto_publish_v5_callback_set(m.client, &Impl::onPublish);
  mosquitto_log_callback_set(m.client, &Impl::onLog);

  const int rc = mosquitto_connect_async(m.client, settings.host.c_str(), settings.port, settings.keepalive_s);
  if (rc != MOSQ_ERR_SUCCESS) {
    // (a TLS handshake that fails at once has logged OpenSSL's reason on this thread already)
    const std::string reason = rc == MOSQ_ERR_ERRNO ? std::strerror(errno) : mosquitto_strerror(rc);
    std::unique_lock lock(m.mutex);
    const std::string detail = m.clientError.empty() ? "" : " (" + m.clientError + ")";
    lock.unlock();
    m.failure("connect", fmt::format("cannot connect: {}{}; retrying, records wait in the queue", reason, detail));
  }
  check(mosquitto_loop_start(m.client), "the network thread");
  std::unique_lock lock(m.mutex);
  m.changed.wait_for(lock, std::chrono::seconds(3), [&] {
    return m.up || m.failures.count("refused") || m.failures.count("connect") || !m.clientError.empty();
  });
  const bool named = m.up || m.failures.count("refused") || m.failures.count("connect");
  const std::string clientError = m.clientError;
  lock.unlock();
  if (!named)
    m.failure("connect", fmt::format("cannot connect: {}; retrying, records wait in the queue",
                                     clientError.empty() ? "no answer within 3 s" : clientError));
}

MqttOutput::~MqttOutput() {
  if (!impl_ || !impl_->client) return;
  Impl& m = *impl_;
  if (!m.finished) {
    // The run ended in an error: what it published may still go, then the last will says it is lost.
    std::unique_lock lock(m.mutex);
    m.changed.wait_for(lock, std::chrono::duration<double>(m.settings.drain_s),
                       [&] { return m.pending.empty() || !m.up; });
    m.finished = true;
    lock.unlock();
    mosquitto_disconnect_v5(m.client, MQTT_RC_DISCONNECT_WITH_WILL_MSG, nullptr);
    mosquitto_loop_stop(m.client, false);  // the disconnect (or its attempt) ends the network thread's loop
  }
  mosquitto_destroy(m.client);
}

void MqttOutput::publishRecord(std::uint64_t part, const std::string& json) {
  Impl& m = *impl_;
  {
    std::lock_guard lock(m.mutex);
    if (m.pendingRecords >= m.settings.queueLimit) {
      if (!m.droppingNow) m.firstDropped = part;
      ++m.dropped;
      const bool first = !m.droppingNow;
      m.droppingNow = true;
      if (first)
        spdlog::error(
            "{}: {} records wait unacknowledged (queue_limit); part {}'s record and those after it are "
            "not published until the queue drains (they are in the run's records.jsonl)",
            m.where(), m.pendingRecords, part);
      return;
    }
    m.droppingNow = false;
  }
  std::string why;
  if (!m.publish(m.recordTopic, json, m.settings.qos, false, true, &why)) {
    std::lock_guard lock(m.mutex);
    if (m.dropped++ == 0) m.firstDropped = part;
    spdlog::warn("{}: part {}'s record not published: {}", m.where(), part, why);
  }
}

void MqttOutput::publishState(RunState state) {
  std::string why;
  const std::string text = toString(state);
  if (!impl_->publish(impl_->stateTopic, text, 1, true, false, &why))
    spdlog::warn("{}: the state '{}' not published: {}", impl_->where(), text, why);
}

std::vector<std::string> MqttOutput::finish() {
  Impl& m = *impl_;
  if (m.finished) return problems();
  publishState(RunState::Stopped);
  std::unique_lock lock(m.mutex);
  m.changed.wait_for(lock, std::chrono::duration<double>(m.settings.drain_s), [&] { return m.pending.empty(); });
  m.finished = true;
  lock.unlock();
  mosquitto_disconnect_v5(m.client, MQTT_RC_NORMAL_DISCONNECTION, nullptr);
  mosquitto_loop_stop(m.client, false);
  return problems();
}

std::vector<std::string> MqttOutput::problems() const {
  const Impl& m = *impl_;
  std::lock_guard lock(m.mutex);
  std::vector<std::string> out;
  for (const auto& [kind, what] : m.failures) out.push_back(fmt::format("{}: {}", m.where(), what));
  if (m.dropped > 0)
    out.push_back(fmt::format("{}: {} record(s) not published, the first part {}'s (they are in records.jsonl)",
                              m.where(), m.dropped, m.firstDropped));
  if (m.finished && !m.pending.empty())
    out.push_back(
        fmt::format("{}: {} message(s) not acknowledged within drain_s = {} s (the records are in "
                    "records.jsonl)",
                    m.where(), m.pending.size(), m.settings.drain_s));
  return out;
}

std::size_t MqttOutput::pending() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->pending.size();
}

bool MqttOutput::connected() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->up;
}

const std::string& MqttOutput::broker() const {
  return impl_->settings.broker;
}

}  // namespace lfi
