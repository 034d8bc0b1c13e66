// SPDX-License-Identifier: Apache-2.0
#pragma once
// The requests `lfi sim-bench` takes on its control socket
// (docs/hardware-in-the-loop.md lists them), one line each: a verb and its
// words, separated by spaces ("part /abs/scene.toml", "camera off",
// "packet-loss 0.05"). The socket and the served bench that carries a request
// out are the program's; reading the line is here.

#include <string>

namespace lfi::emulation {

struct BenchControlRequest {
  enum class Action {
    Part,     // a part's scene under the camera (argument; empty: the bench's own)
    Trigger,  // an edge on Line0
    CameraOff,
    CameraOn,
    PacketLoss,  // packetLoss of the GVSP packets dropped
    DisplayUnplug,
    DisplayPlug,
    DisplayStall,
    DisplayCorrupt,
    DisplayShort,
    DisplayHang,
    DisplayAnswer,
    Status,
  };
  Action action = Action::Status;
  std::string argument;   // the words after the verb as sent, spaces at the end left out
  double packetLoss = 0;  // PacketLoss: 0..1
};

// Reads one request line. Throws Errc::InvalidArgument for an unknown request
// (naming it and listing the requests) and for a packet loss that is not a
// fraction 0..1.
BenchControlRequest parseBenchControlRequest(const std::string& line);

}  // namespace lfi::emulation
