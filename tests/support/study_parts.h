// SPDX-License-Identifier: Apache-2.0
#pragma once
// The study's defect parts on the inspection bench (data/scenes/inspection_bench.toml:
// the N-BK7 lens, R = 51.5 mm, 5 mm thick, Ø25.4, seen in 0.5 mm object pixels), as
// edits of that scene file's text, with where each defect is on the part.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace lfi::testing_support {

// The bench's object pixel: what a defect's position is known to.
inline constexpr double kInspectionPixel_mm = 0.5;

// The lens's camera-side face: z = t/2 - (R - sqrt(R² - r²)) at radial distance r.
inline double inspectionLensFaceZ(double r) {
  return 2.5 - (51.5 - std::sqrt(51.5 * 51.5 - r * r));
}

struct StudyPart {
  std::string name;
  std::vector<std::pair<std::string, std::string>> edits;  // of the bench's scene text
  std::string extra;                                       // objects appended after the lens
  std::vector<std::pair<double, double>> defects_mm;       // known positions on the part
  double within_mm = 0;                                    // ... and how near the detector places them
  bool intact = false;
};

inline std::vector<StudyPart> studyParts() {
  const auto spheres = [](const char* material) {
    return fmt::format(
        "[[object]]\nname = \"centre\"\nshape = \"sphere\"\nradius_mm = 0.5\n{0}\n"
        "[[object]]\nname = \"rim\"\nshape = \"sphere\"\nradius_mm = 0.5\nposition_mm = [10, 0, 0]\n"
        "{0}\n",
        material);
  };
  return {
      {"intact", {}, "", {}, 0, true},
      // Ø1 mm spheres, two pixels across: within a pixel of their centres.
      {"particles", {}, spheres("material = \"absorber\""), {{0, 0}, {10, 0}}, kInspectionPixel_mm},
      {"bubbles", {}, spheres("material = \"dielectric\"\nior = 1.0"), {{0, 0}, {10, 0}}, kInspectionPixel_mm},
      // A 2 mm sphere cut out of the camera-side face 6 mm off axis: its region's centroid inside its outline.
      {"cut",
       {},
       fmt::format("[[object.cut]]\nposition_mm = [6, 0, {:.6f}]\nradius_mm = 2\n", inspectionLensFaceZ(6)),
       {{6, 0}},
       2.0},
      // The whole part off: the index 10 % high, the lens 3 mm down the axis.
      {"index", {{"ior = 1.5168", "ior = 1.66848"}}, "", {}},
      {"moved", {{"material = \"dielectric\"", "material = \"dielectric\"\nposition_mm = [0, 0, -3]"}}, "", {}},
  };
}

// The scene text of `part`: the bench's scene `sceneText` edited.
inline std::string studyPartScene(std::string sceneText, const StudyPart& part) {
  for (const auto& [from, to] : part.edits) {
    const auto at = sceneText.find(from);
    if (at == std::string::npos) throw std::runtime_error("the scene has no '" + from + "' to edit for " + part.name);
    sceneText.replace(at, from.size(), to);
  }
  return sceneText + "\n" + part.extra + "\n";
}

// The centroids (x, y) mm of the regions a finder reported on a part.
using Centroids = std::vector<std::pair<double, double>>;

// What is wrong with `found`, the regions reported on `part`, or "" when it is the whole answer: as many regions
// as the part has placed defects, each defect within `within_mm` of a region and each region within `within_mm`
// of a defect, so a region beside them (a spurious one) or one missing is named. The placed defects are further
// apart than twice `within_mm`, so that pairs them one to one. A part off as a whole (no place) has one region
// or more anywhere; the intact part none.
inline std::string misplacedDefects(const StudyPart& part, const Centroids& found) {
  const auto distance = [](const std::pair<double, double>& a, const std::pair<double, double>& b) {
    return std::hypot(a.first - b.first, a.second - b.second);
  };
  const auto nearest = [&](const std::pair<double, double>& p, const Centroids& among) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& q : among) best = std::min(best, distance(p, q));
    return best;
  };
  if (part.intact) return found.empty() ? "" : fmt::format("{} regions on the intact part", found.size());
  if (part.defects_mm.empty()) return found.empty() ? "no region on a part off as a whole" : "";
  std::string wrong;
  if (found.size() != part.defects_mm.size())
    wrong += fmt::format("{} regions for {} defects; ", found.size(), part.defects_mm.size());
  for (const auto& d : part.defects_mm)
    if (const double r = nearest(d, found); r > part.within_mm)
      wrong += fmt::format("the defect at ({}, {}) mm has no region within {} mm (nearest {:.3f} mm); ", d.first,
                           d.second, part.within_mm, r);
  for (const auto& c : found)
    if (const double r = nearest(c, part.defects_mm); r > part.within_mm)
      wrong += fmt::format("a region at ({:.3f}, {:.3f}) mm is {:.3f} mm from every defect; ", c.first, c.second, r);
  return wrong;
}

}  // namespace lfi::testing_support
