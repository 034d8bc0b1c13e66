// SPDX-License-Identifier: Apache-2.0
#pragma once
// The camera's output line pulsed on a failed part, as the bench's
// [output.line] says (bench_file.h; docs/inspection.md "The verdict out to the
// line"): a PLC's input or a reject gate wired to the camera's output. Through
// the camera's GenICam features (SFNC's DigitalIOControl): LineSelector =
// <line>, LineMode = Output (where the camera has LineMode), LineSource =
// <user_output>, and UserOutputSelector = <user_output>, whose
// UserOutputValue is the line's level.
//
// The run raises the line as soon as a part's verdict fails, before its
// images and record are written, and lowers it once pulse_ms have passed
// since, before the next part: the line is high for at least pulse_ms, and a
// part's pulse always ends before the next part's can start. Drive it from
// the camera's thread (camera.h).

#include "lfi/controller/bench_file.h"
#include "lfi/drivers/camera.h"

#include <chrono>

namespace lfi {

class RejectLine {
 public:
  // Sets the line up and low. A camera without the features, or one that
  // refuses the values, throws Errc::NotFound or Errc::Device naming the
  // camera, the feature and the value.
  RejectLine(Camera& camera, const LineOutputSettings& settings);
  // Lowers the line if it is high; never throws.
  ~RejectLine();
  RejectLine(const RejectLine&) = delete;
  RejectLine& operator=(const RejectLine&) = delete;

  void raise();
  // Waits for the rest of the pulse, then lowers the line; nothing when it is low.
  void lower();
  bool high() const { return high_; }

 private:
  void set(const char* feature, const std::string& value);

  Camera& camera_;
  LineOutputSettings settings_;
  bool high_ = false;
  std::chrono::steady_clock::time_point raised_;
};

}  // namespace lfi
