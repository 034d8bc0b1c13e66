// SPDX-License-Identifier: Apache-2.0
// The detection limits: one defect of each kind at a ladder of sizes, judged
// in every setup by the declared criterion; the smallest size each setup
// detects.

#include "study_internal.h"

#include "lfi/core/error.h"
#include "lfi/sim/solid.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace lfi::study {

using namespace detail;

std::vector<LimitPoint> defaultLimits() {
  std::vector<LimitPoint> points;
  for (const char* kind : {"particle", "bubble"})
    for (double r : {0.02, 0.05, 0.1, 0.2, 0.5}) points.push_back({kind, r});
  for (double r : {0.05, 0.1, 0.2, 0.5, 1.0, 2.0}) points.push_back({"cut", r});
  for (double dn : {0.001, 0.003, 0.01, 0.03, 0.1}) points.push_back({"index", dn});
  for (double dz : {0.03, 0.1, 0.3, 1.0, 3.0}) points.push_back({"shift", dz});
  return points;
}

namespace detail {

SceneSpec limitScene(const Bench& bench, const LimitPoint& point) {
  const Bench::Lens& lens = bench.lens;
  auto refuse = [&](const std::string& why) {
    fail(Errc::InvalidArgument, "detection limit {} = {}: {}", point.kind, point.size, why);
  };
  if (!(point.size > 0) || !std::isfinite(point.size)) refuse("the size must be a number > 0");
  const auto lensSolid =
      sim::Solid::sphericalLens(lens.frontRadius_mm, lens.backRadius_mm, lens.centreThickness_mm, lens.diameter_mm);
  SceneSpec s{.name = fmt::format("{}_{:g}", point.kind, point.size)};
  if (point.kind == "particle" || point.kind == "bubble") {
    if (!sim::sphericalLensHolds(lens.frontRadius_mm, lens.backRadius_mm, lens.centreThickness_mm, lens.diameter_mm,
                                 {0, 0, 0}, point.size))
      refuse("the sphere at the lens's centre would not lie inside the glass");
    s.inclusions = {{{0, 0, 0}, point.size}};
    s.bubbles = point.kind == "bubble";
    s.defects = {{point.kind, sim::Solid::sphere(point.size)}};
  } else if (point.kind == "cut") {
    const double radial = bench.defects.cutLargeRadial_mm;
    if (point.size >= 0.5 * lens.diameter_mm) refuse("the cut would be as wide as the lens");
    const Vec3 c(radial, 0, sim::sphericalFaceZ(lens.backRadius_mm, lens.centreThickness_mm / 2, std::abs(radial)));
    s.cuts = {{c, point.size}};
    s.defects = {{"cut", sim::Solid::sphere(point.size, Rigid3::translation(c))}};
  } else if (point.kind == "index") {
    if (lens.ior * (1 + point.size) > 5)
      refuse(fmt::format("the index would be {:g}, above 5", lens.ior * (1 + point.size)));
    s.iorFactor = 1 + point.size;
    s.defects = {{"lens", lensSolid}};
  } else if (point.kind == "shift") {
    // Away from the camera, towards the back lights: it must stay above them.
    const double nearest =
        std::min({bench.parallel.distance_mm, bench.area.distance_mm, bench.inverseSchlieren.distance_mm});
    if (bench.lensSpan(false).low - point.size <= -nearest)
      refuse(fmt::format("the lens would reach the plane {} mm below its centre", nearest));
    s.lensShift_mm = -point.size;
    const auto moved =
        sim::Solid::combine(sim::Solid::Kind::Union, lensSolid, lensSolid, Rigid3::translation({0, 0, -point.size}));
    s.defects = {{"lens", sim::Solid::combine(sim::Solid::Kind::Union, lensSolid, moved)}};
  } else {
    refuse("unknown kind (particle, bubble, cut, index, shift)");
  }
  return s;
}

std::vector<SceneSpec> limitScenes(const Bench& bench, const std::vector<LimitPoint>& points) {
  if (points.empty()) return {};
  std::vector<SceneSpec> specs = {sceneSpecs(bench).front()};
  std::map<std::string, double> largest;
  for (const LimitPoint& point : points) {
    specs.push_back(limitScene(bench, point));
    if (const auto it = largest.find(point.kind); it != largest.end() && point.size <= it->second)
      fail(Errc::InvalidArgument,
           "detection limit {} = {}: the sizes of a kind must be given in ascending order, "
           "each once",
           point.kind, point.size);
    largest[point.kind] = point.size;
  }
  return specs;
}

nlohmann::ordered_json limitCurves(const std::vector<LimitPoint>& points, const std::vector<std::string>& setups,
                                   const std::vector<std::vector<double>>& cnr) {
  static const std::map<std::string, std::string> units = {{"particle", "radius (mm)"},
                                                           {"bubble", "radius (mm)"},
                                                           {"cut", "radius (mm)"},
                                                           {"index", "relative index change"},
                                                           {"shift", "axial shift (mm)"}};
  nlohmann::ordered_json out = nlohmann::ordered_json::object();
  for (size_t i = 0; i < points.size(); ++i) {
    auto& kind = out[points[i].kind];
    kind["unit"] = units.at(points[i].kind);
    kind["sizes"].push_back(points[i].size);
    for (size_t s = 0; s < setups.size(); ++s) kind["setups"][setups[s]]["cnr"].push_back(cnr[i][s]);
  }
  // The smallest size from which every larger one is detected (sizes ascending: limitScenes).
  for (auto& [name, kind] : out.items()) {
    const auto sizes = kind["sizes"].get<std::vector<double>>();
    for (auto& [setup, curve] : kind["setups"].items()) {
      const auto values = curve["cnr"].get<std::vector<double>>();
      nlohmann::ordered_json limit = nullptr;
      for (size_t k = values.size(); k-- > 0 && values[k] >= kDetectedCnr;) limit = sizes[k];
      curve["limit"] = limit;
    }
  }
  return out;
}

}  // namespace detail

}  // namespace lfi::study
