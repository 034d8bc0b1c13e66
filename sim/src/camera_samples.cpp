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
  const double* r = camera.world.r.data();
  const Vec3 t = camera.world.t;
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
    stratify(b.areaStratum[k], u0, u1, jx, jy);
    stratify(b.stopStratum[k], u2, u3, su, sv);
    concentricDisc(su, sv, ax, ay);
    // TelecentricCamera::RayMap, lane by lane.
    const double cx = camera.pixel * (b.pixelX[k] + jx - camera.halfW) + camera.stop * ax;
    const double cy = camera.pixel * (b.pixelY[k] + jy - camera.halfH) + camera.stop * ay;
    const double dx = -camera.slope * ax, dy = -camera.slope * ay, inv = 1 / std::sqrt(1 + dx * dx + dy * dy);
    const double ex = dx * inv, ey = dy * inv;
    b.ox[k] = r[0] * cx + r[1] * cy + t.x;
    b.oy[k] = r[3] * cx + r[4] * cy + t.y;
    b.oz[k] = r[6] * cx + r[7] * cy + t.z;
    b.dx[k] = r[0] * ex + r[1] * ey + r[2] * inv;
    b.dy[k] = r[3] * ex + r[4] * ey + r[5] * inv;
    b.dz[k] = r[6] * ex + r[7] * ey + r[8] * inv;
  }
}

}  // namespace lfi::sim::detail
