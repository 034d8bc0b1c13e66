// SPDX-License-Identifier: Apache-2.0
// The part model of a scene file against the thick-lens formulas: the study's
// N-BK7 lens (R = ±51.5 mm, 5 mm thick, n = 1.5168) bends a ray 1 mm off the
// axis towards its back focal point; a ray on the axis goes straight through;
// a ray beside the lens, or a scene without a part, is no exit.

#include "lfi/sim/scene_part_model.h"
#include "lfi/core/error.h"

#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace lfi;
using lfi::testing_support::cameraSceneText;
using lfi::testing_support::lensObject;
using lfi::testing_support::TestFolder;
using lfi::testing_support::throwsError;

constexpr double kRadius = 51.5, kThickness = 5, kIor = 1.5168;

TEST(ScenePartModel, BendsARayAsTheThickLensFormulasSay) {
  const TestFolder dir("scene_part_model");
  const sim::ScenePartModel model(dir.write(
      "lens.toml",
      cameraSceneText({}) + "[display]\nposition_mm = [0, 0, -30]\n" +
          lensObject({.radius_mm = kRadius, .centreThickness_mm = kThickness, .diameter_mm = 25.4, .ior = kIor})));
  const auto axis = model.exit({0, 0});
  ASSERT_TRUE(axis);
  EXPECT_NEAR(axis->direction.x, 0, 1e-12);
  EXPECT_NEAR(axis->direction.z, -1, 1e-12);
  EXPECT_LE(axis->point.z, -0.5 * kThickness + 1e-9);  // below the lens

  // Paraxially, a ray at height h leaves the back face at h (1 − d (n − 1) / (n R)) towards the back focal
  // point: its slope is h / f, 1 / f = (n − 1) (2 / R − (n − 1) d / (n R²)). At h = 1 mm the third-order terms
  // are (h / f)² ≈ 4e-4 of these.
  const double h = 1;
  const double power = (kIor - 1) * (2 / kRadius - (kIor - 1) * kThickness / (kIor * kRadius * kRadius));
  const auto ray = model.exit({h, 0});
  ASSERT_TRUE(ray);
  const double slope = ray->direction.x / ray->direction.z;  // per mm downwards: towards the axis is +
  EXPECT_NEAR(slope, h * power, 1e-3 * h * power);
  const Vec3 atBackFace = ray->point + ((-0.5 * kThickness - ray->point.z) / ray->direction.z) * ray->direction;
  EXPECT_NEAR(atBackFace.x, h * (1 - kThickness * (kIor - 1) / (kIor * kRadius)), 2e-3);
  EXPECT_NEAR(ray->direction.y, 0, 1e-12);

  EXPECT_FALSE(model.exit({20, 0}));  // beside the lens (Ø25.4)
  EXPECT_NE(model.description().find("lens"), std::string::npos);
}

// Inside the part: the downward ray at x refracts at the front face (its normal
// at asin(x / R) from the axis; Snell's law), then runs straight to the depth
// asked for. Above the part it has not bent; past a totally absorbing object
// or beside the part it is where it was.
TEST(ScenePartModel, PlacesARayInsideThePartBySnellsLaw) {
  const TestFolder dir("scene_part_model_depth");
  const sim::ScenePartModel model(dir.write(
      "lens.toml",
      cameraSceneText({}) + "[display]\nposition_mm = [0, 0, -30]\n" +
          lensObject({.radius_mm = kRadius, .centreThickness_mm = kThickness, .diameter_mm = 25.4, .ior = kIor})));
  for (const double x : {1.0, 6.4, 10.0}) {
    SCOPED_TRACE(x);
    const double theta = std::asin(x / kRadius), refracted = std::asin(std::sin(theta) / kIor);
    const double face = kThickness / 2 - (kRadius - std::sqrt(kRadius * kRadius - x * x));  // the front face's z
    for (const double z : {0.0, -1.0}) {
      const auto inside = model.atDepth({x, 0}, z);
      ASSERT_TRUE(inside);
      // The refracted ray leans towards the axis by theta - refracted from the vertical.
      EXPECT_NEAR(inside->x, x - (face - z) * std::tan(theta - refracted), 1e-9);
      EXPECT_NEAR(inside->y, 0, 1e-12);
    }
  }
  // At 6.4 mm from the axis and the lens's centre plane: 0.09 mm nearer the axis than seen (1.4 %).
  EXPECT_NEAR(model.atDepth({6.4, 0}, 0)->x, 6.4 * (1 - 0.014), 0.001);
  EXPECT_EQ(model.atDepth({6.4, 3}, 10)->x, 6.4) << "above the part: not bent";
  EXPECT_EQ(model.atDepth({20, 0}, 0)->x, 20) << "beside the part: not bent";
}

TEST(ScenePartModel, ASceneWithoutAPartIsNamed) {
  const TestFolder dir("scene_part_model_empty");
  const auto file = dir.write("empty.toml", cameraSceneText({}) + "[display]\nposition_mm = [0, 0, -30]\n");
  EXPECT_TRUE(throwsError([&] { sim::ScenePartModel{file}; }, Errc::Config, {"empty.toml", "no part"}));
}

}  // namespace
