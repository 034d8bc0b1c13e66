// SPDX-License-Identifier: Apache-2.0
#include "lfi/sim/devices/camera_sensor_model.h"

#include "lfi/core/error.h"
#include "lfi/core/image.h"

#include "lfi/sim/devices/sensor_noise.h"
#include "lfi/sim/render.h"

#include "../parallel_for.h"
#include "../tracer/simd.h"

#include <boost/random/poisson_distribution.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

namespace lfi::sim {

void CameraSensorModel::validate() const {
  // (At most 1e12 e-: a draw's mean past 2^63 electrons would not fit the sampler's integer.)
  if (!(fullWell_e > 0 && fullWell_e <= 1e12))
    fail(Errc::InvalidArgument, "camera sensor: fullWell_e = {} is outside (0, 1e12]", fullWell_e);
  if (!(readNoise_e >= 0 && std::isfinite(readNoise_e)))
    fail(Errc::InvalidArgument, "camera sensor: readNoise_e = {} must be finite and >= 0", readNoise_e);
  if (bitDepth < 8 || bitDepth > 16)
    fail(Errc::InvalidArgument, "camera sensor: bitDepth = {} is outside [8, 16]", bitDepth);
  if (!(electronsPerUnit > 0 && std::isfinite(electronsPerUnit)))
    fail(Errc::InvalidArgument, "camera sensor: electronsPerUnit = {} must be finite and > 0", electronsPerUnit);
  if (!(gain > 0 && std::isfinite(gain)))
    fail(Errc::InvalidArgument, "camera sensor: gain = {} must be finite and > 0", gain);
}

void CameraSensorModel::exposeFor(double brightest, double fraction) {
  if (!(brightest > 0)) fail(Errc::InvalidArgument, "camera sensor: cannot expose for a black image");
  electronsPerUnit = fraction * fullWell_e / (gain * brightest);
}

namespace {

// ---- standard normal deviates, 16 lanes at a time --------------------------

constexpr int kLanes = 16;

std::uint32_t rotl32(std::uint32_t x, int k) {
  return (x << k) | (x >> (32 - k));
}

// xoshiro128++ (Blackman and Vigna, 2018) in kLanes independent generators,
// stored lane by lane so that one step of all of them is a vector operation.
struct UniformLanes {
  alignas(64) std::uint32_t s0[kLanes], s1[kLanes], s2[kLanes], s3[kLanes];

  explicit UniformLanes(std::uint64_t seed) {
    // Each lane's 128 bits of state from SplitMix64's sequence (never all zero:
    // SplitMix64 is a bijection of a counter that does not repeat here).
    std::uint64_t x = seed;
    for (int l = 0; l < kLanes; ++l) {
      const std::uint64_t a = splitMix64(x += 0x9e3779b97f4a7c15ull), b = splitMix64(x += 0x9e3779b97f4a7c15ull);
      s0[l] = static_cast<std::uint32_t>(a), s1[l] = static_cast<std::uint32_t>(a >> 32);
      s2[l] = static_cast<std::uint32_t>(b), s3[l] = static_cast<std::uint32_t>(b >> 32);
    }
  }

  void next(std::uint32_t* __restrict out) {
    for (int l = 0; l < kLanes; ++l) {
      out[l] = rotl32(s0[l] + s3[l], 7) + s0[l];
      const std::uint32_t t = s1[l] << 9;
      s2[l] ^= s0[l];
      s3[l] ^= s1[l];
      s1[l] ^= s2[l];
      s0[l] ^= s3[l];
      s2[l] ^= t;
      s3[l] = rotl32(s3[l], 11);
    }
  }
};

// ln(x) for x in (0, 1] to float precision, with arithmetic only (so that it
// vectorises): x = m 2^e with m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh(s) with
// s = (m - 1) / (m + 1), |s| <= 0.172, its series to s^9 (next term 2e-9).
float logUnit(float x) {
  const auto bits = std::bit_cast<std::int32_t>(x);
  int e = (bits >> 23) - 127;
  float m = std::bit_cast<float>((bits & 0x7fffff) | 0x3f800000);  // [1, 2)
  const bool high = m > 1.41421356f;
  m = high ? 0.5f * m : m;
  e = high ? e + 1 : e;
  const float s = (m - 1) / (m + 1), s2 = s * s;
  const float atanh = s * (1 + s2 * (1.0f / 3 + s2 * (1.0f / 5 + s2 * (1.0f / 7 + s2 * (1.0f / 9)))));
  return static_cast<float>(e) * 0.693147181f + 2 * atanh;
}

// 2 kLanes standard normal deviates a block (Box-Muller): radius from 24 bits
// of one uniform (u in (0, 1]: |z| <= sqrt(-2 ln 2^-24) = 5.77), angle from
// the quadrant in 2 bits of the other and 22 bits inside it, where sine and
// cosine are their Taylor series on (-pi/4, pi/4) (next terms < 3e-9).
LFI_SIMD_CLONES void standardNormals(UniformLanes& uniforms, float* __restrict z, int blocks) {
  alignas(64) std::uint32_t a[kLanes], b[kLanes];
  for (int block = 0; block < blocks; ++block, z += 2 * kLanes) {
    uniforms.next(a);
    uniforms.next(b);
    for (int l = 0; l < kLanes; ++l) {
      const float u = static_cast<float>(static_cast<std::int32_t>(a[l] >> 8) + 1) * 0x1p-24f;
      const float r = std::sqrt(-2 * logUnit(u));
      const float phi = (static_cast<float>(static_cast<std::int32_t>(b[l] & 0x3fffff)) + 0.5f) *
                            (0.5f * std::numbers::pi_v<float> * 0x1p-22f) -
                        0.25f * std::numbers::pi_v<float>;
      const float p2 = phi * phi;
      const float sinPhi =
          phi * (1 + p2 * (-1.0f / 6 + p2 * (1.0f / 120 + p2 * (-1.0f / 5040 + p2 * (1.0f / 362880)))));
      const float cosPhi =
          1 + p2 * (-0.5f + p2 * (1.0f / 24 + p2 * (-1.0f / 720 + p2 * (1.0f / 40320 + p2 * (-1.0f / 3628800)))));
      const std::uint32_t quadrant = b[l] >> 30;  // the angle is quadrant * pi/2 + pi/4 + phi
      const float c = quadrant == 0 ? cosPhi : quadrant == 1 ? -sinPhi : quadrant == 2 ? -cosPhi : sinPhi;
      const float s = quadrant == 0 ? sinPhi : quadrant == 1 ? cosPhi : quadrant == 2 ? -sinPhi : -cosPhi;
      z[l] = r * c;
      z[kLanes + l] = r * s;
    }
  }
}

// ---- one row ----------------------------------------------------------------

struct RowConstants {
  double electronsPerUnit, readNoise, fullWell, scale, maxDn;
  double bandFrom, fullFrom;  // the full-well band [bandFrom, fullFrom) of means (sensor_noise.h)
  bool transformed;           // readNoise >= kTransformedMinReadNoise_e
};

// Digital numbers of a row from its radiance and its normal deviates, by the
// transformed normal or, above the band, the full well; `exact` marks the
// pixels the exact sampler must draw instead.
LFI_SIMD_CLONES void transformedRow(const float* __restrict radiance, const float* __restrict z,
                                    const float* __restrict offset, std::uint16_t* __restrict out,
                                    std::uint8_t* __restrict exact, int n, const RowConstants& k) {
  const std::uint8_t allExact = k.transformed ? 0 : 1;
  for (int i = 0; i < n; ++i) {
    const double in = radiance[i];
    const float zi = z[i];
    const double mean = std::min(std::max(0.0, in * k.electronsPerUnit), k.fullFrom);  // (NaN: 0)
    const ShotReadTransform t = ShotReadTransform::at(mean, k.readNoise);
    const double full = k.fullWell + k.readNoise * zi;
    const double electrons = mean >= k.fullFrom ? full : t.electrons(zi);
    exact[i] = allExact | static_cast<std::uint8_t>((mean >= k.bandFrom) & (mean < k.fullFrom));
    const double dn = std::min(std::max(electrons * k.scale + offset[i], 0.0), k.maxDn);
    out[i] = static_cast<std::uint16_t>(static_cast<std::int32_t>(dn + 0.5));
  }
}

}  // namespace

cv::Mat CameraSensorModel::capture(const cv::Mat& radiance, std::uint64_t seed, int threads) const {
  validate();
  requireImageType(radiance, CV_32FC1, "radiance image for the camera sensor");
  if (!offset_dn.empty() && (offset_dn.type() != CV_32FC1 || offset_dn.size() != radiance.size()))
    fail(Errc::InvalidArgument, "camera sensor: offset_dn is {} x {} of type {}, the radiance {} x {} (CV_32FC1)",
         offset_dn.cols, offset_dn.rows, offset_dn.type(), radiance.cols, radiance.rows);
  const std::vector<float> noOffset(offset_dn.empty() ? static_cast<std::size_t>(radiance.cols) : 0, 0.0f);
  cv::Mat out(radiance.size(), CV_16UC1);
  const double scale = gain / fullWell_e * maxDigitalNumber();
  const double maxDn = maxDigitalNumber();
  const double margin = 8 * std::sqrt(fullWell_e) + 10;  // P(Poisson crosses the well) < 1e-15 outside it
  const RowConstants k{
      .electronsPerUnit = electronsPerUnit,
      .readNoise = readNoise_e,
      .fullWell = fullWell_e,
      .scale = scale,
      .maxDn = maxDn,
      .bandFrom = std::max(0.0, fullWell_e - margin),
      .fullFrom = fullWell_e + margin,
      .transformed = readNoise_e >= kTransformedMinReadNoise_e,
  };
  const int width = radiance.cols, blocks = (width + 2 * kLanes - 1) / (2 * kLanes);
  // Rows in parallel, each with its own generators keyed by (seed, row): the
  // result depends on neither the threads nor the image's width.
  auto row = [&](int r) {
    const std::uint64_t rowSeed = splitMix64(seed ^ splitMix64(static_cast<std::uint64_t>(r) + 1));
    UniformLanes uniforms(rowSeed);
    std::vector<float> z(static_cast<std::size_t>(blocks) * 2 * kLanes);
    std::vector<std::uint8_t> exact(static_cast<std::size_t>(width));
    standardNormals(uniforms, z.data(), blocks);
    const float* in = radiance.ptr<float>(r);
    const float* offset = offset_dn.empty() ? noOffset.data() : offset_dn.ptr<float>(r);
    auto* o = out.ptr<std::uint16_t>(r);
    transformedRow(in, z.data(), offset, o, exact.data(), width, k);
    // The exact sampler for the marked pixels (its own engine, made when first needed).
    std::optional<std::mt19937_64> engine;
    for (int c = 0; c < width; ++c) {
      if (!exact[static_cast<std::size_t>(c)]) continue;
      if (!engine) engine.emplace(splitMix64(rowSeed ^ 0x5851f42d4c957f2dull));
      const double mean = std::max(0.0, static_cast<double>(in[c])) * electronsPerUnit;
      double electrons = fullWell_e;
      if (mean < k.fullFrom) {
        electrons = 0;  // (the sampler needs a mean > 0)
        if (mean > 0) {
          // Boost.Random's Poisson: inversion below a mean of 10, Hörmann's transformed rejection above.
          boost::random::poisson_distribution<long long, double> shot(mean);
          electrons = std::min(static_cast<double>(shot(*engine)), fullWell_e);
        }
      }
      electrons += readNoise_e * z[static_cast<std::size_t>(c)];
      o[c] = static_cast<std::uint16_t>(std::clamp(std::round(electrons * scale + offset[c]), 0.0, maxDn));
    }
  };
  detail::parallelFor(radiance.rows, threads, row);
  return out;
}

double CameraSensorModel::noiseDn(double dn) const {
  const double scale = gain / fullWell_e * maxDigitalNumber();
  const double electrons = std::max(0.0, dn / scale);
  // Shot and read noise, plus the uniform quantisation error (1/12 DN^2).
  return std::sqrt((electrons + readNoise_e * readNoise_e) * scale * scale + 1.0 / 12);
}

}  // namespace lfi::sim
