// SPDX-License-Identifier: Apache-2.0
// The display-quality sweep: its default points, the light field variant of
// each point (checked before the study starts), and the answers drawn from
// the variants' results.

#include "study_internal.h"

#include "lfi/core/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

namespace lfi::study {

using namespace detail;

namespace {

// Paraxial focal length of the bench lens (thick-lens lensmaker equation).
double lensFocalLength(const Bench::Lens& lens) {
  const double c1 = lens.frontRadius_mm == 0 ? 0 : 1 / lens.frontRadius_mm;
  const double c2 = lens.backRadius_mm == 0 ? 0 : 1 / lens.backRadius_mm;
  const double n = lens.ior, t = lens.centreThickness_mm;
  return 1 / ((n - 1) * (c1 - c2 + (n - 1) * t * c1 * c2 / n));
}

}  // namespace

namespace detail {

std::vector<DisplayClass> displayClasses(const Bench& bench) {
  const DisplayOpticsParams& own = bench.display.optics;
  const double pixel = bench.inverseSchlieren.pixelPitch_mm;
  // The bench's lattice, or a lenticular sheet's lens pitch as the array's.
  const double pitch = fullParallax(own.type) ? own.arrayPitch_mm : own.lensPitch_px * pixel;
  const double offset = fullParallax(own.type) ? own.arrayOffsetX_mm : own.offset_px * pixel;
  const double focal = own.focalLength_mm > 0 ? own.focalLength_mm : own.gap_mm;
  DisplayOpticsParams lenslet;
  lenslet.type = OpticsType::LensletArray;
  lenslet.packing = LensPacking::Square;
  lenslet.arrayPitch_mm = pitch;
  lenslet.arrayOffsetX_mm = lenslet.arrayOffsetY_mm = offset;
  lenslet.gap_mm = own.gap_mm;
  lenslet.focalLength_mm = focal;
  DisplayOpticsParams pinhole = lenslet;
  pinhole.type = OpticsType::PinholeArray;
  pinhole.focalLength_mm = 0;
  // Four panel pixels: 4.9 % of the plane passes at the bench's 16-pixel pitch
  // (one pixel's hole would pass 0.3 %), each beam 4 pixels wide in angle.
  pinhole.pinholeDiameter_mm = 4 * pixel;
  DisplayOpticsParams lenticular;
  lenticular.type = OpticsType::Lenticular;
  lenticular.lensPitch_px = pitch / pixel;
  lenticular.offset_px = offset / pixel;
  lenticular.gap_mm = own.gap_mm;
  lenticular.focalLength_mm = focal;
  const double hole = std::numbers::pi / 4 * pinhole.pinholeDiameter_mm * pinhole.pinholeDiameter_mm;
  return {{toString(OpticsType::LensletArray), lenslet, 1.0},
          {toString(OpticsType::PinholeArray), pinhole, hole / (pitch * pitch)},
          {toString(OpticsType::Lenticular), lenticular, 1.0}};
}

std::vector<SweepVariant> sweepVariants(const Bench& bench, const std::vector<SweepPoint>& sweep) {
  const LightFieldGeometry reference = bench.lightFieldGeometry();
  const double delta = reference.distance_mm, shift = std::abs(bench.defects.misalignment_mm);
  const double footprint = 0.5 * bench.lens.diameter_mm * std::abs(1 - delta / lensFocalLength(bench.lens)) +
                           (delta + 2 * shift) * std::tan(bench.camera.objectNa) + shift + 2.0;
  const double lowest = bench.lensSpan(true).low;
  std::vector<SweepVariant> variants;
  for (const SweepPoint& point : sweep) {
    SweepVariant v{point, reference};
    LightFieldGeometry& g = v.geometry;
    auto refuse = [&](const std::string& why) {
      fail(Errc::InvalidArgument, "sweep point {} = {}: {}", point.series, point.value, why);
    };
    if (!std::isfinite(point.value)) refuse("not a number");
    if (point.series == "angular") {
      if (point.value < 1 || point.value > 256 || point.value != std::floor(point.value))
        refuse("the angular elements per side must be a whole number in [1, 256]");
      g.angular = static_cast<int>(point.value);
      g.pixelPitch_mm = reference.elementPitch_mm() / g.angular;
    } else if (point.series == "element") {
      if (!(point.value > 0)) refuse("the element pitch must be > 0 mm");
      g.pixelPitch_mm = point.value / g.angular;
    } else if (point.series == "delta_error") {
      v.displayError_mm = point.value;
      if (-(delta + point.value) >= lowest)
        refuse(
            fmt::format("the display plane at z = {} would be inside or above the lens, which reaches down to "
                        "z = {:.4g} (with the bench's misalignment_mm); choose a larger [inverse_schlieren] "
                        "distance_mm, or leave the sweep out (--no-sweep)",
                        -(delta + point.value), lowest));
    } else {
      refuse("unknown series (angular, element, delta_error)");
    }
    // (In double first: a tiny element would make a count past int, and LightFieldGeometry refuses past 2^15.)
    const double elements = std::ceil(2 * footprint / g.elementPitch_mm());
    if (!(elements <= 1 << 15))
      refuse(fmt::format("the lens's {:.4g} mm footprint needs {:g} elements a side, more than 32768", 2 * footprint,
                         elements));
    g.spatialX = g.spatialY = std::max(2, static_cast<int>(elements));
    try {
      g.validate();
    } catch (const Error& e) {
      refuse(e.what());
    }
    variants.push_back(std::move(v));
  }
  return variants;
}

}  // namespace detail

std::vector<SweepPoint> defaultSweep() {
  std::vector<SweepPoint> points;
  for (int n : {4, 8, 16, 32}) points.push_back({"angular", static_cast<double>(n)});
  for (double e : {0.2, 0.4, 0.8, 1.6, 3.2, 6.4}) points.push_back({"element", e});
  for (double d : {-8.0, -4.0, -2.0, -1.0, 0.0, 1.0, 2.0, 4.0, 8.0}) points.push_back({"delta_error", d});
  return points;
}

nlohmann::ordered_json sweepAnswers(const nlohmann::ordered_json& sweep) {
  // For each defect and lookup: the coarsest light field that still detects
  // it (largest element, fewest angular elements) and the largest display
  // position error up to which it stays detected (on both sides).
  nlohmann::ordered_json answers;
  for (const char* lookup : {"nearest", "interpolated"}) {
    std::map<std::string, double> coarsestElement, fewestAngular, deltaTolerance;
    std::vector<nlohmann::ordered_json> deltaPoints;
    // Per defect, series and setting: whether every point there detects it.
    std::map<std::string, std::map<double, bool>> byElement, byAngular;
    auto note = [](std::map<double, bool>& at, double value, bool detected) {
      auto [it, fresh] = at.try_emplace(value, true);
      it->second = it->second && detected;
    };
    for (const auto& p : sweep["points"]) {
      for (const auto& [defect, cnr] : p["cnr"][lookup].items()) {
        const bool detected = cnr.get<double>() >= kDetectedCnr;
        const double value = p["value"].get<double>();
        if (p["series"] == "element") note(byElement[defect], value, detected);
        if (p["series"] == "angular") note(byAngular[defect], value, detected);
      }
      if (p["series"] == "delta_error") deltaPoints.push_back(p);
    }
    // From the finest setting towards coarser ones, up to the first that misses
    // the defect: a coarse setting that detects it beyond one that does not
    // (capture noise) is no answer.
    for (const auto& [defect, at] : byElement)
      for (const auto& [element, detected] : at) {  // ascending element size
        if (!detected) break;
        coarsestElement[defect] = element;
      }
    for (const auto& [defect, at] : byAngular)
      for (auto it = at.rbegin(); it != at.rend() && it->second; ++it) fewestAngular[defect] = it->first;
    // Per defect: for each |error|, whether every point at that |error| detects.
    std::map<std::string, std::map<double, bool>> detectedAt;
    for (const auto& p : deltaPoints)
      for (const auto& [defect, cnr] : p["cnr"][lookup].items()) {
        note(detectedAt[defect], std::abs(p["value"].get<double>()), cnr.get<double>() >= kDetectedCnr);
      }
    for (const auto& [defect, levels] : detectedAt)
      for (const auto& [level, detected] : levels) {  // ascending |error|
        if (!detected) break;
        deltaTolerance[defect] = level;
      }
    for (const auto& [defect, unused] : sweep["points"][0]["cnr"][lookup].items()) {
      auto& a = answers[defect][lookup];
      a["coarsest_element_mm"] =
          coarsestElement.count(defect) ? nlohmann::ordered_json(coarsestElement[defect]) : nullptr;
      a["fewest_angular"] = fewestAngular.count(defect) ? nlohmann::ordered_json(fewestAngular[defect]) : nullptr;
      a["delta_tolerance_mm"] = deltaTolerance.count(defect) ? nlohmann::ordered_json(deltaTolerance[defect]) : nullptr;
    }
  }
  return answers;
}

}  // namespace lfi::study
