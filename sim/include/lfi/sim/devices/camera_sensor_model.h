// SPDX-License-Identifier: Apache-2.0
#pragma once
// The camera's sensor: radiance in, digital numbers out. One model for the
// whole stack (the study and the simulated camera backend use it).
//
//   parameter        units      meaning (defaults: a Sony IMX264-class CMOS)
//   fullWell_e       e-         saturation capacity (10 500 e-)
//   readNoise_e      e- rms     temporal read noise (2.4 e-)
//   bitDepth         bits       ADC resolution (12)
//   electronsPerUnit e- / unit  exposure x quantum efficiency x pixel etendue: electrons
//                               collected per unit of relative radiance
//   gain             -          digital gain applied before quantisation (1 = full well
//                               maps to full scale)
//   offset_dn        DN         per-pixel offset added before quantisation (black level
//                               and dark signal non-uniformity: sensorPattern()); CV_32FC1
//                               of the radiance's size, empty: 0
// signal_e ~ Poisson(electronsPerUnit * L) + Normal(0, readNoise_e);
// DN = clamp(round(gain * signal_e / fullWell_e * (2^bits - 1) + offset_dn), 0, 2^bits - 1),
// with the Poisson draw clipped at the full well. How capture() draws that law
// fast, and how close: sensor_noise.h.

#include <opencv2/core.hpp>

#include <cstdint>

namespace lfi::sim {

struct CameraSensorModel {
  double fullWell_e = 10500;
  double readNoise_e = 2.4;
  int bitDepth = 12;
  double electronsPerUnit = 1000;
  double gain = 1;
  cv::Mat offset_dn;

  int maxDigitalNumber() const { return (1 << bitDepth) - 1; }
  // Sets electronsPerUnit so that radiance `brightest` fills `fraction` of the well.
  void exposeFor(double brightest, double fraction = 0.7);
  // CV_32FC1 radiance -> CV_16UC1 digital numbers, with a reproducible noise draw
  // (the same for any number of worker threads; 0 = all cores). Errc::InvalidArgument
  // when offset_dn is neither empty nor CV_32FC1 of the radiance's size.
  cv::Mat capture(const cv::Mat& radiance, std::uint64_t seed, int threads = 0) const;
  // Expected noise (DN rms) of a pixel whose mean signal is `dn` DN.
  double noiseDn(double dn) const;
  void validate() const;
};

}  // namespace lfi::sim
