// SPDX-License-Identifier: Apache-2.0
#pragma once
// A camera's dark and flat frames (`lfi calibrate camera --dark`, `--flat`)
// and the correction they make of every image the controller takes
// (docs/calibration.md, "Dark and flat frames"):
//
//   corrected = (image - dark) · g,   g = median(flat - dark) / (flat - dark)
//
// per pixel: the dark frame's offsets (black level, dark non-uniformity)
// taken away, and each pixel's response (vignetting, photo-response
// non-uniformity) made the median pixel's. A pixel the image saturates stays
// at the camera's full scale: a clipped value measures nothing, and checks
// after the correction still see it.
//
// Each frame is the mean of many frames at the bench's camera settings: the
// dark one with the display dark (and the lens capped where room light
// reaches the camera), the flat one of a uniform source filling the view (an
// opal diffuser in the part's place lit by the display; on a simulated bench
// data/scenes/inspection_bench_flat.toml). It is kept as a radiance EXR in
// camera DN whose lfi.settings.* attributes say how it was taken (kind,
// camera, exposure_us, gain, pixel_format, binning, width, height, frames).
//
// Refusals (Errc::Config, naming the file(s)): a flat frame with saturated
// pixels, with pixels below kLeastRelativeResponse of the median response
// (dead, dusty or unlit), or no brighter than the dark frame; frames of other
// sizes, kinds or settings than each other or the bench's camera.

#include "lfi/controller/bench_file.h"
#include "lfi/controller/bench_file_edit.h"
#include "lfi/drivers/camera.h"
#include "lfi/drivers/light_field_capture.h"

#include <opencv2/core.hpp>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

namespace lfi {

enum class CalibrationFrameKind { Dark, Flat };
const char* toString(CalibrationFrameKind kind);

// A pixel whose response (flat - dark) is below this fraction of the
// median's is refused: its correction would multiply its noise more than 5 times.
inline constexpr double kLeastRelativeResponse = 0.2;

struct CalibrationFrame {
  CalibrationFrameKind kind = CalibrationFrameKind::Dark;
  cv::Mat image;            // CV_32FC1, the mean of `frames` frames, DN
  std::string camera;       // the camera's device id
  CameraSettings settings;  // exposure_us, gain, pixelFormat, binning (what the frame depends on)
  int frames = 0;
  std::filesystem::path file;  // where it was read from (empty for one just taken)

  // "dark frame 'file'" or "dark frame" for messages.
  std::string name() const;
};

// Takes the frame through `bench` (Controller::probe() of a controller
// without a correction, averaging `frames` frames an image): the panel dark
// for a dark frame, all white for a flat one; `camera`, `settings` and
// `frames` are recorded with it.
CalibrationFrame takeCalibrationFrame(BenchProbe& bench, CalibrationFrameKind kind, const std::string& camera,
                                      const CameraSettings& settings, int frames);

// Writes it atomically; never replaces a file (Errc::Exists).
void writeCalibrationFrame(const std::filesystem::path& file, const CalibrationFrame& frame);
// Reads one; Errc::InvalidFile naming the file and the attribute that is
// missing or wrong, or when it is of another kind than `kind`.
CalibrationFrame readCalibrationFrame(const std::filesystem::path& file, CalibrationFrameKind kind);

class FrameCorrection {
 public:
  // Checks the frames against each other (same camera settings and size; the
  // refusals above, for a flat).
  FrameCorrection(CalibrationFrame dark, std::optional<CalibrationFrame> flat);

  // Errc::Config naming the frame's file and the setting when `settings`
  // differ from the frames' in exposure, gain, pixel format or binning.
  void requireSettings(const CameraSettings& settings, const std::string& where) const;

  // Corrects a CV_32FC1 image in place. Errc::Config naming the dark frame's
  // file when the image is of another size (the camera's region changed).
  void apply(cv::Mat& image) const;

  const CalibrationFrame& dark() const { return dark_; }
  const std::optional<CalibrationFrame>& flat() const { return flat_; }
  // g, CV_32FC1 (1 everywhere without a flat frame).
  const cv::Mat& gain() const { return gain_; }

 private:
  CalibrationFrame dark_;
  std::optional<CalibrationFrame> flat_;
  cv::Mat gain_;
  float fullScale_dn_ = 0;
};

// What `lfi calibrate camera --dark` (`--flat`) writes into a bench file:
// [camera] dark_frame (flat_frame), `file` relative to the bench file's folder,
// with a comment naming the calibration and its time.
void setCalibrationFrame(BenchFileEdit& edit, CalibrationFrameKind kind, const std::filesystem::path& file,
                         const std::string& stampUtc);

// The calibration's record (JSON, "lfi-calibration-record" version 1, `what`
// "dark" or "flat"): the camera and its settings, the frame's mean, spread
// and range (DN) and, with a flat frame, the relative response's range.
std::string calibrationFrameRecord(const FrameCorrection& correction, CalibrationFrameKind kind, const BenchFile& bench,
                                   const std::string& stampUtc, const std::string& cameraDescription);

// The correction the bench file's [camera] dark_frame and flat_frame make
// (none without dark_frame), checked against its camera settings.
std::shared_ptr<const FrameCorrection> loadFrameCorrection(const BenchFile& bench);

}  // namespace lfi
