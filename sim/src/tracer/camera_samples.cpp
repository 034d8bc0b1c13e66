// SPDX-License-Identifier: Apache-2.0
#include "camera_samples.h"

#include "lfi/sim/render.h"

#include "simd.h"

#include <algorithm>
#include <cmath>

namespace lfi::sim::detail {

namespace {

// The rest of permutationElement for lanes whose first round gave i[k]: the
// cycle walk of the few lanes at or past n (none when n is a power of two),
// then the rotation, for all lanes at once.
inline void walkAndRotate(int lanes, std::uint32_t n, std::uint32_t mask, const std::uint32_t* key, std::uint32_t* i) {
  unsigned walk = 0;
  for (int k = 0; k < lanes; ++k) walk |= i[k] >= n ? 1u : 0u;
  if (walk)
    for (int k = 0; k < lanes; ++k)
      while (i[k] >= n) i[k] = permutationRound(i[k], mask, key[k]);
  for (int k = 0; k < lanes; ++k) i[k] = permutationRotation(i[k], n, mask, key[k]);
}

}  // namespace

LFI_SIMD_CLONES std::uint64_t makeCameraSamples(const TelecentricCamera::RayMap& camera, std::uint64_t seed, int side,
                                                int n, CameraSampleBatch& b) {
  constexpr std::uint64_t kGolden = 0x9e3779b97f4a7c15ull;  // Sampler's increment
  const std::uint64_t seedHash = splitMix64(seed);
  const double invSide = 1.0 / side;
  // The stop strata: the permutation's first round for every sample at once,
  // then the few that must walk on (none when side^2 is a power of two).
  const auto strata = static_cast<std::uint32_t>(side * side), mask = permutationMask(strata);
  std::uint32_t stop[CameraSampleBatch::kSize];
  for (int k = 0; k < n; ++k)  // (unstratified samples permute 0, for a walk that ends)
    stop[k] = permutationRound(b.sample[k] < strata ? b.sample[k] : 0, mask, b.stopKey[k]);
  walkAndRotate(n, strata, mask, b.stopKey, stop);
  std::uint32_t passed[CameraSampleBatch::kSize];
  for (int k = 0; k < n; ++k) {
    // Sampler(seed, stream) and its first two draws, as pairs (Sampler::nextPair).
    const std::uint64_t state = splitMix64(b.stream[k] ^ seedHash);
    const std::uint64_t pixelDraw = splitMix64(state), stopDraw = splitMix64(state + kGolden);
    const double u0 = Sampler::unitInterval32(static_cast<std::uint32_t>(pixelDraw >> 32));
    const double u1 = Sampler::unitInterval32(static_cast<std::uint32_t>(pixelDraw));
    const double u2 = Sampler::unitInterval32(static_cast<std::uint32_t>(stopDraw >> 32));
    const double u3 = Sampler::unitInterval32(static_cast<std::uint32_t>(stopDraw));
    b.state[k] = state + 2 * kGolden;
    // Jittered stratum (row = stratum div side, exactly: the quotient is at
    // least 0.5 / side away from an integer) or the plain draws.
    auto stratify = [&](double stratum, double u, double v, double& x, double& y) {
      const double row = std::floor((stratum + 0.5) * invSide), col = stratum - row * side;
      x = stratum >= 0 ? (col + u) * invSide : u;
      y = stratum >= 0 ? (row + v) * invSide : v;
    };
    double jx, jy, su, sv, ax, ay;
    const bool stratified = b.sample[k] < strata;
    stratify(stratified ? b.sample[k] : -1.0, u0, u1, jx, jy);
    stratify(stratified ? stop[k] : -1.0, u2, u3, su, sv);
    concentricDisc(su, sv, ax, ay);
    passed[k] = ax <= camera.edge ? 1u : 0u;
    camera.trace(b.pixelX[k] + jx, b.pixelY[k] + jy, ax, ay, b.ox[k], b.oy[k], b.oz[k], b.dx[k], b.dy[k], b.dz[k]);
  }
  std::uint64_t withRay = 0;
  for (int k = 0; k < n; ++k) withRay |= std::uint64_t{passed[k]} << k;
  return withRay;
}

LFI_SIMD_CLONES std::uint64_t makeLightFieldSamples(const LightFieldSensor& sensor, std::uint64_t seed, int side, int n,
                                                    CameraSampleBatch& b) {
  constexpr std::uint64_t kGolden = 0x9e3779b97f4a7c15ull;  // Sampler's increment
  const std::uint64_t seedHash = splitMix64(seed);
  const auto strata = static_cast<std::uint32_t>(side * side);
  const double invSide = 1.0 / side, angular = sensor.geometry.angular, invAngular = 1.0 / angular;
  const double e = sensor.geometry.elementPitch_mm();
  const double halfX = 0.5 * sensor.geometry.spatialX, halfY = 0.5 * sensor.geometry.spatialY;
  const auto& r = sensor.worldFromSensor.r;
  const Vec3 shift = sensor.worldFromSensor.t;
  std::uint32_t seen[CameraSampleBatch::kSize];
  for (int k = 0; k < n; ++k) {
    const std::uint64_t state = splitMix64(b.stream[k] ^ seedHash);
    double ox = Sampler::unitInterval(splitMix64(state)), oy = Sampler::unitInterval(splitMix64(state + kGolden));
    b.state[k] = state + 2 * kGolden;
    // The jittered stratum (row = sample div side, exactly: the quotient is at
    // least 0.5 / side away from an integer).
    const double s = b.sample[k], row = std::floor((s + 0.5) * invSide), col = s - row * side;
    const bool stratified = b.sample[k] < strata;
    ox = stratified ? (col + ox) * invSide : ox;
    oy = stratified ? (row + oy) * invSide : oy;
    // LightFieldSensor::ray: element (ex, ey) and angular pixel (u, v) of the
    // lenslet pixel, as integer division and remainder would give them.
    const double ex = std::floor((b.pixelX[k] + 0.5) * invAngular), ey = std::floor((b.pixelY[k] + 0.5) * invAngular);
    const double u = b.pixelX[k] - ex * angular, v = b.pixelY[k] - ey * angular;
    const double px = (2.0 * (u + ox)) / angular - 1, py = (2.0 * (v + oy)) / angular - 1;
    const double r2 = px * px + py * py;
    seen[k] = r2 < 1 ? 1u : 0u;
    const double qx = (ex + 0.5 - halfX) * e, qy = (ey + 0.5 - halfY) * e, qz = 0;
    b.ox[k] = r[0] * qx + r[1] * qy + r[2] * qz + shift.x;  // Rigid3::point
    b.oy[k] = r[3] * qx + r[4] * qy + r[5] * qz + shift.y;
    b.oz[k] = r[6] * qx + r[7] * qy + r[8] * qz + shift.z;
    const double dx = -px, dy = -py, dz = std::sqrt(std::max(0.0, 1 - r2));  // LightField::directionFromDisc
    b.dx[k] = r[0] * dx + r[1] * dy + r[2] * dz;                             // Rigid3::vector
    b.dy[k] = r[3] * dx + r[4] * dy + r[5] * dz;
    b.dz[k] = r[6] * dx + r[7] * dy + r[8] * dz;
  }
  std::uint64_t withRay = 0;
  for (int k = 0; k < n; ++k) withRay |= std::uint64_t{seen[k]} << k;
  return withRay;
}

LFI_SIMD_CLONES void makeStratifiedChoices(std::uint32_t spp, int n, ChoiceBatch& b) {
  // As permutationElement: the first round for every lane at once, then the
  // lanes that must walk on (none when spp is a power of two).
  const std::uint32_t mask = permutationMask(spp);
  const double stratumWidth = 1.0 / spp;
  for (int d = 0; d < kBatchedChoices; ++d) {
    std::uint32_t stratum[ChoiceBatch::kSize];
    for (int k = 0; k < n; ++k) stratum[k] = permutationRound(b.sample[k], mask, b.key[d][k]);
    walkAndRotate(n, spp, mask, b.key[d], stratum);
    for (int k = 0; k < n; ++k) b.u[d][k] = jitteredChoice(stratum[k], stratumWidth, b.sample[k], b.key[d][k]);
  }
}

}  // namespace lfi::sim::detail
