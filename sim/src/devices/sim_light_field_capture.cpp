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
    // (0 means "not set" in a light field file; here it is where the sensor is.)
    if (!(settings_.geometry.distance_mm > 0))
      fail(Errc::InvalidArgument,
           "sim light field capture of '{}': distance_mm = {} must be > 0: the sensor's plane "
           "lies Δ below the part",
           sceneFile_.string(), settings_.geometry.distance_mm);
    // Load now, so that a bad scene file is reported at open.
    SceneDescription d = loadSceneFile(sceneFile_);
    seed_ = d.render.seed;
    ambientIor_ = d.ambientIor;  // (a bench in a medium is captured in it)
    for (Object& o : d.objects)
      if (!o.emission) parts_.push_back(std::move(o));
    if (parts_.empty()) fail(Errc::Config, "'{}': no part to capture (every object emits)", sceneFile_.string());
    // The sensor looks up at the part from below it, the beam shines down from
    // above it: a part reaching either plane would be captured from inside.
    const double sensorZ = -settings_.geometry.distance_mm, beamZ = settings_.beamDistance_mm;
    for (const Object& part : parts_)
      if (const Bounds box = worldBounds(part); !(box.lo.z > sensorZ && box.hi.z < beamZ))
        fail(Errc::Config,
             "'{}': part '{}' spans z = {} .. {} mm, which reaches the light field sensor's plane "
             "(z = -distance_mm = {}) or the beam's (z = beam_distance_mm = {}): the part must lie between them",
             sceneFile_.string(), part.name, box.lo.z, box.hi.z, sensorZ, beamZ);
  }

  LightFieldGeometry geometry() const override { return settings_.geometry; }

  std::string description() const override {
    const auto& g = settings_.geometry;
    return fmt::format("sim:{} ({}x{} elements of {}x{}, pitch {} mm, Δ = {} mm, beam {} rad, {} spp)",
                       percentEncodeUriPart(sceneFile_.string()), g.spatialX, g.spatialY, g.angular, g.angular,
                       g.pixelPitch_mm, g.distance_mm, settings_.beamHalfAngle_rad, settings_.samplesPerPixel);
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

template <typename T>
T parseValue(const DeviceUri& uri, const std::string& key, T fallback) {
  auto it = uri.query.find(key);
  if (it == uri.query.end()) return fallback;
  T value{};
  const std::string& text = it->second;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size())
    fail(Errc::Config, "light field capture URI '{}': {} = '{}' is not a number", uri.text, key, text);
  return value;
}

}  // namespace

std::unique_ptr<LightFieldCapture> openSimLightFieldCapture(const std::filesystem::path& sceneFile,
                                                            const SimCaptureSettings& settings) {
  return std::make_unique<SimLightFieldCapture>(sceneFile, settings);
}

void registerSimLightFieldCapture() {
  backendRegistry<LightFieldCapture>().addOnce(LightFieldCaptureBackend{
      .scheme = "sim",
      .queryKeys = {"spatial", "angular", "pitch_mm", "distance_mm", "beam_half_angle_rad", "beam_distance_mm", "spp"},
      .description = "sim:<scene-file>[?spatial=&angular=&pitch_mm=&distance_mm=&beam_half_angle_rad=&"
                     "beam_distance_mm=&spp=]  simulated lensless light field sensor",
      .factory = [](const DeviceUri& uri) -> std::unique_ptr<LightFieldCapture> {
        SimCaptureSettings s;
        s.geometry.spatialX = s.geometry.spatialY = parseValue(uri, "spatial", s.geometry.spatialX);
        s.geometry.angular = parseValue(uri, "angular", s.geometry.angular);
        s.geometry.pixelPitch_mm = parseValue(uri, "pitch_mm", s.geometry.pixelPitch_mm);
        s.geometry.distance_mm = parseValue(uri, "distance_mm", s.geometry.distance_mm);
        s.beamHalfAngle_rad = parseValue(uri, "beam_half_angle_rad", s.beamHalfAngle_rad);
        s.beamDistance_mm = parseValue(uri, "beam_distance_mm", s.beamDistance_mm);
        s.samplesPerPixel = parseValue(uri, "spp", s.samplesPerPixel);
        try {
          return openSimLightFieldCapture(uri.path, s);
        } catch (const Error& e) {  // (a setting out of range: the URI's)
          if (e.code() != Errc::InvalidArgument) throw;
          fail(Errc::Config, "light field capture URI '{}': {}", uri.text, e.what());
        }
      },
  });
}

}  // namespace lfi::sim
