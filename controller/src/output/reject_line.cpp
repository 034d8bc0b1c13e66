// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/reject_line.h"

#include "lfi/core/error.h"
#include "lfi/core/log.h"

#include <thread>

namespace lfi {

RejectLine::RejectLine(Camera& camera, const LineOutputSettings& settings) : camera_(camera), settings_(settings) {
  set("LineSelector", settings_.line);
  try {
    set("LineMode", "Output");
  } catch (const Error& e) {
    // Cameras whose output lines are outputs only have no LineMode.
    if (e.code() != Errc::NotFound) throw;
  }
  set("LineSource", settings_.userOutput);
  set("UserOutputSelector", settings_.userOutput);
  set("UserOutputValue", "false");
}

RejectLine::~RejectLine() {
  if (!high_) return;
  try {
    set("UserOutputValue", "false");
  } catch (const Error& e) {
    spdlog::error("[output.line]: {} stays high: {}", settings_.line, e.what());
  }
}

void RejectLine::set(const char* feature, const std::string& value) {
  try {
    camera_.setFeature(feature, value);
  } catch (const Error& e) {
    fail(e.code(), "[output.line]: {} = {} for {}: {}", feature, value, settings_.line, e.what());
  }
}

void RejectLine::raise() {
  set("UserOutputValue", "true");
  high_ = true;
  raised_ = std::chrono::steady_clock::now();
}

void RejectLine::lower() {
  if (!high_) return;
  std::this_thread::sleep_until(raised_ + std::chrono::duration<double, std::milli>(settings_.pulse_ms));
  set("UserOutputValue", "false");
  high_ = false;
}

}  // namespace lfi
