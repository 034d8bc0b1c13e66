// SPDX-License-Identifier: Apache-2.0
#pragma once
// Path tracer for specular transport (the paper's model): from a sensor sample through
// Fresnel reflection/refraction (chosen at random with probability F), Beer-
// Lambert absorption, opaque absorbers and Lambertian bounces, to an emitter.
// Tile-parallel with TBB; within a tile, 16 samples at a time are traced as
// one Embree packet. Every sample draws from its own random stream keyed by
// (seed, pixel, sample) and is summed in sample order, so a fixed seed gives a
// bit-identical image for any thread count, tile size or tile order.

#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include <opencv2/core.hpp>

#include <atomic>
#include <bit>
#include <cstdint>
#include <functional>
#include <vector>

namespace lfi::sim {

struct RenderOptions {
  int samplesPerPixel = 16;
  std::uint64_t seed = 1;
  int maxDepth = 64;  // interactions per path; longer paths contribute 0
  // Fresnel events among the first splitDepth interactions are split (both
  // branches traced, weighted F and 1 - F) rather than sampled: same mean, far
  // less noise for the few interfaces of a lens. 0 = pure sampling; at most
  // kMaxSplitDepth (each split doubles a sample's paths).
  static constexpr int kMaxSplitDepth = 12;
  int splitDepth = 4;
  int threads = 0;  // 0 = all cores
  int tileSize = 16;
  // Called from worker threads with the fraction done (0..1), at most once per tile.
  std::function<void(double)> progress;
  // Set to true from any thread to stop; render() then throws Errc::Cancelled.
  const std::atomic<bool>* cancel = nullptr;
};

// Linear radiance image (CV_32FC1, sensor width x height): the mean over samples.
cv::Mat render(const Scene& scene, const Sensor& sensor, const RenderOptions& options);

// Radiance carried back along one ray of sight (exposed for tests and tools).
struct Sampler;
double traceRadiance(const Scene& scene, const Ray& ray, Sampler& sampler, int maxDepth, int splitDepth = 0);

// The deterministic refraction-only path of a ray (reflection only under total
// internal reflection): its vertices, starting with the origin. The path ends
// at an emitter, an absorber, a diffuse surface, after maxDepth vertices, or,
// when it leaves the scene, with one more vertex at `escape` mm along the ray.
std::vector<Vec3> refractionPath(const Scene& scene, const Ray& ray, int maxDepth = 64, double escape = 1e4);

// SplitMix64's output function (Steele, Lea and Flood 2014): a 64-bit mix.
inline std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// Deterministic random numbers, one stream per key: SplitMix64 (passes
// BigCrush) started at a hash of (seed, stream). A path draws a few dozen
// numbers, so streams of distinct keys do not overlap.
struct Sampler {
  std::uint64_t state;
  Sampler(std::uint64_t seed, std::uint64_t stream) : state(splitMix64(stream ^ splitMix64(seed))) {}
  std::uint64_t nextU64() {
    const std::uint64_t x = state;
    state += 0x9e3779b97f4a7c15ull;  // the golden-ratio increment; splitMix64 mixes x + increment
    return splitMix64(x);
  }
  std::uint32_t nextU32() { return static_cast<std::uint32_t>(nextU64() >> 32); }
  double next() { return unitInterval(nextU64()); }  // uniform in [0, 1)
  // Two uniform doubles from one draw, one from each half: in [0, 1) in steps
  // of 2^-32, fine enough for a position within a pixel or on the stop.
  void nextPair(double& a, double& b) {
    const std::uint64_t x = nextU64();
    a = unitInterval32(static_cast<std::uint32_t>(x >> 32));
    b = unitInterval32(static_cast<std::uint32_t>(x));
  }
  // The top 52 bits as the mantissa of a double in [1, 2), minus 1: uniform
  // in [0, 1) in steps of 2^-52, with integer operations only.
  static double unitInterval(std::uint64_t bits) {
    return std::bit_cast<double>((bits >> 12) | 0x3ff0000000000000ull) - 1.0;
  }
  // The same for 32 bits: uniform in [0, 1) in steps of 2^-32.
  static double unitInterval32(std::uint32_t bits) {
    return std::bit_cast<double>((std::uint64_t{bits} << 20) | 0x3ff0000000000000ull) - 1.0;
  }
};

// Kensler's hash (Correlated Multi-Jittered Sampling, Pixar 2013): every step
// (xor with the key, odd multiplies, xor-shifts of the bits under the mask) is
// invertible on the low k bits, so one round permutes [0, mask + 1) for
// mask = 2^k - 1.
inline std::uint32_t permutationRound(std::uint32_t i, std::uint32_t mask, std::uint32_t key) {
  i ^= key, i *= 0xe170893du, i ^= key >> 16, i ^= (i & mask) >> 4;
  i ^= key >> 8, i *= 0x0929eb3fu, i ^= key >> 23, i ^= (i & mask) >> 1;
  i *= 1 | key >> 27, i *= 0x6935fa69u, i ^= (i & mask) >> 11, i *= 0x74dcb303u;
  i ^= (i & mask) >> 2, i *= 0x9e501cc3u, i ^= (i & mask) >> 2, i *= 0xc860a3dfu;
  i &= mask, i ^= i >> 5;
  return i;
}
inline std::uint32_t permutationMask(std::uint32_t n) {  // 2^k - 1 >= n - 1
  std::uint32_t mask = n - 1;
  mask |= mask >> 1, mask |= mask >> 2, mask |= mask >> 4, mask |= mask >> 8, mask |= mask >> 16;
  return mask;
}
// Element i of a pseudo-random permutation of [0, n) chosen by `key` (Kensler
// 2013), computed on its own, without building the permutation; 0 <= i < n.
// Rounds are repeated while the value is >= n (cycle walking, which permutes
// [0, n)); then a rotation by the key (in 64 bits: i + key must not wrap; a
// mask when n is a power of two).
inline std::uint32_t permutationRotation(std::uint32_t i, std::uint32_t n, std::uint32_t mask, std::uint32_t key) {
  return (n & mask) == 0 ? (i + key) & mask : static_cast<std::uint32_t>((std::uint64_t{i} + key) % n);
}
inline std::uint32_t permutationElement(std::uint32_t i, std::uint32_t n, std::uint32_t key) {
  const std::uint32_t mask = permutationMask(n);
  do i = permutationRound(i, mask, key);
  while (i >= n);
  return permutationRotation(i, n, mask, key);
}

// Shirley and Chiu's concentric map of the unit square onto the unit disc:
// area-preserving (uniform u gives a uniform point), keeps strata compact,
// no singular centre. Square edges go to the circle.
Vec2 concentricDisc(double u1, double u2);

// Fresnel reflectance of unpolarised light at an interface n1 -> n2 for the
// cosine of the incidence angle (1 under total internal reflection).
double fresnelReflectance(double cosIncidence, double n1, double n2);
// Refracts unit `d` at a surface with unit normal `n` facing the incoming side
// (d . n < 0), eta = n1 / n2. Returns false under total internal reflection.
// Both give unit vectors to rounding, for unit d and n.
bool refract(const Vec3& d, const Vec3& n, double eta, Vec3& out);
Vec3 reflect(const Vec3& d, const Vec3& n);

}  // namespace lfi::sim
