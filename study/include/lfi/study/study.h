// SPDX-License-Identifier: Apache-2.0
#pragma once
// The reference study (docs/study.md): the bi-convex lens with six kinds of defect,
// seen by the telecentric camera in five setups (parallel and area back light,
// conventional schlieren, inverse schlieren with the ideal light field emitter
// and through the bench's display), each image compared with the intact lens
// in the same setup by one declared criterion (docs/study.md).

#include "lfi/core/config.h"
#include "lfi/core/light_field.h"
#include "lfi/drivers/display.h"
#include "lfi/sim/devices/camera_sensor_model.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace lfi::study {

// The bench file (data/benches/reference.toml documents every field).
struct Bench {
  struct Lens {
    double ior, diameter_mm, frontRadius_mm, backRadius_mm, centreThickness_mm, absorption_per_mm;
  } lens;
  struct Camera {
    double pixelPitch_mm, magnification, workingDistance_mm, objectNa;
    int width, height;
    double fullWell_e, readNoise_e, exposureFill;
    int bitDepth;
  } camera;
  struct Backlight {
    double distance_mm, size_mm, halfAngle_rad;
  } parallel, area;
  // Conventional schlieren: the parallel back light, and a knife edge in the
  // camera's stop at knifeEdge (units of the stop's radius; TelecentricCamera).
  struct Schlieren {
    double knifeEdge;
  } schlieren;
  struct InverseSchlieren {
    double distance_mm, pixelPitch_mm;
    int angular, spatial;
    LightFieldLookup lookup;
    double captureHalfAngle_rad, captureDistance_mm;
    // What the display shows for the captured light field: its radiance
    // (Captured), or every angular pixel lit or dark (Binary: binaryDrive()
    // at binaryThreshold of the brightest).
    enum class Drive { Captured, Binary } drive;
    double binaryThreshold;
  } inverseSchlieren;
  // The bench's light field display, for the "display" setup (inverse
  // schlieren through a panel and its optics rather than the ideal emitter):
  // its panel is the light field's pixel grid (pixelPitch_mm, spatial x
  // angular pixels a side, one mono subpixel) at Δ + gap below the lens.
  struct Display {
    DisplayOpticsParams optics;
  } display;
  struct Defects {
    double inclusionRadius_mm, rimRadial_mm, cutLargeRadius_mm, cutLargeRadial_mm, cutSubpixelRadius_mm,
        cutSubpixelRadial_mm, indexFactor, misalignment_mm;
  } defects;
  std::string source;  // the file load() read (recorded in study.json)

  // Reads a bench file. Errors name the file, line and key, also for values
  // in range that together make a bench that cannot exist (a part inside the
  // lens, a defect outside it).
  static Bench load(const std::filesystem::path& path);
  // The same with numbers of the file replaced ("table.key" = value: a
  // sweep's point, sweep_file.h), checked as the file's own.
  static Bench load(const std::filesystem::path& path, const std::vector<ConfigTable::Override>& overrides);
  // The lens's lowest and highest z (world frame, mm): at the origin, and
  // with `misaligned` over both of its positions (also moved by
  // -misalignment_mm along z, the misaligned scene's).
  struct Span {
    double low, high;
  };
  Span lensSpan(bool misaligned) const;
  sim::TelecentricCamera telecentricCamera() const;
  sim::CameraSensorModel sensorModel() const;
  LightFieldGeometry lightFieldGeometry() const;
  // What the display shows for a light field captured on this bench (drive).
  LightField displayed(const LightField& captured) const;
  // The display with `optics` over the bench's panel (Display above).
  DisplayInfo displayInfo(const DisplayOpticsParams& optics) const;
};

enum class Quality { Quick, Default, High };
Quality parseQuality(const std::string& name);

// One variant of the display-quality sweep: `series` is "angular" (angular
// elements per side at the bench's element size), "element" (element pitch in
// mm at the bench's angular resolution) or "delta_error" (display moved by
// `value` mm away from the lens after capturing at Δ).
struct SweepPoint {
  std::string series;
  double value;
};
std::vector<SweepPoint> defaultSweep();

// One defect of the detection limits (docs/study.md): `kind` is "particle"
// (an opaque sphere of radius `size` mm at the lens's centre), "bubble" (an
// air sphere, the same), "cut" (a sphere of radius `size` mm cut out of the
// camera-side surface where the large cut is), "index" (the lens's index
// higher by the fraction `size`) or "shift" (the lens moved `size` mm along
// the axis, away from the camera).
struct LimitPoint {
  std::string kind;
  double size;
};
std::vector<LimitPoint> defaultLimits();

struct StudyOptions {
  Quality quality = Quality::Default;
  // Display-quality sweep; unset: defaultSweep() except in quick quality.
  std::optional<std::vector<SweepPoint>> sweep;
  // Detection limits; unset: defaultLimits() except in quick quality.
  std::optional<std::vector<LimitPoint>> limits;
  std::uint64_t seed = 1;
  int threads = 0;
  bool overwrite = false;
  // Progress: a label for the current step and the overall fraction done.
  std::function<void(const std::string&, double)> progress;
};

// How evenly a setup lights the intact lens: over its inner part (object
// points within 0.9 R of the axis), the share of camera pixels above a quarter
// of the brightest and the coefficient of variation (standard deviation over
// mean) of the rendered radiance.
struct Uniformity {
  double litShare = 0;
  double cv = 0;
};
// The intact lens under `setup` ("parallel", "area", "schlieren",
// "inverse_schlieren") as the study renders it at `quality` (its camera,
// samples and, for inverse schlieren, its light field capture).
Uniformity intactUniformity(const Bench& bench, const std::string& setup, Quality quality, std::uint64_t seed = 1,
                            int threads = 0);

// Runs the study, writes DIR/study.json, DIR/images/*, DIR/report.html and
// returns the JSON document.
nlohmann::ordered_json runStudy(const Bench& bench, const std::filesystem::path& outDir, const StudyOptions& options);

// From the sweep's points: per defect and lookup, the coarsest light field
// that still detects it and the display position tolerance.
nlohmann::ordered_json sweepAnswers(const nlohmann::ordered_json& sweep);

// The verdict table as text, for the terminal.
std::string verdictTable(const nlohmann::ordered_json& study);

}  // namespace lfi::study
