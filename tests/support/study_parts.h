// SPDX-License-Identifier: Apache-2.0
#pragma once
// The study's defect parts on the inspection bench (data/scenes/inspection_bench.toml:
// the N-BK7 lens, R = 51.5 mm, 5 mm thick, Ø25.4, seen in 0.5 mm object pixels), as
// edits of that scene file's text, with where each defect is on the part.

#include <fmt/format.h>

#include <cmath>
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

}  // namespace lfi::testing_support
