// SPDX-License-Identifier: Apache-2.0
#include "lfi/sim/devices/camera_sensor_model.h"

#include "lfi/core/error.h"
#include "lfi/core/image.h"

#include "../parallel_for.h"

#include <boost/random/normal_distribution.hpp>
#include <boost/random/poisson_distribution.hpp>

#include <algorithm>
#include <cmath>
#include <random>

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

cv::Mat CameraSensorModel::capture(const cv::Mat& radiance, std::uint64_t seed, int threads) const {
  validate();
  requireImageType(radiance, CV_32FC1, "radiance image for the camera sensor");
  cv::Mat out(radiance.size(), CV_16UC1);
  const double scale = gain / fullWell_e * maxDigitalNumber();
  const double maxDn = maxDigitalNumber();
  // Rows in parallel: each has its own engine, so the result does not depend on the threads.
  auto row = [&](int r) {
    // One engine per row keyed by (seed, row): reproducible and independent of image width.
    std::mt19937_64 engine(seed * 0x9e3779b97f4a7c15ull + static_cast<std::uint64_t>(r));
    // Boost.Random's samplers: its Poisson distribution (inversion below a mean
    // of 10, Hörmann's transformed rejection above) sets up in a few operations,
    // so one per pixel costs little; the standard library's set-up took twice its
    // draw (lfi-frame-bench).
    boost::random::normal_distribution<double> read(0.0, readNoise_e > 0 ? readNoise_e : 1.0);  // (sigma > 0)
    // Far past the full well the draw is the full well: no draw (a mean past 2^63 electrons would not fit one).
    const double surelyFull = fullWell_e + 20 * std::sqrt(fullWell_e) + 100;
    const float* in = radiance.ptr<float>(r);
    auto* o = out.ptr<std::uint16_t>(r);
    for (int c = 0; c < radiance.cols; ++c) {
      const double mean = std::max(0.0, static_cast<double>(in[c])) * electronsPerUnit;
      double electrons = fullWell_e;
      if (mean < surelyFull) {
        electrons = 0;  // (the sampler needs a mean > 0)
        if (mean > 0) {
          boost::random::poisson_distribution<long long, double> shot(mean);
          electrons = std::min(static_cast<double>(shot(engine)), fullWell_e);
        }
      }
      if (readNoise_e > 0) electrons += read(engine);
      o[c] = static_cast<std::uint16_t>(std::clamp(std::round(electrons * scale), 0.0, maxDn));
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
