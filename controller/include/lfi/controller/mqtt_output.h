// SPDX-License-Identifier: Apache-2.0
#pragma once
// A run's records and state on an MQTT broker, as the bench's [output.mqtt]
// says (bench_file.h; docs/inspection.md "The verdict out to the line"), over
// libmosquitto:
//
//   <topic>/record   each part's record, its JSON line (inspection_record.h),
//                    at the bench's QoS, in the order of the parts, not retained
//   <topic>/state    "running", "waiting" (for a device) or "stopped", retained,
//                    QoS 1; the last will "lost", retained, when the run's
//                    connection ends without "stopped" (the process died)
//
// libmosquitto's network thread keeps the connection, reconnecting with a
// doubling back-off (1 s to 8 s). While the broker is away, records at QoS 1
// and 2 wait in the client's queue and go out in order when it is back; at
// most queue_limit of them wait unacknowledged. A record past that bound, or
// one at QoS 0 while no broker listens, is not published: it stays in the
// run's records.jsonl, and the output says how many (problems()). An
// unreachable broker or a refused connection (bad credentials, a client the
// broker does not allow) is a problem of the output, named with the broker and
// the cause; it never stops the run nor touches its records.

#include "lfi/controller/bench_file.h"

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace lfi {

enum class RunState { Running, Waiting, Stopped };

const char* toString(RunState state);  // "running", "waiting", "stopped"

class MqttOutput {
 public:
  // Reads the credentials and certificate files (Errc::NotFound or
  // Errc::Config naming the file), then connects, waiting up to 3 s for the
  // broker's answer; a broker that is away by then, or a connection that
  // failed (a TLS handshake's error named), is a problem, retried in the
  // background.
  explicit MqttOutput(const MqttOutputSettings& settings);
  // Ends the connection without "stopped" (the broker then sends the last
  // will) unless finish() said it; never throws.
  ~MqttOutput();
  MqttOutput(const MqttOutput&) = delete;
  MqttOutput& operator=(const MqttOutput&) = delete;

  // Hands a part's record (its JSON text) to the queue; never blocks on the
  // network. `part` names it in problems.
  void publishRecord(std::uint64_t part, const std::string& json);
  void publishState(RunState state);
  // Publishes "stopped", waits up to drain_s for every queued message's
  // acknowledgement, disconnects, and returns problems().
  std::vector<std::string> finish();

  // What went wrong so far, each naming the broker: the connection's
  // failures (the last of each kind) and the records not published or not
  // acknowledged.
  std::vector<std::string> problems() const;
  // Messages handed to the client and not yet acknowledged (QoS 1 and 2) or sent (QoS 0).
  std::size_t pending() const;
  // Whether the broker accepted the connection and it is up.
  bool connected() const;
  const std::string& broker() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lfi
