// SPDX-License-Identifier: Apache-2.0
#include "lfi/emulation/bench_control.h"

#include "lfi/core/error.h"

#include <exception>
#include <sstream>

namespace lfi::emulation {

namespace {

double parseRatio(const std::string& text) {
  std::size_t used = 0;
  double value = -1;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
  }
  if (used != text.size() || !(value >= 0 && value <= 1))
    fail(Errc::InvalidArgument, "packet-loss '{}': a fraction 0..1 is needed", text);
  return value;
}

}  // namespace

BenchControlRequest parseBenchControlRequest(const std::string& line) {
  using Action = BenchControlRequest::Action;
  std::istringstream in(line);
  std::string verb, what;
  in >> verb;
  std::getline(in >> std::ws, what);
  while (!what.empty() && what.back() == ' ') what.pop_back();
  BenchControlRequest r;
  r.argument = what;
  if (verb == "part") {
    r.action = Action::Part;
  } else if (verb == "trigger" && what.empty()) {
    r.action = Action::Trigger;
  } else if (verb == "camera" && (what == "off" || what == "on")) {
    r.action = what == "off" ? Action::CameraOff : Action::CameraOn;
  } else if (verb == "packet-loss") {
    r.action = Action::PacketLoss;
    r.packetLoss = parseRatio(what);
  } else if (verb == "display" && (what == "unplug" || what == "plug")) {
    r.action = what == "unplug" ? Action::DisplayUnplug : Action::DisplayPlug;
  } else if (verb == "display" && what == "stall") {
    r.action = Action::DisplayStall;
  } else if (verb == "display" && what == "corrupt") {
    r.action = Action::DisplayCorrupt;
  } else if (verb == "display" && what == "short") {
    r.action = Action::DisplayShort;
  } else if (verb == "display" && (what == "hang" || what == "answer")) {
    r.action = what == "hang" ? Action::DisplayHang : Action::DisplayAnswer;
  } else if (verb == "status" && what.empty()) {
    r.action = Action::Status;
  } else {
    fail(Errc::InvalidArgument,
         "unknown request '{}' (part [SCENE] | trigger | camera off|on | packet-loss R | display "
         "unplug|plug|stall|corrupt|short|hang|answer | status)",
         line);
  }
  return r;
}

}  // namespace lfi::emulation
