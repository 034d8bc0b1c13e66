// SPDX-License-Identifier: Apache-2.0
#pragma once
// The other side of a calibration uncertainty's coverage, shared by the unit
// tests of the fits and the tests on the ray-traced bench: normalised errors
// pooled into a chi-square and held above its lower 10⁻³ quantile.

#include <cmath>

namespace lfi::testing_support {

// The other side of an uncertainty's coverage: the errors not much smaller than the stated standard uncertainty
// σ = U / k says. Normalised errors z = error / σ pooled over independent quantities and benches: where σ is right
// and the errors normal, Σ z² is chi-square with n degrees of freedom.
struct NormalisedErrors {
  double sum2 = 0;
  int n = 0;
  void add(double error, double sigma) {
    sum2 += (error / sigma) * (error / sigma);
    ++n;
  }
  double rms() const { return std::sqrt(sum2 / n); }
};

// Chi-square's lower 10⁻³ quantile for `dof` degrees of freedom, by Wilson-Hilferty (Φ⁻¹(10⁻³) = −3.0902): from
// 20 to 200 degrees of freedom it lies below the exact one by less than 0.1, which makes a false failure slightly
// rarer still.
inline double chiSquareLower1e3(int dof) {
  const double w = 2.0 / (9 * dof);
  return dof * std::pow(1 - w - 3.0902 * std::sqrt(w), 3);
}

// How much larger than the true variance a stated σ² is, at most on average, when it is the largest of an honest
// estimate with `nu` degrees of freedom (a residuals' or a bootstrap's, relative spread √(2/ν)) and terms that do
// not exceed the truth: 1 + E[δ⁺] for δ ~ N(0, 2/ν), 1 + 1/√(πν). A pooled Σ z² is held to the chi-square quantile
// over this: a Monte Carlo of Σ xᵢ / max(1, yᵢ/ν), x ~ χ²₁, y ~ χ²_ν, finds 0.85 10⁻³ below it for n = 28,
// ν = 38 and 0.92 10⁻³ for n = 20, ν = 99 (3 10⁵ draws each).
inline double maxOfEstimatesInflation(double nu) {
  return 1 + 1 / std::sqrt(M_PI * nu);
}

}  // namespace lfi::testing_support
