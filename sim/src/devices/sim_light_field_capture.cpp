// SPDX-License-Identifier: Apache-2.0
#include "lfi/sim/devices/sim_light_field_capture.h"

#include "lfi/core/error.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/sim/render.h"
#include "lfi/sim/scene_file.h"

#include "capture_beam.h"

#include <algorithm>
#include <charconv>
#include <string>
#include <vector>

namespace lfi::sim {
namespace {

class SimLightFieldCapture final : public LightFieldCapture {
 public:
  SimLightFieldCapture(const std::filesystem::path& sceneFile, const SimCaptureSettings& settings)
      : sceneFile_(sceneFile), settings_(settings) {
    try {
      settings_.geometry.validate();
    } catch (const Error& e) {
      fail(e.code(), "sim light field capture of '{}': {}", sceneFile_.string(), e.what());
    }
    if (!(settings_.beamHalfAngle_rad >= kNarrowestCone_rad && settings_.beamHalfAngle_rad < 1.5))
      fail(Errc::InvalidArgument, "sim light field capture of '{}': beam_half_angle_rad = {} is outside [1e-6, 1.5)",
           sceneFile_.string(), settings_.beamHalfAngle_rad);
    // (As a scene file's positions and samples per pixel: a beam at infinity would light nothing.)
    if (!(settings_.beamDistance_mm > 0 && settings_.beamDistance_mm <= kFarthest_mm))
      fail(Errc::InvalidArgument, "sim light field capture of '{}': beam_distance_mm = {} is outside (0, 1e6]",
           sceneFile_.string(), settings_.beamDistance_mm);
    static_assert(kFarthest_mm == 1e6 && kNarrowestCone_rad == 1e-6, "the messages above state the bounds");
    if (settings_.samplesPerPixel < 1 || settings_.samplesPerPixel > kMostSamplesPerPixel)
      fail(Errc::InvalidArgument, "sim light field capture of '{}': spp = {} is outside 1 .. 2^20", sceneFile_.string(),
           settings_.samplesPerPixel);
    // Load now, so that a bad scene file is reported at open.
    SceneDescription d = loadSceneFile(sceneFile_);
    seed_ = d.render.seed;
    ambientIor_ = d.ambientIor;  // (a bench in a medium is captured in it)
    for (Object& o : d.objects)
      if (!o.emission) parts_.push_back(std::move(o));
    if (parts_.empty()) fail(Errc::Config, "'{}': no part to capture (every object emits)", sceneFile_.string());
    setDistance(settings_.geometry.distance_mm);
  }

  // (0 means "not set" in a light field file; here it is where the sensor is.)
  void setDistance(double distance_mm) override {
    if (!(distance_mm > 0 && distance_mm <= kFarthest_mm))
      fail(Errc::InvalidArgument,
           "sim light field capture of '{}': Δ = {} mm is outside (0, 1e6]: the sensor's plane lies Δ below the part",
           sceneFile_.string(), distance_mm);
    // The sensor looks up at the part from below it, the beam shines down from
    // above it: a part reaching either plane would be captured from inside.
    const double sensorZ = -distance_mm, beamZ = settings_.beamDistance_mm;
    for (const Object& part : parts_)
      if (const Bounds box = worldBounds(part); !(box.lo.z > sensorZ && box.hi.z < beamZ))
        fail(Errc::Config,
             "'{}': part '{}' spans z = {} .. {} mm, which reaches the light field sensor's plane "
             "(z = -Δ = {}) or the beam's (z = beam_distance_mm = {}): the part must lie between them",
             sceneFile_.string(), part.name, box.lo.z, box.hi.z, sensorZ, beamZ);
    settings_.geometry.distance_mm = distance_mm;
  }

  LightFieldGeometry geometry() const override { return settings_.geometry; }

  std::string description() const override {
    const auto& g = settings_.geometry;
    return fmt::format("{} ({}x{} elements of {}x{}, pitch {} mm, Δ = {} mm, beam {} rad, {} spp)",
                       DeviceUri{.scheme = "sim", .path = sceneFile_.string()}, g.spatialX, g.spatialY, g.angular,
                       g.angular, g.pixelPitch_mm, g.distance_mm, settings_.beamHalfAngle_rad,
                       settings_.samplesPerPixel);
  }

  LightField capture(const std::function<void(double)>& progress) override {
    const double size = 4 * std::max(settings_.geometry.extentX_mm(), settings_.geometry.extentY_mm()) + 200;
    const Scene scene =
        detail::captureScene(parts_, ambientIor_, settings_.beamDistance_mm, settings_.beamHalfAngle_rad, size);
    const LightFieldSensor sensor{settings_.geometry, Rigid3::translation({0, 0, -settings_.geometry.distance_mm})};
    RenderOptions ro;
    ro.samplesPerPixel = settings_.samplesPerPixel;
    ro.seed = seed_ ^ 0x4c46ull;
    ro.threads = settings_.threads;
    ro.progress = progress;
    return LightField(settings_.geometry, render(scene, sensor, ro));
  }

 private:
  std::filesystem::path sceneFile_;
  SimCaptureSettings settings_;
  std::vector<Object> parts_;
  std::uint64_t seed_ = 1;
  double ambientIor_ = 1;
};

// The sim: capture's query keys; their defaults are SimCaptureSettings's.
const SimCaptureSettings kDefaults;
const UriKey kSpatial{.name = "spatial",
                      .value = UriValue::Integer,
                      .lo = 1,
                      .hi = 1 << 14,
                      .fallback = kDefaults.geometry.spatialX,
                      .meaning = "spatial elements per side"};
const UriKey kAngular{.name = "angular",
                      .value = UriValue::Integer,
                      .lo = 1,
                      .hi = 1 << 10,
                      .fallback = kDefaults.geometry.angular,
                      .meaning = "angular elements per side"};
const UriKey kPitch{.name = "pitch_mm",
                    .unit = "mm",
                    .lo = 1e-6,
                    .hi = 1e3,
                    .fallback = kDefaults.geometry.pixelPitch_mm,
                    .meaning = "sensor pixel pitch"};
const UriKey kBeamHalfAngle{.name = "beam_half_angle_rad",
                            .unit = "rad",
                            .lo = kNarrowestCone_rad,
                            .hi = 1.5,
                            .fallback = kDefaults.beamHalfAngle_rad,
                            .meaning = "divergence of the collimated beam"};
const UriKey kBeamDistance{.name = "beam_distance_mm",
                           .unit = "mm",
                           .lo = 1e-6,
                           .hi = kFarthest_mm,
                           .fallback = kDefaults.beamDistance_mm,
                           .meaning = "beam plane at world z = +beam_distance_mm, facing -z"};
const UriKey kSpp{.name = "spp",
                  .value = UriValue::Integer,
                  .lo = 1,
                  .hi = kMostSamplesPerPixel,
                  .fallback = kDefaults.samplesPerPixel,
                  .meaning = "samples per sensor pixel"};

}  // namespace

std::unique_ptr<LightFieldCapture> openSimLightFieldCapture(const std::filesystem::path& sceneFile,
                                                            const SimCaptureSettings& settings) {
  return std::make_unique<SimLightFieldCapture>(sceneFile, settings);
}

void registerSimLightFieldCapture() {
  backendRegistry<LightFieldCapture>().addOnce(LightFieldCaptureBackend{
      .scheme = "sim",
      .keys = {kSpatial, kAngular, kPitch, kBeamHalfAngle, kBeamDistance, kSpp},
      .description = "sim:<scene-file>[?spatial=&angular=&pitch_mm=&beam_half_angle_rad=&beam_distance_mm=&spp=]  "
                     "simulated lensless light field sensor (Δ: the bench's)",
      .factory = [](const DeviceUri& uri) -> std::unique_ptr<LightFieldCapture> {
        SimCaptureSettings s;
        s.geometry.spatialX = s.geometry.spatialY = *uriNumber<int>(uri, kSpatial);
        s.geometry.angular = *uriNumber<int>(uri, kAngular);
        s.geometry.pixelPitch_mm = *uriNumber(uri, kPitch);
        s.beamHalfAngle_rad = *uriNumber(uri, kBeamHalfAngle);
        s.beamDistance_mm = *uriNumber(uri, kBeamDistance);
        s.samplesPerPixel = *uriNumber<int>(uri, kSpp);
        try {
          return openSimLightFieldCapture(uri.path, s);
        } catch (const Error& e) {  // (a setting out of range: the URI's)
          if (e.code() != Errc::InvalidArgument) throw;
          fail(Errc::Config, "light field capture URI '{}': {}", uri.text(), e.what());
        }
      },
  });
}

}  // namespace lfi::sim
