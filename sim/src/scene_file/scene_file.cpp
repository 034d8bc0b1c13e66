// SPDX-License-Identifier: Apache-2.0
// The scene file reader (loadSceneFile): the file's tables (render settings,
// the camera or light field sensor, [camera_sensor], the objects, [display]) into
// a scene, with the check that no sensor's rays start inside a solid.

#include "lfi/sim/scene_file.h"

#include "lfi/core/config.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/drivers/display_calibration_file.h"
#include "lfi/drivers/display_optics.h"

#include "scene_file_internal.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

namespace lfi::sim {

namespace fs = std::filesystem;

Rigid3 placement(const std::vector<double>& p, const std::vector<double>& r) {
  const double deg = std::numbers::pi / 180;
  Rigid3 x = Rigid3::rotation({0, 0, 1}, r[2] * deg) * Rigid3::rotation({0, 1, 0}, r[1] * deg) *
             Rigid3::rotation({1, 0, 0}, r[0] * deg);
  x.t = {p[0], p[1], p[2]};
  return x;
}

namespace detail {

Rigid3 readPlacement(ConfigTable& t) {
  return placement(t.numbers("position_mm", 3, std::vector<double>{0, 0, 0}, -kFarthest_mm, kFarthest_mm),
                   t.numbers("rotation_deg", 3, std::vector<double>{0, 0, 0}, -360, 360));
}

}  // namespace detail

namespace {

DisplayParameters readDisplay(ConfigTable& t) {
  // The class's default display (display_optics.h) gives what the table leaves out.
  const DisplayInfo defaults = defaultDisplay(readOpticsClass(t, OpticsType::LensletArray));
  DisplayParameters d;
  DisplayInfo& info = d.info;
  info.vendor = "lfi";
  info.model = "SimDisplay";
  d.worldFromDisplay = detail::readPlacement(t);
  info.panelWidth_px = t.integer("panel_width_px", defaults.panelWidth_px, 1, 16384);
  info.panelHeight_px = t.integer("panel_height_px", defaults.panelHeight_px, 1, 16384);
  info.pixelPitch_mm = t.number("pixel_pitch_mm", defaults.pixelPitch_mm, 1e-4, 10);
  const std::string sub = t.string("subpixels", "rgb", {"mono", "rgb", "bgr"});
  info.subpixels = sub == "mono"  ? SubpixelLayout::Mono
                   : sub == "rgb" ? SubpixelLayout::RgbStripe
                                  : SubpixelLayout::BgrStripe;
  info.optics = readDisplayOpticsTable(t, defaults.optics);
  info.viewCount = t.integer("view_count", defaults.viewCount, 1, 1 << 20);
  info.brightnessMin = t.integer("brightness_min", defaults.brightnessMin, 0, 1 << 20);
  info.brightnessMax = t.integer("brightness_max", defaults.brightnessMax, 0, 1 << 20);
  if (info.brightnessMax < info.brightnessMin)
    fail(Errc::Config, "{}: brightness_max = {} is below brightness_min = {}",
         t.where(t.has("brightness_max") ? "brightness_max" : "brightness_min"), info.brightnessMax,
         info.brightnessMin);
  d.brightness = t.number("brightness", 1.0, 0, 1e12);
  if (t.has("response_gamma") && t.has("response_table"))
    fail(Errc::Config, "{}: give response_gamma or response_table, not both", t.where("response_table"));
  d.light.gamma = t.number("response_gamma", 1.0, 0.1, 10);
  d.light.table = t.numbers("response_table", 2, 4096, std::vector<double>{}, 0, 1);
  for (std::size_t i = 1; i < d.light.table.size(); ++i)
    if (d.light.table[i] < d.light.table[i - 1])
      fail(Errc::Config,
           "{}: element {} ({}) is below element {} ({}): a panel's light does not fall as its drive rises",
           t.where("response_table"), i, d.light.table[i], i - 1, d.light.table[i - 1]);
  if (!d.light.table.empty() && d.light.table.back() != 1)
    fail(Errc::Config, "{}: the last element is {}, not 1 (brightness is the radiance at full drive)",
         t.where("response_table"), d.light.table.back());
  d.light.backlightFalloff = t.number("backlight_falloff", 0.0, 0, 0.9);
  t.finish();
  try {
    info.validate();
  } catch (const Error& e) {
    fail(Errc::Config, "{}: [display]: {}", t.file(), e.what());
  }
  return d;
}

// Whether `p` lies inside the closed mesh: the parity of the triangles a ray
// from p crosses (a direction no axis-aligned or diagonal edge lies along).
bool insideClosedMesh(const TriangleMesh& mesh, const Vec3& p) {
  bool inside = false;
  for (const auto& t : mesh.triangles) inside ^= detail::parityRayCrosses(mesh, t, p);
  return inside;
}

// Rays start in air: a sensor whose rays would start inside a solid gives a
// wrong image without a word. Checks a sample of the points where the
// sensor's rays start (a solid small enough to fit between them is missed),
// a grid over a rectangle of half sizes halfX, halfY about the origin of its
// plane, each moved by `reach` in eight directions (a stop's disc), against
// every solid and every closed mesh (an open one has no inside).
void requireOutsideSolids(const std::vector<Object>& objects, const Rigid3& worldFromPlane, double halfX, double halfY,
                          double reach, const std::string& where) {
  constexpr int kGrid = 17, kDirections = 8;
  for (const Object& object : objects) {
    std::function<bool(const Vec3&)> contains;  // in the object's frame
    if (const auto* solid = std::get_if<std::shared_ptr<const Solid>>(&object.shape)) {
      contains = [solid](const Vec3& p) { return (*solid)->contains(p); };
    } else if (const auto* mesh = std::get_if<TriangleMesh>(&object.shape)) {
      // Whether it is closed is asked only once a point falls in its box (the closure check costs time).
      contains = [mesh, box = detail::bounds(*mesh), closed = std::optional<bool>()](const Vec3& p) mutable {
        if (!box.holds(p)) return false;
        if (!closed) closed = !meshClosureFault(*mesh);
        return *closed && insideClosedMesh(*mesh, p);
      };
    } else {
      continue;
    }
    const Rigid3 objectFromWorld = object.worldFromObject.inverse();
    for (int i = 0; i < kGrid; ++i)
      for (int j = 0; j < kGrid; ++j) {
        const double x = halfX * (2.0 * i / (kGrid - 1) - 1), y = halfY * (2.0 * j / (kGrid - 1) - 1);
        for (int k = 0; k <= (reach > 0 ? kDirections : 0); ++k) {  // k = 0: the grid point itself
          const double a = 2 * std::numbers::pi * k / kDirections, r = k == 0 ? 0.0 : reach;
          const Vec3 p = worldFromPlane.point({x + r * std::cos(a), y + r * std::sin(a), 0});
          if (contains(objectFromWorld.point(p)))
            fail(Errc::Config,
                 "{}: the sensor's rays would start inside object '{}' (at ({:.4g}, {:.4g}, {:.4g}) "
                 "mm); the tracer starts them in air: move the sensor or the object",
                 where, object.name, p.x, p.y, p.z);
        }
      }
  }
}

}  // namespace

SceneDescription loadSceneFile(const fs::path& path) {
  ConfigTable root = ConfigTable::parseFile(path);
  root.requireKnownKeys({"format", "version", "ambient_ior", "render", "camera", "light_field_sensor", "camera_sensor",
                         "object", "display"});
  root.string("format", std::nullopt, {"lfi-scene"});
  root.integer("version", std::nullopt, 1, 1);
  SceneDescription d;
  d.name = path.stem().string();
  d.ambientIor = root.number("ambient_ior", 1.0, 1.0, 5.0);
  if (root.has("render")) {
    ConfigTable r = root.table("render");
    d.render.samplesPerPixel = r.integer("samples_per_pixel", 16, 1, kMostSamplesPerPixel);
    d.render.seed = static_cast<std::uint64_t>(r.integer64("seed", 1, 0, kLargestSeed));
    d.render.splitDepth = r.integer("split_depth", 4, 0, RenderOptions::kMaxSplitDepth);
    d.render.maxDepth = r.integer("max_depth", 64, 1, 1024);
    r.finish();
  }
  const bool hasCamera = root.has("camera"), hasLightField = root.has("light_field_sensor");
  std::string sensorWhere;  // the sensor's position_mm, to name it
  if (hasCamera == hasLightField)
    fail(Errc::Config, "{}: give exactly one sensor: [camera] or [light_field_sensor]",
         hasCamera ? root.where("light_field_sensor") : path.string());
  if (hasCamera) {
    ConfigTable c = root.table("camera");
    TelecentricCamera cam;
    cam.focalLength_mm = c.number("focal_length_mm", std::nullopt, 1e-3, 1e5);
    cam.imageDistance_mm = c.number("image_distance_mm", std::nullopt, 1e-3, 1e5);
    cam.stopDiameter_mm = c.number("stop_diameter_mm", std::nullopt, 1e-6, 1e4);
    cam.pixelPitch_mm = c.number("pixel_pitch_mm", std::nullopt, 1e-6, 100);
    cam.width = c.integer("width", std::nullopt, 1, 65536);
    cam.height = c.integer("height", std::nullopt, 1, 65536);
    if (static_cast<std::int64_t>(cam.width) * cam.height > kMaxExrPixels)
      fail(Errc::Config,
           "{}: {} x {} pixels is more than a radiance EXR holds (2^30): the render could not be "
           "written",
           c.where("height"), cam.width, cam.height);
    cam.worldFromCamera = detail::readPlacement(c);
    sensorWhere = c.where("position_mm");
    c.finish();
    if (cam.imageDistance_mm <= cam.focalLength_mm)
      fail(Errc::Config, "{} = {} must exceed focal_length_mm = {} (otherwise no real object is in focus)",
           c.where("image_distance_mm"), cam.imageDistance_mm, cam.focalLength_mm);
    try {
      cam.validate();
    } catch (const Error& e) {
      fail(Errc::Config, "{}: [camera]: {}", path.string(), e.what());
    }
    // b just past f puts the focused plane, and the field with it, out of any bench's reach.
    const TelecentricCamera::RayMap map(cam);
    if (const double reach = map.pixel * std::max(map.halfW, map.halfH) + map.stop; !(reach <= kFarthest_mm))
      fail(Errc::Config, "{} = {}: with focal_length_mm = {}, the field reaches {:g} mm from the axis, past {:g} mm",
           c.where("image_distance_mm"), cam.imageDistance_mm, cam.focalLength_mm, reach, kFarthest_mm);
    d.sensor = cam;
  } else {
    ConfigTable c = root.table("light_field_sensor");
    LightFieldSensor lfs;
    lfs.geometry.spatialX = c.integer("spatial_x", std::nullopt, 1, 1 << 15);
    lfs.geometry.spatialY = c.integer("spatial_y", std::nullopt, 1, 1 << 15);
    lfs.geometry.angular = c.integer("angular", std::nullopt, 1, 1024);
    lfs.geometry.pixelPitch_mm = c.number("pixel_pitch_mm", std::nullopt, 1e-6, 100);
    lfs.geometry.distance_mm = c.number("distance_mm", 0.0, 0, 1e6);
    lfs.worldFromSensor = detail::readPlacement(c);
    sensorWhere = c.where("position_mm");
    c.finish();
    try {
      lfs.geometry.validate();
    } catch (const Error& e) {
      fail(Errc::Config, "{} (with spatial_x, spatial_y): {}", c.where("angular"), e.what());
    }
    if (const double reach = std::max(lfs.geometry.extentX_mm(), lfs.geometry.extentY_mm()) / 2;
        !(reach <= kFarthest_mm))
      fail(Errc::Config,
           "{} = {}: with spatial_x = {}, spatial_y = {} and angular = {}, the sensor reaches {:g} mm "
           "from its centre, past {:g} mm",
           c.where("pixel_pitch_mm"), lfs.geometry.pixelPitch_mm, lfs.geometry.spatialX, lfs.geometry.spatialY,
           lfs.geometry.angular, reach, kFarthest_mm);
    d.sensor = lfs;
  }
  if (root.has("camera_sensor")) {
    if (!hasCamera) fail(Errc::Config, "{}: [camera_sensor] needs a [camera]", root.where("camera_sensor"));
    ConfigTable c = root.table("camera_sensor");
    d.cameraSensor.fullWell_e = c.number("full_well_e", d.cameraSensor.fullWell_e, 1, 1e9);
    d.cameraSensor.readNoise_e = c.number("read_noise_e", d.cameraSensor.readNoise_e, 0, 1e6);
    d.cameraSensor.bitDepth = c.integer("bit_depth", d.cameraSensor.bitDepth, 8, 16);
    d.cameraSensor.electronsPerUnitPerUs =
        c.number("electrons_per_unit_per_us", d.cameraSensor.electronsPerUnitPerUs, 1e-12, 1e12);
    const double maxDn = (1 << d.cameraSensor.bitDepth) - 1;
    d.cameraSensor.blackLevel_dn = c.number("black_level_dn", 0.0, 0, maxDn / 2);
    d.cameraSensor.darkFpn_dn = c.number("dark_fpn_dn", 0.0, 0, maxDn / 8);
    d.cameraSensor.gainFpn = c.number("gain_fpn", 0.0, 0, 0.25);
    d.cameraSensor.vignetting = c.number("vignetting", 0.0, 0, 0.9);
    d.cameraSensor.patternSeed = static_cast<std::uint64_t>(c.integer64("pattern_seed", 1, 0, kLargestSeed));
    c.finish();
  }
  // Errors, the study's report and the tracer's messages name objects: one name each.
  std::map<std::string, std::string> named;  // name -> where
  for (ConfigTable& o : root.tables("object")) {
    d.objects.push_back(detail::readObject(o));
    const std::string& name = d.objects.back().name;
    if (name.empty()) fail(Errc::Config, "{} is empty: errors and reports name an object by it", o.where("name"));
    if (const auto [at, fresh] = named.emplace(name, o.where("name")); !fresh)
      fail(Errc::Config, "{}: '{}' names another object too ({})", o.where("name"), name, at->second);
  }
  if (root.has("display")) {
    if (named.contains("display"))
      fail(Errc::Config, "{}: 'display' names the [display] panel's object: call this one something else",
           named["display"]);
    ConfigTable t = root.table("display");
    d.display = readDisplay(t);
    const DisplayInfo& info = d.display->info;
    Object obj;
    obj.name = "display";
    obj.shape = Rectangle{info.panelWidth_px * info.pixelPitch_mm, info.panelHeight_px * info.pixelPitch_mm};
    obj.worldFromObject = d.display->worldFromDisplay;
    obj.emission = makePanelEmission(std::make_shared<const PanelOptics>(info), cv::Mat(), d.display->brightness);
    d.displayObject = static_cast<int>(d.objects.size());
    d.objects.push_back(std::move(obj));
  }
  if (d.objects.empty()) fail(Errc::Config, "{}: the scene has no [[object]]", path.string());
  if (const auto* cam = std::get_if<TelecentricCamera>(&d.sensor)) {
    const TelecentricCamera::RayMap map(*cam);  // origins: the field, moved by up to the stop's radius
    requireOutsideSolids(d.objects, cam->worldFromCamera, map.pixel * map.halfW, map.pixel * map.halfH, map.stop,
                         sensorWhere);
  } else {
    const auto& lfs = std::get<LightFieldSensor>(d.sensor);
    const double e = lfs.geometry.elementPitch_mm();  // origins: the element centres
    requireOutsideSolids(d.objects, lfs.worldFromSensor, 0.5 * (lfs.geometry.extentX_mm() - e),
                         0.5 * (lfs.geometry.extentY_mm() - e), 0, sensorWhere);
  }
  root.finish();
  return d;
}

}  // namespace lfi::sim
