// SPDX-License-Identifier: Apache-2.0
#pragma once
// The coded reference capture (`coded:`): the bench measures its own reference
// through its display and camera, with the intact part in place. Binary Gray
// code patterns over the panel's columns and rows (calib/coded_patterns.h)
// tell, for every camera pixel, which panel pixels' light reaches it through
// the part and the telecentric stop (one, or two per axis where a camera pixel
// sees two); those panel pixels, lit, are the inverse schlieren reference, and
// their weights are then refined in a closed loop (calib/coded_reference.h)
// until the intact part looks uniform.
//
//   step        frames                         what
//   white, black  2                            all white, all black (W × H panel)
//   rounds      2·⌈log2 W⌉ + 2·⌈log2 H⌉ + 1     each round: every pattern and its inverse
//               each                           with the panel pixels found so far dark,
//                                              then the all-white panel less those found
//                                              now (the light left); until at most
//                                              max_light_left is left, a round finds
//                                              nothing, or `rounds` have run
//   refine      1 .. 1 + iterations            the reference panel shown and taken;
//                                              stops at the uniformity target
//
// Each frame is the controller's inspection image (the mean of the bench's
// inspection frames). Decoding thresholds are calib::DecodeSettings' 8-bit
// figures scaled to the camera's full scale. Uniformity is measured over the
// linked camera pixels that see the panel fully (white − black at least 0.8
// of its 99th percentile). The refinement's target level is the
// `target_percentile` of their levels under the first reference panel (at full
// drive a panel pixel can only be dimmed); the loop stops when their
// coefficient of variation is at most `target_cv` or a step does not improve
// it (the best weights are kept).
//
// Refusals (Errc::Device, naming the bench's display and camera):
//   - the display not visible: no camera pixel brighter by minLit under the
//     all-white panel than under the all-black one;
//   - a camera that saturates: more than 1 % of the lit pixels at its full
//     scale under the all-white panel;
//   - the part missing: every decoded ray leaves the display within one panel
//     pixel's angle of the axis (nothing deflects it; `allow_undeflected=1` for
//     a part that does not);
//   - too few camera pixels decoded: fewer than `min_decoded` of the lit ones;
//   - a display that refuses a frame or a camera that fails: the frame's number.
//
// URI: coded:[?rounds=&max_light_left=&target_cv=&iterations=&
//      target_percentile=&min_decoded=&min_confidence=&second_share=&
//      allow_undeflected=]
//   key                 default  meaning
//   rounds              3        most rounds of patterns
//   max_light_left      0.02     stop when at most this share of the lit pixels' light is unfound
//   target_cv           0.05     uniformity target (standard deviation / mean)
//   iterations          8        most refinement steps
//   target_percentile   0.1      the target level's percentile, (0, 1)
//   min_decoded         0.5      fraction of lit camera pixels that must decode (first round)
//   min_confidence      0.25     a decoded pixel's panel pixels are lit from this confidence on
//   second_share        0.1      a camera pixel decodes to two panel columns (rows) when the
//                                second has this share of its light (DecodeSettings::secondShare)
//   allow_undeflected   0        1: accept a part that deflects no ray
// Δ, recorded in the light field, is the bench's (setDistance; 0 until set).
//
// The light field (capture()'s result) is the reference panel decoded through
// the display's optics (display_optics.h, decodePanelImage) at white = 1:
// elements of the optics' pitch (the lenslet or pinhole pitch; a lenticular
// sheet's lens pitch along a row), n × n directions with n = ⌈2·gap / panel
// pixel pitch⌉ (one sample per panel pixel's angle at the axis), covering the
// panel.

#include "lfi/drivers/light_field_capture.h"

#include <chrono>
#include <memory>
#include <string>

namespace lfi {

struct CodedCaptureSettings {
  int rounds = 3;
  double maxLightLeft = 0.02;
  double targetCv = 0.05;
  int iterations = 8;
  double targetPercentile = 0.1;
  double minDecoded = 0.5;
  double minConfidence = 0.25;
  double secondShare = 0.1;
  bool allowUndeflected = false;
};

// What the last capture did.
struct CodedCaptureReport {
  int panelWidth = 0, panelHeight = 0;
  int patternFrames = 0;            // white, black and every round's patterns and light-left frame
  int refineFrames = 0;             // reference panels shown and taken (the first and its refinements)
  double seconds = 0;               // the whole capture
  int rounds = 0;                   // of patterns
  double lightLeft = 1;             // of the lit pixels' light, after the last round that found any
  int lit = 0, decoded = 0;         // camera pixels, in the first round
  int panelPixelsLit = 0;           // in the reference panel
  double cvFirst = 0, cvFinal = 0;  // uniformity under the first and the final reference panel
  double target_dn = 0;
  bool converged = false;  // cvFinal <= target_cv
};

class CodedCapture final : public LightFieldCapture {
 public:
  // Throws Errc::InvalidArgument naming a setting out of range.
  explicit CodedCapture(CodedCaptureSettings settings);

  // The light field's geometry once the bench is set (before: only distance_mm).
  LightFieldGeometry geometry() const override;
  // Δ to record in the light field. Errc::InvalidArgument outside [0, 1e6] mm.
  void setDistance(double distance_mm) override;
  // Errc::InvalidArgument without a bench; the refusals above.
  LightField capture(const std::function<void(double)>& progress = {}) override;
  std::string description() const override;
  bool measuresThroughBench() const override { return true; }
  void setBench(BenchProbe* bench) override { bench_ = bench; }
  cv::Mat panelImage() const override { return panel_; }

  const CodedCaptureReport& report() const { return report_; }

 private:
  CodedCaptureSettings settings_;
  BenchProbe* bench_ = nullptr;
  double distance_mm_ = 0;
  cv::Mat panel_;
  CodedCaptureReport report_;
};

// The geometry of the light field a coded capture writes for a display (above).
LightFieldGeometry codedLightFieldGeometry(const DisplayInfo& display, double distance_mm);

// Registers the controller's backends: coded: (light field capture). Idempotent.
void registerControllerBackends();

}  // namespace lfi
