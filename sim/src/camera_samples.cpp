#include "camera_samples.h"

#include "lfi/sim/render.h"

#include "simd.h"

#include <cmath>

namespace lfi::sim::detail {

LFI_SIMD_CLONES void makeCameraSamples(const TelecentricCamera::RayMap& camera, std::uint64_t seed, int side, int n,
                                       CameraSampleBatch& b) {
  constexpr std::uint64_t kGolden = 0x9e3779b97f4a7c15ull;  // Sampler's increment
  const std::uint64_t seedHash = splitMix64(seed);
  const double invSide = 1.0 / side;
  // The stop strata: the permutation's first round for every sample at once,
  // then the few that must walk on (none when side^2 is a power of two).
  const auto strata = static_cast<std::uint32_t>(side * side), mask = permutationMask(strata);
  std::uint32_t stop[CameraSampleBatch::kSize];
  for (int k = 0; k < n; ++k)  // (unstratified samples permute 0, for a walk that ends)
    stop[k] = permutationRound(b.sample[k] < strata ? b.sample[k] : 0, mask, b.stopKey[k]);
  for (int k = 0; k < n; ++k) {
    while (stop[k] >= strata) stop[k] = permutationRound(stop[k], mask, b.stopKey[k]);
    stop[k] = permutationRotation(stop[k], strata, mask, b.stopKey[k]);
  }
  for (int k = 0; k < n; ++k) {
    // Sampler(seed, stream) and its first four draws.
    const std::uint64_t state = splitMix64(b.stream[k] ^ seedHash);
    const double u0 = Sampler::unitInterval(splitMix64(state)), u1 = Sampler::unitInterval(splitMix64(state + kGolden));
    const double u2 = Sampler::unitInterval(splitMix64(state + 2 * kGolden));
    const double u3 = Sampler::unitInterval(splitMix64(state + 3 * kGolden));
    b.state[k] = state + 4 * kGolden;
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
    camera.trace(b.pixelX[k] + jx, b.pixelY[k] + jy, ax, ay, b.ox[k], b.oy[k], b.oz[k], b.dx[k], b.dy[k], b.dz[k]);
  }
}

LFI_SIMD_CLONES void makeStratifiedChoices(std::uint32_t spp, int n, ChoiceBatch& b) {
  // As permutationElement: the first round for every lane at once, then the
  // lanes that must walk on (none when spp is a power of two).
  const std::uint32_t mask = permutationMask(spp);
  const double stratumWidth = 1.0 / spp;
  for (int d = 0; d < kStratifiedChoices; ++d) {
    std::uint32_t stratum[ChoiceBatch::kSize];
    for (int k = 0; k < n; ++k) stratum[k] = permutationRound(b.sample[k], mask, b.key[d][k]);
    for (int k = 0; k < n; ++k) {
      while (stratum[k] >= spp) stratum[k] = permutationRound(stratum[k], mask, b.key[d][k]);
      stratum[k] = permutationRotation(stratum[k], spp, mask, b.key[d][k]);
    }
    for (int k = 0; k < n; ++k) {
      const double jitter = Sampler::unitInterval(splitMix64((std::uint64_t{b.key[d][k]} << 32) | b.sample[k]));
      b.u[d][k] = (stratum[k] + jitter) * stratumWidth;
    }
  }
}

}  // namespace lfi::sim::detail
