// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim: what the renderer's new samples start with, for many
// samples at once (structure of arrays, vectorised): the telecentric camera's
// samples and every sample's stratified Fresnel choices. A camera sample is:
// its random stream, two draws as pairs (pixel area, stop), the jittered strata,
// Shirley's concentric map of the stop draw and the ray of sight of
// TelecentricCamera::RayMap. path_walk.cpp's concentricDisc() and this batch
// share the disc arithmetic below, so both give the same bits.

#include "lfi/sim/render.h"
#include "lfi/sim/sensors.h"

#include <cstdint>
#include <numbers>

namespace lfi::sim::detail {

// sin x and cos x for |x| <= pi/4 by their Taylor series to x^15 and x^16
// (remainders below 5e-17, so exact to rounding), by Estrin's scheme for a
// short dependency chain.
inline void sinCosQuarter(double x, double& sinX, double& cosX) {
  const double y = -x * x, y2 = y * y, y4 = y2 * y2, y8 = y4 * y4;
  // sin x / x = sum y^k / (2k+1)!, cos x = sum y^k / (2k)!, k = 0..7 (cos: ..8)
  const double s01 = 1 + y * (1.0 / 6), s23 = 1.0 / 120 + y * (1.0 / 5040);
  const double s45 = 1.0 / 362880 + y * (1.0 / 39916800), s67 = 1.0 / 6227020800 + y * (1.0 / 1307674368000);
  const double c01 = 1 + y * 0.5, c23 = 1.0 / 24 + y * (1.0 / 720);
  const double c45 = 1.0 / 40320 + y * (1.0 / 3628800), c67 = 1.0 / 479001600 + y * (1.0 / 87178291200);
  sinX = x * ((s01 + s23 * y2) + (s45 + s67 * y2) * y4);
  cosX = (c01 + c23 * y2) + (c45 + c67 * y2) * y4 + y8 * (1.0 / 20922789888000);
}

// Shirley and Chiu's concentric map, branch-free: for |a| > |b| (a = 2 u1 - 1,
// b = 2 u2 - 1) the point is a (cos phi, sin phi) with phi = pi/4 b/a,
// otherwise b (sin psi, cos psi) with psi = pi/4 a/b.
inline void concentricDisc(double u1, double u2, double& x, double& y) {
  const double a = 2 * u1 - 1, b = 2 * u2 - 1;
  const bool wide = std::abs(a) > std::abs(b);
  const double r = wide ? a : b, other = wide ? b : a;
  const double ratio = r != 0 ? other / r : 0;
  double s, c;
  sinCosQuarter((std::numbers::pi / 4) * ratio, s, c);
  x = r * (wide ? c : s);
  y = r * (wide ? s : c);
}

// What the samples are (filled by the renderer) and what they give.
struct CameraSampleBatch {
  static constexpr int kSize = 64;
  // In: each sample's random stream (Sampler(seed, stream)), pixel, index in
  // the pixel and the key of its pixel's stop permutation. The first side^2
  // samples of a pixel are stratified: sample s's pixel-area draw falls in
  // stratum s, its stop draw in stratum permutationElement(s, side^2, key);
  // the rest draw plainly.
  std::uint64_t stream[kSize];
  double pixelX[kSize], pixelY[kSize];
  std::uint32_t sample[kSize], stopKey[kSize];
  // Out: the ray of sight (world frame) and the stream's state after the two draws.
  double ox[kSize], oy[kSize], oz[kSize], dx[kSize], dy[kSize], dz[kSize];
  std::uint64_t state[kSize];
};

// Samples 0..n-1 of `batch`; `side` strata per axis. Returns the mask of
// samples (bit k) that pass the stop (all but those a knife edge blocks).
std::uint64_t makeCameraSamples(const TelecentricCamera::RayMap& camera, std::uint64_t seed, int side, int n,
                                CameraSampleBatch& batch);

// The same for a light field sensor (stopKey unused; pixelX, pixelY the
// lenslet image's column and row), to the bit as one sample at a time:
// Sampler(seed, stream), its first two draws (Sampler::next) as the offset in
// the pixel, jittered in stratum `sample` of side x side when sample < side^2,
// and LightFieldSensor::ray. Returns the samples that have a ray (bit k);
// the others fall outside the hemisphere mapping.
std::uint64_t makeLightFieldSamples(const LightFieldSensor& sensor, std::uint64_t seed, int side, int n,
                                    CameraSampleBatch& batch);

// The first kStratifiedChoices Fresnel choices of a pixel's samples are drawn
// from a Latin hypercube rather than at random: choice d of sample s falls in
// stratum permutationElement(s, spp, key[d]) of [0, 1) cut into spp, jittered
// by unitInterval(splitMix64(key[d] << 32 | s)). Across the pixel's samples
// each choice then covers [0, 1) evenly, so the few reflect/refract branches of
// a lens are taken in proportion.
constexpr int kStratifiedChoices = 4;
// The choice in a given stratum (of width 1/spp), jittered.
inline double jitteredChoice(std::uint32_t stratum, double stratumWidth, std::uint32_t sample, std::uint32_t key) {
  const double jitter = Sampler::unitInterval(splitMix64((std::uint64_t{key} << 32) | sample));
  return (stratum + jitter) * stratumWidth;
}
inline double stratifiedChoice(std::uint32_t spp, std::uint32_t sample, std::uint32_t key) {
  return jitteredChoice(permutationElement(sample, spp, key), 1.0 / spp, sample, key);
}

// The first kBatchedChoices of them (a lens's two faces), for many samples at
// once; the rest, which few paths reach, one at a time when they are needed.
constexpr int kBatchedChoices = 2;
struct ChoiceBatch {
  static constexpr int kSize = 16;
  std::uint32_t sample[kSize];                // in: index in the pixel, < spp
  std::uint32_t key[kBatchedChoices][kSize];  // in: the pixel's key of each choice
  double u[kBatchedChoices][kSize];           // out: stratifiedChoice(spp, sample, key)
};

// Choices of samples 0..n-1 of `batch`, spp samples per pixel.
void makeStratifiedChoices(std::uint32_t spp, int n, ChoiceBatch& batch);

}  // namespace lfi::sim::detail
