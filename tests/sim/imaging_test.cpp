// Whole-bench imaging checks: the telecentric camera's depth of field against
// thin-lens geometry, and the inverse schlieren round trip (capture a light
// field through the intact lens, emit it, image it).

#include "lfi/sim/render.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace {

using namespace lfi;
using namespace lfi::sim;

// Edge spread function of a uniform disc of radius rho blurring a step at
// x = 0 (bright for x > 0): the fraction of the disc on the bright side.
double discEdgeSpread(double x, double rho) {
  if (x <= -rho) return 0;
  if (x >= rho) return 1;
  return 0.5 + (x * std::sqrt(rho * rho - x * x) + rho * rho * std::asin(x / rho)) / (std::numbers::pi * rho * rho);
}

TEST(Imaging, DefocusedEdgeBlursByTheStopCone) {
  // Camera: f = 100, b = 200 (focus at wz = 200, m = 1), stop D = 2 mm, so every
  // object-side ray is within tan θ = (D/2)/f · ρ' of the chief ray; the rays of
  // one pixel meet at the focal plane and at a distance δ from it fill a disc of
  // radius ρ = δ (D/2) / f, uniformly (o is affine in the stop sample).
  // An opaque half plane δ = 40 mm behind the focal plane, over a Lambertian back
  // light, therefore images as the step convolved with that disc: ρ = 0.4 mm.
  TelecentricCamera cam;
  cam.focalLength_mm = 100;
  cam.imageDistance_mm = 200;
  cam.stopDiameter_mm = 2;
  cam.pixelPitch_mm = 0.02;  // object pixel 0.02 mm: ρ spans 20 pixels
  cam.width = 80;
  cam.height = 4;
  cam.worldFromCamera = TelecentricCamera::lookingDownFrom(200);
  const double delta = 40, rho = delta * (cam.stopDiameter_mm / 2) / cam.focalLength_mm;
  std::vector<Object> objects;
  objects.push_back({"edge", Rectangle{100, 100}, Rigid3::translation({-50, 0, -delta}), Absorber{}, std::nullopt});
  objects.push_back(
      {"light", Rectangle{400, 400}, Rigid3::translation({0, 0, -100}), Absorber{}, LambertianEmission{1}});
  const Scene scene(std::move(objects));
  RenderOptions options;
  options.samplesPerPixel = 1024;
  const cv::Mat image = render(scene, cam, options);
  double worst = 0;
  for (int i = 0; i < cam.width; ++i) {
    // Pixel i covers object x in [(i - W/2) p, (i + 1 - W/2) p]; average the ESF over it.
    double expected = 0;
    for (int k = 0; k < 16; ++k)
      expected += discEdgeSpread((i + (k + 0.5) / 16 - cam.width / 2.0) * cam.pixelPitch_mm, rho);
    expected /= 16;
    double measured = 0;
    for (int j = 0; j < cam.height; ++j) measured += image.at<float>(j, i) / cam.height;
    worst = std::max(worst, std::abs(measured - expected));
  }
  // 4 x 1024 samples per column: Monte Carlo error below ~0.01.
  EXPECT_LT(worst, 0.03);
  // In focus, the same edge is sharp: one transition pixel.
  std::vector<Object> focused;
  focused.push_back({"edge", Rectangle{100, 100}, Rigid3::translation({-50, 0, 0}), Absorber{}, std::nullopt});
  focused.push_back(
      {"light", Rectangle{400, 400}, Rigid3::translation({0, 0, -100}), Absorber{}, LambertianEmission{1}});
  const cv::Mat sharp = render(Scene(std::move(focused)), cam, options);
  EXPECT_LT(sharp.at<float>(0, cam.width / 2 - 2), 1e-6);
  EXPECT_GT(sharp.at<float>(0, cam.width / 2 + 1), 1 - 1e-6);
}

struct RoundTrip {
  double fractionLit;   // inner-lens pixels brighter than a quarter of the brightest
  double cv;            // coefficient of variation over the inner lens
};

// The method on a small bench: capture the light field of a collimated beam
// through the intact lens at Δ, emit it from Δ, image with the telecentric camera.
RoundTrip roundTrip(LightFieldLookup lookup, bool parallelInstead, cv::Mat* imageOut = nullptr) {
  const auto lens = Solid::sphericalLens(51.5, -51.5, 5, 25.4);
  const double delta = 30, captureTheta = 0.0087;
  LightFieldGeometry g;
  // Rays that leave the inner 10 mm of the lens parallel to the axis cross the
  // display plane within |x| < 10 (1 - Δ/f) = 4 mm: 16 elements of 0.8 mm cover it.
  g.spatialX = g.spatialY = 16;
  g.angular = 16;
  g.pixelPitch_mm = 0.05;
  g.distance_mm = delta;
  auto lightField = std::make_shared<LightField>(g);
  if (!parallelInstead) {
    std::vector<Object> objects;
    objects.push_back({"lens", lens, {}, Dielectric{1.5168, 0}, std::nullopt});
    Rigid3 down = Rigid3::rotation({1, 0, 0}, std::numbers::pi);
    down.t = {0, 0, 50};
    objects.push_back({"beam", Rectangle{100, 100}, down, Absorber{}, ParallelEmission{1, captureTheta}});
    RenderOptions ro;
    ro.samplesPerPixel = 64;
    *lightField =
        LightField(g, render(Scene(std::move(objects)), LightFieldSensor{g, Rigid3::translation({0, 0, -delta})}, ro));
  }
  std::vector<Object> objects;
  objects.push_back({"lens", lens, {}, Dielectric{1.5168, 0}, std::nullopt});
  if (parallelInstead)
    objects.push_back({"collimated", Rectangle{100, 100}, Rigid3::translation({0, 0, -delta}), Absorber{},
                       ParallelEmission{1, captureTheta}});
  else
    objects.push_back({"display", Rectangle{g.extentX_mm(), g.extentY_mm()}, Rigid3::translation({0, 0, -delta}),
                       Absorber{}, LightFieldEmission{lightField, lookup}});
  TelecentricCamera cam;  // 0.243x telecentric lens class, object NA 0.0152, 0.5 mm object pixels
  cam.imageDistance_mm = 0.243 * 102.5;
  cam.focalLength_mm = 1 / (1 / 102.5 + 1 / cam.imageDistance_mm);
  cam.stopDiameter_mm = 2 * cam.focalLength_mm * std::tan(0.0152);
  cam.pixelPitch_mm = 0.5 * 0.243;
  cam.width = cam.height = 60;
  cam.worldFromCamera = TelecentricCamera::lookingDownFrom(102.5);
  RenderOptions ro;
  ro.samplesPerPixel = 64;
  const cv::Mat image = render(Scene(std::move(objects)), cam, ro);
  if (imageOut) *imageOut = image;
  std::vector<float> inner;
  for (int j = 0; j < cam.height; ++j)
    for (int i = 0; i < cam.width; ++i) {
      const double x = (i + 0.5 - cam.width / 2.0) * 0.5, y = (j + 0.5 - cam.height / 2.0) * 0.5;
      if (x * x + y * y < 10.0 * 10.0) inner.push_back(image.at<float>(j, i));
    }
  double maxValue = *std::max_element(inner.begin(), inner.end());
  double mean = 0, var = 0, lit = 0;
  for (float v : inner) mean += v / inner.size();
  for (float v : inner) {
    var += (v - mean) * (v - mean) / inner.size();
    lit += v > 0.25 * maxValue ? 1 : 0;
  }
  return {lit / inner.size(), std::sqrt(var) / mean};
}

TEST(Imaging, InverseSchlierenLightsTheWholeIntactLens) {
  // Under collimated light only rays the lens barely deflects reach the camera:
  // a disc of radius about f (θe + θc) = 50 mm x 0.024 = 1.2 mm of the inner
  // 10 mm radius, i.e. ~1.5 % of its area. The emitted light field undoes the
  // lens's deflection everywhere, so the whole lens must appear lit.
  const RoundTrip parallel = roundTrip(LightFieldLookup::Nearest, true);
  const RoundTrip nearest = roundTrip(LightFieldLookup::Nearest, false);
  const RoundTrip interpolated = roundTrip(LightFieldLookup::Interpolated, false);
  RecordProperty("parallel_fraction_lit", std::to_string(parallel.fractionLit));
  RecordProperty("nearest_fraction_lit", std::to_string(nearest.fractionLit));
  RecordProperty("nearest_cv", std::to_string(nearest.cv));
  RecordProperty("interpolated_fraction_lit", std::to_string(interpolated.fractionLit));
  RecordProperty("interpolated_cv", std::to_string(interpolated.cv));
  std::printf(
      "lit fraction of the inner lens: parallel %.3f, light field nearest %.3f (cv %.3f), interpolated %.3f (cv "
      "%.3f)\n",
      parallel.fractionLit, nearest.fractionLit, nearest.cv, interpolated.fractionLit, interpolated.cv);
  // Reached (issue 3 asks to state it): nearest 80 % of the inner lens lit,
  // cv 0.43; interpolated 93 %, cv 0.36, against 0.9 % under the collimated
  // beam. The bounds keep that, with a margin for the sampling: a round trip
  // that lit only part of the lens (a wrong sign or scale of the emitted
  // directions, a shifted light field) falls well below them.
  EXPECT_LT(parallel.fractionLit, 0.05);
  EXPECT_GT(nearest.fractionLit, 0.75);
  EXPECT_GT(interpolated.fractionLit, 0.9);
  EXPECT_LT(nearest.cv, 0.5);
  EXPECT_LT(interpolated.cv, 0.42);
  EXPECT_LT(interpolated.cv, nearest.cv);  // interpolation smooths the element steps
}

}  // namespace
