#include "lfi/core/config.h"
#include "lfi/core/error.h"
#include "lfi/study/study.h"

#include <cmath>

namespace lfi::study {

Bench Bench::load(const std::filesystem::path& path) {
  ConfigTable root = ConfigTable::parseFile(path);
  root.string("format", std::nullopt, {"lfi-bench"});
  root.integer("version", std::nullopt, 1, 1);
  Bench b;
  {
    ConfigTable t = root.table("lens");
    b.lens.ior = t.number("ior", std::nullopt, 1.0, 4.0);
    b.lens.diameter_mm = t.number("diameter_mm", std::nullopt, 0.1, 1000);
    b.lens.frontRadius_mm = t.number("front_radius_mm", std::nullopt, -1e6, 1e6);
    b.lens.backRadius_mm = t.number("back_radius_mm", std::nullopt, -1e6, 1e6);
    b.lens.centreThickness_mm = t.number("centre_thickness_mm", std::nullopt, 0.01, 1000);
    b.lens.absorption_per_mm = t.number("absorption_per_mm", 0.0, 0, 100);
    const std::pair<const char*, double> radii[] = {{"front_radius_mm", b.lens.frontRadius_mm},
                                                    {"back_radius_mm", b.lens.backRadius_mm}};
    for (const auto& [key, r] : radii)  // as Solid::sphericalLens requires
      if (r != 0 && std::abs(r) < b.lens.diameter_mm / 2)
        fail(Errc::Config, "{}: |radius| {} is smaller than the semi-diameter {} (0 for a flat face)", t.where(key),
             std::abs(r), b.lens.diameter_mm / 2);
    t.finish();
  }
  {
    ConfigTable t = root.table("camera");
    b.camera.pixelPitch_mm = t.number("pixel_pitch_mm", std::nullopt, 1e-4, 1);
    b.camera.width = t.integer("width", std::nullopt, 8, 16384);
    b.camera.height = t.integer("height", std::nullopt, 8, 16384);
    b.camera.magnification = t.number("magnification", std::nullopt, 1e-3, 100);
    b.camera.workingDistance_mm = t.number("working_distance_mm", std::nullopt, 1, 1e4);
    b.camera.objectNa = t.number("object_na", std::nullopt, 1e-5, 0.5);
    b.camera.fullWell_e = t.number("full_well_e", std::nullopt, 100, 1e7);
    b.camera.readNoise_e = t.number("read_noise_e", std::nullopt, 0, 1000);
    b.camera.bitDepth = t.integer("bit_depth", std::nullopt, 8, 16);
    b.camera.exposureFill = t.number("exposure_fill", 0.7, 0.01, 1.0);
    t.finish();
  }
  auto backlight = [&](const char* name, bool parallel) {
    ConfigTable t = root.table(name);
    Backlight l{};
    l.distance_mm = t.number("distance_mm", std::nullopt, 0.01, 1e4);
    l.size_mm = t.number("size_mm", std::nullopt, 0.01, 1e4);
    l.halfAngle_rad = parallel ? t.number("half_angle_rad", std::nullopt, 1e-6, 1.5) : 0;
    t.finish();
    return l;
  };
  b.parallel = backlight("parallel", true);
  b.area = backlight("area", false);
  {
    ConfigTable t = root.table("inverse_schlieren");
    auto& s = b.inverseSchlieren;
    s.distance_mm = t.number("distance_mm", std::nullopt, 0.01, 1e4);
    s.pixelPitch_mm = t.number("pixel_pitch_mm", std::nullopt, 1e-4, 10);
    s.angular = t.integer("angular", std::nullopt, 1, 256);
    s.spatial = t.integer("spatial", std::nullopt, 1, 4096);
    s.lookup = t.string("lookup", "nearest", {"nearest", "interpolated"}) == "nearest" ? LightFieldLookup::Nearest
                                                                                       : LightFieldLookup::Interpolated;
    s.captureHalfAngle_rad = t.number("capture_half_angle_rad", std::nullopt, 1e-6, 1.5);
    s.captureDistance_mm = t.number("capture_distance_mm", std::nullopt, 0.01, 1e4);
    try {
      b.lightFieldGeometry().validate();
    } catch (const Error& e) {
      fail(Errc::Config, "{} (with spatial): {}", t.where("angular"), e.what());
    }
    t.finish();
  }
  {
    ConfigTable t = root.table("defects");
    auto& d = b.defects;
    d.inclusionRadius_mm = t.number("inclusion_radius_mm", std::nullopt, 1e-4, 100);
    d.rimRadial_mm = t.number("rim_radial_mm", std::nullopt, -1e3, 1e3);
    d.cutLargeRadius_mm = t.number("cut_large_radius_mm", std::nullopt, 1e-4, 100);
    d.cutLargeRadial_mm = t.number("cut_large_radial_mm", std::nullopt, -1e3, 1e3);
    d.cutSubpixelRadius_mm = t.number("cut_subpixel_radius_mm", std::nullopt, 1e-5, 100);
    d.cutSubpixelRadial_mm = t.number("cut_subpixel_radial_mm", std::nullopt, -1e3, 1e3);
    d.indexFactor = t.number("index_factor", std::nullopt, 0.5, 2);
    d.misalignment_mm = t.number("misalignment_mm", std::nullopt, -1e3, 1e3);
    t.finish();
  }
  root.finish();
  const double semi = b.lens.diameter_mm / 2;
  if (std::abs(b.defects.rimRadial_mm) + b.defects.inclusionRadius_mm >= semi)
    fail(Errc::Config, "{}: [defects] rim_radial_mm + inclusion_radius_mm must stay inside the lens (semi-diameter {})",
         path.string(), semi);
  return b;
}

sim::TelecentricCamera Bench::telecentricCamera() const {
  // Thin-lens model of the telecentric lens: m = b / wz, 1/f = 1/wz + 1/b, and
  // the stop in the image-side focal plane sets the object-side NA: D = 2 f tan(NA).
  sim::TelecentricCamera c;
  const double wz = camera.workingDistance_mm, b = camera.magnification * wz;
  c.imageDistance_mm = b;
  c.focalLength_mm = 1.0 / (1.0 / wz + 1.0 / b);
  c.stopDiameter_mm = 2 * c.focalLength_mm * std::tan(camera.objectNa);
  c.pixelPitch_mm = camera.pixelPitch_mm;
  c.width = camera.width;
  c.height = camera.height;
  c.worldFromCamera = sim::TelecentricCamera::lookingDownFrom(wz);  // focused on z = 0
  return c;
}

sim::CameraSensorModel Bench::sensorModel() const {
  sim::CameraSensorModel m;
  m.fullWell_e = camera.fullWell_e;
  m.readNoise_e = camera.readNoise_e;
  m.bitDepth = camera.bitDepth;
  return m;
}

LightFieldGeometry Bench::lightFieldGeometry() const {
  LightFieldGeometry g;
  g.spatialX = g.spatialY = inverseSchlieren.spatial;
  g.angular = inverseSchlieren.angular;
  g.pixelPitch_mm = inverseSchlieren.pixelPitch_mm;
  g.distance_mm = inverseSchlieren.distance_mm;
  return g;
}

}  // namespace lfi::study
