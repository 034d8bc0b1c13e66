// SPDX-License-Identifier: Apache-2.0
// The renderer's random numbers and samples: SplitMix64 streams, Kensler's
// permutations, the concentric disc, and the vectorised sample and stratified
// choice passes against the one-sample formulas, to the bit.
#include "lfi/sim/render.h"
#include "lfi/sim/sensors.h"

#include "camera_samples.h"  // sim/src/tracer: the renderer's vectorised sample pass

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

namespace {

using namespace lfi;
using namespace lfi::sim;

// permutationElement permutes [0, n) for any n (powers of two and, by cycle
// walking, the rest); distinct keys give distinct permutations; over many keys
// each element lands in each position equally often (here 4000 keys, n = 8:
// each count is 500 +- 21 (binomial sigma), bounded at 5 sigma).
TEST(Sampler, PermutationElementsPermuteAndAreUniform) {
  for (std::uint32_t n : {1u, 2u, 3u, 7u, 16u, 64u, 100u, 1000u})
    for (std::uint32_t key : {0u, 1u, 0xdeadbeefu, 0x9e3779b9u, 0xffffffffu, 0xfffffc00u}) {
      std::vector<int> seen(n, 0);
      for (std::uint32_t i = 0; i < n; ++i) {
        const std::uint32_t v = permutationElement(i, n, key);
        ASSERT_LT(v, n);
        ++seen[v];
      }
      for (std::uint32_t v = 0; v < n; ++v) ASSERT_EQ(seen[v], 1) << "n = " << n << ", key = " << key;
    }
  int same = 0;
  for (std::uint32_t i = 0; i < 64; ++i) same += permutationElement(i, 64, 11) == permutationElement(i, 64, 12);
  EXPECT_LT(same, 16);
  std::array<std::array<int, 8>, 8> counts{};
  Sampler keys(3, 9);
  for (int k = 0; k < 4000; ++k) {
    const std::uint32_t key = keys.nextU32();
    for (std::uint32_t i = 0; i < 8; ++i) ++counts[i][permutationElement(i, 8, key)];
  }
  const double sigma = std::sqrt(4000 * (1.0 / 8) * (7.0 / 8));
  for (const auto& row : counts)
    for (int c : row) EXPECT_NEAR(c, 500, 5 * sigma);
}

// Uniform doubles in [0, 1) with mean 1/2, one per draw or two (whose
// product then has mean 1/4: the halves are uncorrelated); the ends of the
// 32-bit map.
TEST(Sampler, UniformDoublesAreInRange) {
  Sampler sampler(3, 9);
  constexpr int kDraws = 100000;
  double sum = 0, sumA = 0, sumB = 0, sumAB = 0;
  for (int k = 0; k < kDraws; ++k) {
    const double u = sampler.next();
    double a, b;
    sampler.nextPair(a, b);
    for (const double v : {u, a, b}) {
      ASSERT_GE(v, 0.0);
      ASSERT_LT(v, 1.0);
    }
    sum += u, sumA += a, sumB += b, sumAB += a * b;
  }
  const double sigma = std::sqrt(1.0 / 12 / kDraws);
  EXPECT_NEAR(sum / kDraws, 0.5, 5 * sigma);
  EXPECT_NEAR(sumA / kDraws, 0.5, 5 * sigma);
  EXPECT_NEAR(sumB / kDraws, 0.5, 5 * sigma);
  EXPECT_NEAR(sumAB / kDraws, 0.25, 5 * std::sqrt(7.0 / 144 / kDraws));  // var(ab) = 1/9 - 1/16
  EXPECT_EQ(Sampler::unitInterval32(0), 0.0);
  EXPECT_EQ(Sampler::unitInterval32(0xffffffffu), 1.0 - 0x1p-32);
  EXPECT_EQ(Sampler::unitInterval32(0x80000000u), 0.5);
}

// The concentric map (Shirley and Chiu 1997): square (u1, u2) -> 2u - 1 =
// (a, b); for |a| > |b| the point is a (cos phi, sin phi) with phi = pi/4 b/a,
// otherwise b (sin psi, cos psi) with psi = pi/4 a/b. The renderer's own sin
// and cos (series on |x| <= pi/4) must agree with libm to rounding; the map
// keeps radius max(|a|, |b|) and is uniform: a quadrant's share is 1/4 and the
// mean of r^2 over a uniform disc is 1/2.
TEST(ConcentricDisc, IsShirleysMapToRoundingAndUniform) {
  Sampler sampler(5, 1);
  double r2 = 0;
  int firstQuadrant = 0;
  const int n = 200000;
  for (int k = 0; k < n; ++k) {
    const double u1 = sampler.next(), u2 = sampler.next();
    const Vec2 p = concentricDisc(u1, u2);
    const double a = 2 * u1 - 1, b = 2 * u2 - 1;
    const double phi = std::abs(a) > std::abs(b) ? std::numbers::pi / 4 * b / a : std::numbers::pi / 4 * a / b;
    const Vec2 expected = std::abs(a) > std::abs(b) ? Vec2(a * std::cos(phi), a * std::sin(phi))
                                                    : Vec2(b * std::sin(phi), b * std::cos(phi));
    ASSERT_NEAR(p.x, expected.x, 4e-16) << u1 << " " << u2;
    ASSERT_NEAR(p.y, expected.y, 4e-16) << u1 << " " << u2;
    ASSERT_NEAR(std::hypot(p.x, p.y), std::max(std::abs(a), std::abs(b)), 1e-15);
    r2 += p.x * p.x + p.y * p.y;
    firstQuadrant += p.x > 0 && p.y > 0;
  }
  EXPECT_NEAR(r2 / n, 0.5, 5 * std::sqrt(1.0 / 12 / n));  // r^2 is uniform on [0, 1)
  EXPECT_NEAR(firstQuadrant, n / 4, 5 * std::sqrt(n * 0.25 * 0.75));
  // Square edges and corners land on the circle at the angles the map gives them.
  EXPECT_NEAR(concentricDisc(1, 0.5).x, 1, 1e-16);
  EXPECT_NEAR(concentricDisc(1, 1).x, std::sqrt(0.5), 2e-16);
  EXPECT_NEAR(concentricDisc(1, 1).y, std::sqrt(0.5), 2e-16);
  EXPECT_NEAR(concentricDisc(0.5, 0).y, -1, 1e-16);
  EXPECT_EQ(concentricDisc(0.5, 0.5).x, 0);
}

// The renderer makes a packet's camera samples in one vectorised pass (an
// AVX-512, AVX2 or baseline clone). Each must be, to the bit, what the public
// one-sample formulas give: the sample's stream Sampler(seed, stream) and its
// first four draws, the jittered pixel stratum, the stop stratum through
// concentricDisc, and TelecentricCamera::ray; a stratum of -1 means plain draws.
TEST(CameraSamples, VectorisedPassEqualsOneSampleAtATime) {
  TelecentricCamera cam;
  cam.width = 300, cam.height = 200, cam.pixelPitch_mm = 0.05;
  cam.worldFromCamera = Rigid3::rotation(Vec3(1, 2, 3).normalized(), 0.7);
  cam.worldFromCamera.t = {3, -4, 150};
  const TelecentricCamera::RayMap map(cam);
  const int side = 3;
  const std::uint64_t seed = 42;
  detail::CameraSampleBatch batch;
  for (int k = 0; k < detail::CameraSampleBatch::kSize; ++k) {
    batch.stream[k] = 1000003ull * static_cast<std::uint64_t>(k) + 17;
    batch.pixelX[k] = 37 * k % cam.width, batch.pixelY[k] = 11 * k % cam.height;
    batch.sample[k] = static_cast<std::uint32_t>((7 * k + 3) % 13);  // side^2 = 9: some stratified, some not
    batch.stopKey[k] = 0x9e3779b9u * static_cast<std::uint32_t>(k + 1);
  }
  detail::makeCameraSamples(map, seed, side, detail::CameraSampleBatch::kSize, batch);
  for (int k = 0; k < detail::CameraSampleBatch::kSize; ++k) {
    Sampler sampler(seed, batch.stream[k]);
    double u0, u1, u2, u3;
    sampler.nextPair(u0, u1);
    sampler.nextPair(u2, u3);
    const bool plain = batch.sample[k] >= side * side;
    auto stratified = [&](std::uint32_t s, double u, double v) {
      if (plain) return Vec2(u, v);
      const auto row = static_cast<int>(s) / side, col = static_cast<int>(s) - row * side;
      return Vec2((col + u) * (1.0 / side), (row + v) * (1.0 / side));  // the renderer's jittered stratum
    };
    const std::uint32_t stopStratum = plain ? 0 : permutationElement(batch.sample[k], side * side, batch.stopKey[k]);
    const Vec2 stop = stratified(stopStratum, u2, u3);
    const Ray ray = cam.ray(static_cast<int>(batch.pixelX[k]), static_cast<int>(batch.pixelY[k]),
                            stratified(batch.sample[k], u0, u1), concentricDisc(stop.x, stop.y));
    EXPECT_EQ(batch.ox[k], ray.origin.x) << k;
    EXPECT_EQ(batch.oy[k], ray.origin.y) << k;
    EXPECT_EQ(batch.oz[k], ray.origin.z) << k;
    EXPECT_EQ(batch.dx[k], ray.direction.x) << k;
    EXPECT_EQ(batch.dy[k], ray.direction.y) << k;
    EXPECT_EQ(batch.dz[k], ray.direction.z) << k;
    EXPECT_EQ(batch.state[k], sampler.state) << k;
  }
}

// The light field sensor's samples, made in one vectorised pass, equal to the
// bit the sample stream's first two draws (Sampler::next), the jittered pixel
// stratum and LightFieldSensor::ray, or have no ray where that has none.
TEST(CameraSamples, LightFieldPassEqualsOneSampleAtATime) {
  LightFieldSensor sensor;
  sensor.geometry = {.spatialX = 7, .spatialY = 5, .angular = 9, .pixelPitch_mm = 0.03, .distance_mm = 0};
  sensor.worldFromSensor = Rigid3::translation({1, -2, -30}) * Rigid3::rotation({1, -0.5, 0.2}, 0.4);
  const std::uint64_t seed = 17;
  int withRay = 0, without = 0;
  for (const int side : {1, 3, 4}) {
    std::mt19937 rng(static_cast<unsigned>(side));
    for (int round = 0; round < 40; ++round) {
      detail::CameraSampleBatch batch;
      // Whole batches (as the renderer makes them) and partial ones (a tile's last).
      const int n = round % 2 ? detail::CameraSampleBatch::kSize : 1 + round * 3 % detail::CameraSampleBatch::kSize;
      for (int k = 0; k < n; ++k) {
        batch.stream[k] = rng() * 0x9e3779b97f4a7c15ull + static_cast<std::uint64_t>(k);
        batch.pixelX[k] = rng() % static_cast<unsigned>(sensor.geometry.width());
        batch.pixelY[k] = rng() % static_cast<unsigned>(sensor.geometry.height());
        batch.sample[k] = rng() % static_cast<unsigned>(side * side + 3);  // also past the strata
      }
      const std::uint64_t hasRay = detail::makeLightFieldSamples(sensor, seed, side, n, batch);
      for (int k = 0; k < n; ++k) {
        Sampler sampler(seed, batch.stream[k]);
        const double first = sampler.next();
        Vec2 offset(first, sampler.next());
        if (const auto s = static_cast<int>(batch.sample[k]); s < side * side) {
          const int row = s / side;
          offset = Vec2((s - row * side + offset.x) * (1.0 / side), (row + offset.y) * (1.0 / side));
        }
        const auto ray = sensor.ray(static_cast<int>(batch.pixelX[k]), static_cast<int>(batch.pixelY[k]), offset);
        ASSERT_EQ(hasRay >> k & 1, ray.has_value() ? 1u : 0u) << k;
        EXPECT_EQ(batch.state[k], sampler.state) << k;
        if (!ray) {
          ++without;
          continue;
        }
        ++withRay;
        EXPECT_EQ(Vec3(batch.ox[k], batch.oy[k], batch.oz[k]), ray->origin) << k;
        EXPECT_EQ(Vec3(batch.dx[k], batch.dy[k], batch.dz[k]), ray->direction) << k;
      }
    }
  }
  EXPECT_GT(withRay, 500);
  EXPECT_GT(without, 50);
}

// The stratified Fresnel choices, made in the vectorised pass (the first
// kBatchedChoices) or one at a time (stratifiedChoice, all of them), equal the
// formula of camera_samples.h to the bit, for sample counts with and without
// cycle walking; and each choice's values over a pixel's samples form a Latin
// hypercube (one value in each of the spp strata).
TEST(CameraSamples, StratifiedChoicesAreALatinHypercube) {
  for (const std::uint32_t spp : {1u, 9u, 16u, 13u, 100u, 300u}) {
    std::vector<std::vector<int>> perStratum(detail::kStratifiedChoices, std::vector<int>(spp, 0));
    for (std::uint32_t first = 0; first < spp; first += detail::ChoiceBatch::kSize) {
      detail::ChoiceBatch batch;
      const int n = static_cast<int>(std::min<std::uint32_t>(detail::ChoiceBatch::kSize, spp - first));
      auto key = [](int d) { return 0x2545f491u * static_cast<std::uint32_t>(d + 3); };
      for (int k = 0; k < n; ++k) {
        batch.sample[k] = first + static_cast<std::uint32_t>(k);
        for (int d = 0; d < detail::kBatchedChoices; ++d) batch.key[d][k] = key(d);
      }
      detail::makeStratifiedChoices(spp, n, batch);
      for (int k = 0; k < n; ++k)
        for (int d = 0; d < detail::kStratifiedChoices; ++d) {
          const std::uint32_t s = batch.sample[k];
          const double jitter = Sampler::unitInterval(splitMix64((std::uint64_t{key(d)} << 32) | s));
          const double u = (permutationElement(s, spp, key(d)) + jitter) * (1.0 / spp);
          EXPECT_EQ(detail::stratifiedChoice(spp, s, key(d)), u) << spp << " " << s;
          if (d < detail::kBatchedChoices) {
            EXPECT_EQ(batch.u[d][k], u) << spp << " " << s;
          }
          ASSERT_GE(u, 0);
          ASSERT_LT(u, 1);
          ++perStratum[static_cast<size_t>(d)][static_cast<size_t>(u * spp)];
        }
    }
    for (const auto& counts : perStratum)
      for (const int c : counts) EXPECT_EQ(c, 1) << "spp " << spp;
  }
  // A batch as the renderer fills it: samples of several pixels, each with its own keys.
  std::mt19937 rng(5);
  for (const std::uint32_t spp : {16u, 13u, 300u}) {
    detail::ChoiceBatch batch;
    for (int k = 0; k < detail::ChoiceBatch::kSize; ++k) {
      batch.sample[k] = rng() % spp;
      for (int d = 0; d < detail::kBatchedChoices; ++d) batch.key[d][k] = rng();
    }
    detail::makeStratifiedChoices(spp, detail::ChoiceBatch::kSize, batch);
    for (int k = 0; k < detail::ChoiceBatch::kSize; ++k)
      for (int d = 0; d < detail::kBatchedChoices; ++d)
        EXPECT_EQ(batch.u[d][k], detail::stratifiedChoice(spp, batch.sample[k], batch.key[d][k])) << spp << " " << k;
  }
}

}  // namespace
