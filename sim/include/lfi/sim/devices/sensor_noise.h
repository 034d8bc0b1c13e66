// SPDX-License-Identifier: Apache-2.0
#pragma once
// How CameraSensorModel::capture draws a pixel's noise (camera_sensor_model.h):
// the law is
//   electrons = min(Poisson(m), fullWell) + readNoise * Z,  Z ~ Normal(0, 1)
//   DN        = clamp(round(electrons * scale), 0, 2^bits - 1)
// for a pixel whose mean is m electrons.
//
// Two samplers draw it, chosen per pixel:
//
// * Exact: a Poisson draw (Boost.Random: inversion below a mean of 10,
//   Hörmann's transformed rejection above) plus the normal read noise. About
//   40 ns a pixel: 200 ms for a 5 MP frame on one core.
//
// * Transformed normal: the sum Poisson(m) + readNoise * Z as the Cornish-Fisher
//   expansion of its own cumulants (k1 = m, k2 = m + readNoise^2, k3 = k4 = k5 = m)
//   to third order, applied to one standard normal deviate. The arithmetic is the
//   same on every pixel, so it runs vectorised: a few ns a pixel. It is not the
//   exact law; its error is bounded by computing both laws of DN (the exact one
//   as the Poisson-weighted sum of normal intervals, the transformed one by
//   inverting the expansion) and taking their total variation distance: below
//   1e-4 for every mean, gain and bit depth when readNoise >= 2 e-, and below
//   2e-5 at the default 2.4 e- (tests/sim/sensor_model_test.cpp computes it over
//   a grid). Telling two laws that far apart takes of the order of 1 / TV^2 =
//   1e8 draws at one mean; a 5 MP frame is 5e6. Below 2 e- of read noise the sum's lattice of whole
//   electrons shows through the quantisation and the expansion misses it, so
//   such a sensor draws every pixel exactly.
//
//   Used where           readNoise_e >= kTransformedMinReadNoise_e and the mean
//                        is below the full-well band (fullWell - 8 sqrt(fullWell) - 10):
//                        there the well fills with probability < 1e-15, so the
//                        clip does not matter either.
//   Exact where          the mean is inside the band: the well may fill.
//   Full where           the mean is above the band: the well is full with
//                        probability > 1 - 1e-15, and electrons = fullWell + readNoise * Z
//                        is the law itself.
//
// The normal deviates come from Box-Muller on xoshiro128++ (Blackman and
// Vigna) uniforms, 16 generators side by side: 24-bit radii and 22-bit angles,
// so |Z| <= 5.77 (the normal's mass beyond is 8e-9) — part of the bound above.
// The deviates and the expansion's coefficients are floats (relative precision
// 6e-8: the electrons they give move by less than 1e-3 of a 16-bit DN's width);
// the mean, the electrons and the digital numbers are doubles, so that rounding
// does not move a DN's bounds.

#include <cmath>

namespace lfi::sim {

inline constexpr double kTransformedMinReadNoise_e = 2.0;

// The transformed-normal draw of one pixel: electrons(z) for a standard normal z.
struct ShotReadTransform {
  double mean = 0;                               // m, electrons
  float sd = 0;                                  // sqrt(m + readNoise^2), electrons
  float c0 = 0, c1 = 1, c2 = 0, c3 = 0, c4 = 0;  // the expansion as a polynomial in z

  // For a mean of `mean` electrons (>= 0) and `readNoise` e- rms (> 0).
  static ShotReadTransform at(double mean, double readNoise);
  double electrons(float z) const {
    return mean + static_cast<double>(sd * (c0 + z * (c1 + z * (c2 + z * (c3 + z * c4)))));
  }
};

inline ShotReadTransform ShotReadTransform::at(double mean, double readNoise) {
  // Standardised cumulants of Poisson(m) + N(0, r^2): skewness g1 = m / v^1.5,
  // excess kurtosis g2 = m / v^2, fifth g3 = m / v^2.5, with v = m + r^2.
  const float v = static_cast<float>(mean + readNoise * readNoise), m = static_cast<float>(mean);
  const float invSd = 1 / std::sqrt(v), invV = invSd * invSd;
  const float g1 = m * invV * invSd, g2 = m * invV * invV, g3 = g2 * invSd;
  const float g11 = g1 * g1, g111 = g11 * g1, g12 = g1 * g2;
  // Cornish-Fisher to third order (Abramowitz and Stegun 26.2.49):
  //   x = z + (z^2 - 1) g1/6 + (z^3 - 3z) g2/24 - (2z^3 - 5z) g1^2/36
  //         + (z^4 - 6z^2 + 3) g3/120 - (z^4 - 5z^2 + 2) g1 g2/24 + (12z^4 - 53z^2 + 17) g1^3/324
  ShotReadTransform t;
  t.mean = mean;
  t.sd = v * invSd;
  t.c0 = -g1 / 6 + 3 * g3 / 120 - 2 * g12 / 24 + 17 * g111 / 324;
  t.c1 = 1 - 3 * g2 / 24 + 5 * g11 / 36;
  t.c2 = g1 / 6 - 6 * g3 / 120 + 5 * g12 / 24 - 53 * g111 / 324;
  t.c3 = g2 / 24 - 2 * g11 / 36;
  t.c4 = g3 / 120 - g12 / 24 + 12 * g111 / 324;
  return t;
}

}  // namespace lfi::sim
