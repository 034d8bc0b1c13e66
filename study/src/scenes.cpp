// SPDX-License-Identifier: Apache-2.0
// The study's scenes and illuminations, built from the bench: the intact lens
// and its six defect scenes, the back lights, the light field the inverse
// schlieren display shows (captured through the intact lens), and the
// bench's display that shows it through its optics.

#include "study_internal.h"

#include "lfi/drivers/display_optics.h"
#include "lfi/sim/render.h"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <tuple>

namespace lfi::study::detail {

using sim::Object;
using sim::Solid;

std::vector<SceneSpec> sceneSpecs(const Bench& bench) {
  const auto& d = bench.defects;
  const auto lensSolid = Solid::sphericalLens(bench.lens.frontRadius_mm, bench.lens.backRadius_mm,
                                              bench.lens.centreThickness_mm, bench.lens.diameter_mm);
  std::vector<SceneSpec> specs;
  specs.push_back({.name = "intact"});
  for (bool bubbles : {false, true}) {
    SceneSpec s{.name = bubbles ? "scattering" : "absorbing", .bubbles = bubbles};
    const Vec3 centre(0, 0, 0), rim(d.rimRadial_mm, 0, 0);
    s.inclusions = {{centre, d.inclusionRadius_mm}, {rim, d.inclusionRadius_mm}};
    s.defects = {{"center", Solid::sphere(d.inclusionRadius_mm, Rigid3::translation(centre))},
                 {"rim", Solid::sphere(d.inclusionRadius_mm, Rigid3::translation(rim))}};
    specs.push_back(s);
  }
  for (auto [name, radius, radial] : {std::tuple{"cut_large", d.cutLargeRadius_mm, d.cutLargeRadial_mm},
                                      std::tuple{"cut_subpixel", d.cutSubpixelRadius_mm, d.cutSubpixelRadial_mm}}) {
    // Centred on the camera-side (back) surface.
    const Vec3 c(radial, 0,
                 sim::sphericalFaceZ(bench.lens.backRadius_mm, bench.lens.centreThickness_mm / 2, std::abs(radial)));
    SceneSpec s{.name = name};
    s.cuts = {{c, radius}};
    s.defects = {{"cut", Solid::sphere(radius, Rigid3::translation(c))}};
    specs.push_back(s);
  }
  specs.push_back({.name = "index", .iorFactor = d.indexFactor, .defects = {{"lens", lensSolid}}});
  // Both positions of the lens: where it should be and where it is.
  const auto moved =
      Solid::combine(Solid::Kind::Union, lensSolid, lensSolid, Rigid3::translation({0, 0, -d.misalignment_mm}));
  specs.push_back({.name = "misaligned",
                   .lensShift_mm = -d.misalignment_mm,
                   .defects = {{"lens", Solid::combine(Solid::Kind::Union, lensSolid, moved)}}});
  return specs;
}

std::vector<Object> partObjects(const Bench& bench, const SceneSpec& spec) {
  std::shared_ptr<const Solid> lens = Solid::sphericalLens(bench.lens.frontRadius_mm, bench.lens.backRadius_mm,
                                                           bench.lens.centreThickness_mm, bench.lens.diameter_mm);
  for (const auto& [centre, radius] : spec.cuts)
    lens = Solid::combine(Solid::Kind::Difference, lens, Solid::sphere(radius, Rigid3::translation(centre)));
  std::vector<Object> objects;
  objects.push_back({"lens", lens, Rigid3::translation({0, 0, spec.lensShift_mm}),
                     sim::Dielectric{bench.lens.ior * spec.iorFactor, bench.lens.absorption_per_mm}, std::nullopt});
  int k = 0;
  for (const auto& [centre, radius] : spec.inclusions) {
    sim::Material m = spec.bubbles ? sim::Material(sim::Dielectric{1.0, 0}) : sim::Material(sim::Absorber{});
    objects.push_back(
        {fmt::format("inclusion{}", k++), Solid::sphere(radius), Rigid3::translation(centre), m, std::nullopt});
  }
  return objects;
}

Object backlight(const Bench& bench, const Illumination& light) {
  if (light.setup == "parallel" || light.setup == "schlieren")
    return {"parallel backlight", sim::Rectangle{bench.parallel.size_mm, bench.parallel.size_mm},
            Rigid3::translation({0, 0, -bench.parallel.distance_mm}), sim::Absorber{},
            sim::ParallelEmission{1.0, bench.parallel.halfAngle_rad}};
  if (light.setup == "area")
    return {"area backlight", sim::Rectangle{bench.area.size_mm, bench.area.size_mm},
            Rigid3::translation({0, 0, -bench.area.distance_mm}), sim::Absorber{}, sim::LambertianEmission{1.0}};
  const LightFieldGeometry& g = light.lightField->geometry();
  const Rigid3 at = Rigid3::translation({0, 0, -g.distance_mm - light.displayError_mm});
  if (light.setup == "display")
    return {"light field display (panel and optics)", sim::Rectangle{g.extentX_mm(), g.extentY_mm()}, at,
            sim::Absorber{}, *light.panel};
  return {"light field display", sim::Rectangle{g.extentX_mm(), g.extentY_mm()}, at, sim::Absorber{},
          sim::LightFieldEmission{light.lightField, light.lookup}};
}

std::shared_ptr<const sim::PanelEmission> displayPanel(const Bench& bench, const DisplayOpticsParams& optics,
                                                       const LightField& shown) {
  const DisplayInfo info = bench.displayInfo(optics);
  const cv::Mat panel = encodeLightField(shown, DisplayOptics(info), 1.0, bench.inverseSchlieren.lookup);
  return std::make_shared<const sim::PanelEmission>(
      sim::makePanelEmission(std::make_shared<const sim::PanelOptics>(info), panel, 1.0));
}

// The first step of inverse schlieren (docs/study.md): the collimated beam
// from the camera side through the intact lens, recorded by the lensless
// light field sensor at Δ below the lens.
LightField captureLightField(const Bench& bench, const LightFieldGeometry& geometry, int samples, std::uint64_t seed,
                             int threads, const std::function<void(double)>& progress) {
  std::vector<Object> objects = partObjects(bench, SceneSpec{.name = "intact"});
  const double size = 2 * std::max(geometry.extentX_mm(), bench.lens.diameter_mm);
  Rigid3 facingDown = Rigid3::rotation({1, 0, 0}, std::numbers::pi);
  facingDown.t = {0, 0, bench.inverseSchlieren.captureDistance_mm};
  objects.push_back({"collimated capture beam", sim::Rectangle{size, size}, facingDown, sim::Absorber{},
                     sim::ParallelEmission{1.0, bench.inverseSchlieren.captureHalfAngle_rad}});
  sim::Scene scene(std::move(objects));
  sim::LightFieldSensor sensor{geometry, Rigid3::translation({0, 0, -geometry.distance_mm})};
  sim::RenderOptions ro;
  ro.samplesPerPixel = samples;
  ro.seed = seed ^ 0x4c46ull;
  ro.threads = threads;
  ro.progress = progress;
  return LightField(sensor.geometry, sim::render(scene, sensor, ro));
}

}  // namespace lfi::study::detail
