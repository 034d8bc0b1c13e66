#pragma once
// Path tracer for specular transport (SPEC §2): from a sensor sample through
// Fresnel reflection/refraction (chosen at random with probability F), Beer-
// Lambert absorption, opaque absorbers and Lambertian bounces, to an emitter.
// Tile-parallel with TBB. Every pixel draws from its own random stream keyed
// by (seed, pixel, sample), so a fixed seed gives a bit-identical image for
// any thread count or tile order.

#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include <opencv2/core.hpp>

#include <atomic>
#include <cstdint>
#include <functional>

namespace lfi::sim {

struct RenderOptions {
  int samplesPerPixel = 16;
  std::uint64_t seed = 1;
  int maxDepth = 64;   // interactions per path; longer paths contribute 0
  int threads = 0;     // 0 = all cores
  int tileSize = 16;
  // Called from worker threads with the fraction done (0..1), at most once per tile.
  std::function<void(double)> progress;
  // Set to true from any thread to stop; render() then throws Errc::Cancelled.
  const std::atomic<bool>* cancel = nullptr;
};

// Linear radiance image (CV_32FC1, sensor width x height): the mean over samples.
cv::Mat render(const Scene& scene, const Sensor& sensor, const RenderOptions& options);

// Radiance carried back along one ray of sight (exposed for tests and tools).
// `rng` state is a 64-bit counter-based stream; see render.cpp.
struct Sampler;
double traceRadiance(const Scene& scene, Ray ray, Sampler& sampler, int maxDepth);

// Deterministic per-pixel random numbers (PCG32 seeded by a hash of the key).
struct Sampler {
  std::uint64_t state;
  std::uint64_t increment;
  Sampler(std::uint64_t seed, std::uint64_t stream);
  std::uint32_t nextU32();
  double next();  // uniform in [0, 1)
};

// Fresnel reflectance of unpolarised light at an interface n1 -> n2 for the
// cosine of the incidence angle (1 under total internal reflection).
double fresnelReflectance(double cosIncidence, double n1, double n2);
// Refracts unit `d` at a surface with unit normal `n` facing the incoming side
// (d . n < 0), eta = n1 / n2. Returns false under total internal reflection.
bool refract(const Vec3& d, const Vec3& n, double eta, Vec3& out);
Vec3 reflect(const Vec3& d, const Vec3& n);

}  // namespace lfi::sim
