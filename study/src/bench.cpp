// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/config.h"
#include "lfi/core/error.h"
#include "lfi/drivers/display_calibration_file.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/sim/scene_file.h"
#include "lfi/sim/solid.h"
#include "lfi/study/study.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace lfi::study {

namespace {

// Every value is in range by itself; these are the combinations that would
// put one part inside another, or a defect outside the lens: the study would
// run and answer for a bench that cannot exist.
void checkGeometry(const Bench& b, const ConfigTable& cameraTable, const ConfigTable& parallelTable,
                   const ConfigTable& areaTable, const ConfigTable& schlierenTable, const ConfigTable& defectsTable) {
  const Bench::Lens& lens = b.lens;
  const Bench::Defects& defects = b.defects;
  const Bench::Span span = b.lensSpan(true), intact = b.lensSpan(false);
  const std::string spanned =
      fmt::format("the lens (from z = {:.4g} to {:.4g} mm, both of its positions with [defects] misalignment_mm = {})",
                  span.low, span.high, defects.misalignment_mm);
  if (b.camera.workingDistance_mm <= span.high)
    fail(Errc::Config, "{} = {}: the camera's lens plane would be inside or below {}",
         cameraTable.where("working_distance_mm"), b.camera.workingDistance_mm, spanned);
  // The capture sees the intact lens at the origin only.
  if (b.inverseSchlieren.captureDistance_mm <= intact.high)
    fail(Errc::Config, "{} = {}: the capture beam's emitter would be inside or below the lens (up to z = {:.4g} mm)",
         schlierenTable.where("capture_distance_mm"), b.inverseSchlieren.captureDistance_mm, intact.high);
  const std::pair<const ConfigTable*, double> below[] = {{&parallelTable, b.parallel.distance_mm},
                                                         {&areaTable, b.area.distance_mm},
                                                         {&schlierenTable, b.inverseSchlieren.distance_mm}};
  for (const auto& [table, distance] : below)
    if (-distance >= span.low)
      fail(Errc::Config, "{} = {}: the plane at z = {} would be inside or above {}", table->where("distance_mm"),
           distance, -distance, spanned);
  const double semi = lens.diameter_mm / 2;
  const std::pair<const char*, double> cuts[] = {{"cut_large_radial_mm", defects.cutLargeRadial_mm},
                                                 {"cut_subpixel_radial_mm", defects.cutSubpixelRadial_mm}};
  for (const auto& [key, radial] : cuts)
    if (std::abs(radial) >= semi)
      fail(Errc::Config, "{} = {}: the cut's centre would be outside the lens (semi-diameter {})",
           defectsTable.where(key), radial, semi);
  // A cut (centred on the back surface, as the study makes it) that holds the
  // lens's whole box would leave no lens.
  const sim::Bounds box =
      sim::Solid::sphericalLens(lens.frontRadius_mm, lens.backRadius_mm, lens.centreThickness_mm, lens.diameter_mm)
          ->bounds();
  const std::tuple<const char*, double, double> cutBalls[] = {
      {"cut_large_radius_mm", defects.cutLargeRadius_mm, defects.cutLargeRadial_mm},
      {"cut_subpixel_radius_mm", defects.cutSubpixelRadius_mm, defects.cutSubpixelRadial_mm}};
  for (const auto& [key, radius, radial] : cutBalls) {
    const double z = sim::sphericalFaceZ(lens.backRadius_mm, lens.centreThickness_mm / 2, std::abs(radial));
    const Vec3 centre(radial, 0, z);
    if (box.ball(centre, radius) == sim::Bounds::Ball::HoldsAll)
      fail(Errc::Config, "{} = {}: the cut would hold the whole lens ({}): nothing would be left",
           defectsTable.where(key), radius, box.text());
  }
  // The index defect's glass: no lower than air, no higher than a scene file takes.
  if (const double n = lens.ior * defects.indexFactor; !(n >= 1 && n <= 5))
    fail(Errc::Config, "{} = {}: the defect's index would be {} x {} = {:g}, outside [1, 5]",
         defectsTable.where("index_factor"), defects.indexFactor, lens.ior, defects.indexFactor, n);
  // The rim inclusion apart from the centre one: overlapping, the study would report one spot twice.
  if (std::abs(defects.rimRadial_mm) < 2 * defects.inclusionRadius_mm)
    fail(Errc::Config, "{} = {}: the rim inclusion would overlap the one on the axis (radius {} mm each)",
         defectsTable.where("rim_radial_mm"), defects.rimRadial_mm, defects.inclusionRadius_mm);
  // The inclusions, spheres at z = 0, must lie wholly inside the glass.
  for (const double radial : {0.0, defects.rimRadial_mm})
    if (!sim::sphericalLensHolds(lens.frontRadius_mm, lens.backRadius_mm, lens.centreThickness_mm, lens.diameter_mm,
                                 {radial, 0, 0}, defects.inclusionRadius_mm))
      fail(Errc::Config,
           "{}: the inclusion of radius {} mm, {} mm from the axis, would not lie inside the lens "
           "(diameter {}, centre thickness {})",
           defectsTable.where(radial != 0 ? "rim_radial_mm" : "inclusion_radius_mm"), defects.inclusionRadius_mm,
           radial, lens.diameter_mm, lens.centreThickness_mm);
}

}  // namespace

Bench Bench::load(const std::filesystem::path& path) {
  return load(path, {});
}

Bench Bench::load(const std::filesystem::path& path, const std::vector<ConfigTable::Override>& overrides) {
  ConfigTable root = overrides.empty() ? ConfigTable::parseFile(path) : ConfigTable::parseFile(path, overrides);
  root.requireKnownKeys({"format", "version", "lens", "camera", "parallel", "area", "schlieren", "inverse_schlieren",
                         "display", "defects"});
  root.string("format", std::nullopt, {"lfi-bench"});
  root.integer("version", std::nullopt, 1, 1);
  Bench b;
  b.source = path.string();
  // Kept to name their keys in the checks across tables at the end.
  ConfigTable lensTable = root.table("lens"), cameraTable = root.table("camera");
  ConfigTable parallelTable = root.table("parallel"), areaTable = root.table("area");
  ConfigTable schlierenTable = root.table("inverse_schlieren"), defectsTable = root.table("defects");
  {
    ConfigTable& t = lensTable;
    b.lens.ior = t.number("ior", std::nullopt, 1.0, 4.0);
    b.lens.diameter_mm = t.number("diameter_mm", std::nullopt, 0.1, 1000);
    b.lens.frontRadius_mm = t.number("front_radius_mm", std::nullopt, -1e6, 1e6);
    b.lens.backRadius_mm = t.number("back_radius_mm", std::nullopt, -1e6, 1e6);
    b.lens.centreThickness_mm = t.number("centre_thickness_mm", std::nullopt, 0.01, 1000);
    b.lens.absorption_per_mm = t.number("absorption_per_mm", 0.0, 0, 100);
    if (const auto fault = sim::sphericalLensFault(b.lens.frontRadius_mm, b.lens.backRadius_mm,
                                                   b.lens.centreThickness_mm, b.lens.diameter_mm))
      fail(Errc::Config, "{}: {}", t.where(sim::lensKey(fault->part)), fault->why);
    t.finish();
  }
  {
    ConfigTable& t = cameraTable;
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
  auto backlight = [&](ConfigTable& t, bool collimated) {
    Backlight l{};
    l.distance_mm = t.number("distance_mm", std::nullopt, 0.01, 1e4);
    l.size_mm = t.number("size_mm", std::nullopt, 0.01, 1e4);
    l.halfAngle_rad = collimated ? t.number("half_angle_rad", std::nullopt, 1e-6, 1.5) : 0;
    t.finish();
    return l;
  };
  b.parallel = backlight(parallelTable, true);
  b.area = backlight(areaTable, false);
  {
    ConfigTable t = root.table("schlieren");
    b.schlieren.knifeEdge = t.number("knife_edge", std::nullopt, -1, 1);
    t.finish();
  }
  {
    ConfigTable& t = schlierenTable;
    auto& s = b.inverseSchlieren;
    s.distance_mm = t.number("distance_mm", std::nullopt, 0.01, 1e4);
    s.pixelPitch_mm = t.number("pixel_pitch_mm", std::nullopt, 1e-4, 10);
    s.angular = t.integer("angular", std::nullopt, 1, 256);
    s.spatial = t.integer("spatial", std::nullopt, 1, 4096);
    s.lookup = t.string("lookup", "nearest", {"nearest", "interpolated"}) == "nearest" ? LightFieldLookup::Nearest
                                                                                       : LightFieldLookup::Interpolated;
    s.captureHalfAngle_rad = t.number("capture_half_angle_rad", std::nullopt, 1e-6, 1.5);
    s.captureDistance_mm = t.number("capture_distance_mm", std::nullopt, 0.01, 1e4);
    s.drive = t.string("drive", "captured", {"captured", "binary"}) == "binary"
                  ? Bench::InverseSchlieren::Drive::Binary
                  : Bench::InverseSchlieren::Drive::Captured;
    s.binaryThreshold = 0;
    if (s.drive == Bench::InverseSchlieren::Drive::Binary)
      s.binaryThreshold = t.number("binary_threshold", std::nullopt, 1e-9, 1);
    else if (t.has("binary_threshold"))
      fail(Errc::Config, "{}: a threshold for the binary drive, but drive = \"captured\"", t.where("binary_threshold"));
    try {
      b.lightFieldGeometry().validate();
    } catch (const Error& e) {
      fail(Errc::Config, "{} (with spatial): {}", t.where("angular"), e.what());
    }
    t.finish();
  }
  {
    ConfigTable t = root.table("display");
    b.display.optics = readDisplayOpticsTable(t, DisplayOpticsParams{});
    t.finish();
    try {
      DisplayOptics(b.displayInfo(b.display.optics));
    } catch (const Error& e) {
      fail(Errc::Config, "{} (over the panel of [inverse_schlieren]): {}", t.where("optics"), e.what());
    }
  }
  {
    ConfigTable& t = defectsTable;
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
  checkGeometry(b, cameraTable, parallelTable, areaTable, schlierenTable, defectsTable);
  return b;
}

Bench::Span Bench::lensSpan(bool misaligned) const {
  const double semi = lens.diameter_mm / 2, t = lens.centreThickness_mm;
  const double front = std::min(sim::sphericalFaceZ(lens.frontRadius_mm, -t / 2, 0),
                                sim::sphericalFaceZ(lens.frontRadius_mm, -t / 2, semi));
  const double back =
      std::max(sim::sphericalFaceZ(lens.backRadius_mm, t / 2, 0), sim::sphericalFaceZ(lens.backRadius_mm, t / 2, semi));
  const double shift = misaligned ? -defects.misalignment_mm : 0.0;  // the misaligned scene's lens
  return {front + std::min(0.0, shift), back + std::max(0.0, shift)};
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

DisplayInfo Bench::displayInfo(const DisplayOpticsParams& optics) const {
  DisplayInfo info;
  info.vendor = "lfi";
  info.model = "study bench display";
  info.panelWidth_px = info.panelHeight_px = inverseSchlieren.spatial * inverseSchlieren.angular;
  info.pixelPitch_mm = inverseSchlieren.pixelPitch_mm;
  info.subpixels = SubpixelLayout::Mono;
  info.optics = optics;
  // Panel pixels under a lens (pinhole, slit): the directions it can give.
  const double across = fullParallax(optics.type) ? optics.arrayPitch_mm / info.pixelPitch_mm : optics.lensPitch_px;
  info.viewCount = std::max(1, static_cast<int>(std::lround(fullParallax(optics.type) ? across * across : across)));
  info.brightnessMax = 255;
  return info;
}

LightField Bench::displayed(const LightField& captured) const {
  if (inverseSchlieren.drive == InverseSchlieren::Drive::Captured) return captured;
  return binaryDrive(captured, inverseSchlieren.binaryThreshold);
}

}  // namespace lfi::study
