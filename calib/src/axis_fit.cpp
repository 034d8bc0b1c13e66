// SPDX-License-Identifier: Apache-2.0
#include "lfi/calib/axis_fit.h"

#include "lfi/core/error.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <complex>
#include <map>
#include <set>

namespace lfi::calib {

namespace {

// Panel pixels from the centre, y up, with the point's weight (mean 1 over the points).
struct Point {
  double x, y, w;
};

// The start's grid is fine enough that the phase moves less than this many cycles from one node to the next over
// the points' extent.
constexpr double kGridPhase = 0.05;

double median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// θ = (tan s, c, P).
struct Axes {
  double t, c, p;
  int index(const Point& q) const { return static_cast<int>(std::lround((q.x - q.y * t - c) / p)); }
  double residual(const Point& q, int m) const { return q.x - (q.y * t + c + m * p); }
};

// The slant and pitch of greatest phase coherence on the grid, and the offset its phase gives.
Axes start(const std::vector<Point>& points, double pitch0, double slant0, const AxisFitSettings& s) {
  double xMin = 1e300, xMax = -1e300, yMax = 0;
  for (const Point& q : points) {
    xMin = std::min(xMin, q.x), xMax = std::max(xMax, q.x);
    yMax = std::max(yMax, std::abs(q.y));
  }
  const double xReach = std::max({std::abs(xMin), std::abs(xMax), 1.0}), yReach = std::max(yMax, 1.0);
  // Phase (x − y t) / P: a step δt moves it by y δt / P, a step δP by x δP / P².
  const double tStep = kGridPhase * pitch0 / yReach, pStep = kGridPhase * pitch0 * pitch0 / xReach;
  const double tLo = std::tan(slant0 - s.searchSlant_rad), tHi = std::tan(slant0 + s.searchSlant_rad);
  Axes best{std::tan(slant0), 0, pitch0};
  // At most this many points (evenly strided) in the search: the start need only name each point's axis.
  const size_t stride = std::max<size_t>(1, points.size() / 4000);
  double bestCoherence = -1;
  for (double p = pitch0 * (1 - s.searchPitch); p <= pitch0 * (1 + s.searchPitch) + 1e-12; p += pStep)
    for (double t = tLo; t <= tHi + 1e-12; t += tStep) {
      std::complex<double> sum(0, 0);
      for (size_t k = 0; k < points.size(); k += stride) {
        const Point& q = points[k];
        sum += q.w * std::polar(1.0, 2 * M_PI * (q.x - q.y * t) / p);
      }
      if (const double coherence = std::abs(sum); coherence > bestCoherence) {
        bestCoherence = coherence;
        best = {t, std::arg(sum) / (2 * M_PI) * p, p};
      }
    }
  return best;
}

struct Solution {
  Axes axes;
  cv::Matx33d covariance;  // the largest of the three (header), per diagonal element
  double rss = 0, weight = 0;
  int axesUsed = 0;
};

Solution solve(const std::vector<Point>& points, const std::vector<int>& index, const std::vector<size_t>& use) {
  cv::Matx33d h = cv::Matx33d::zeros();
  cv::Vec3d hr(0, 0, 0);
  for (size_t k : use) {
    const Point& q = points[k];
    const cv::Vec3d j(q.y, 1, index[k]);
    h += q.w * j * j.t();
    hr += q.w * q.x * j;
  }
  const cv::Matx33d inverse = h.inv(cv::DECOMP_SVD);
  const cv::Vec3d theta = inverse * hr;
  Solution s;
  s.axes = {theta[0], theta[1], theta[2]};
  struct Group {
    cv::Vec3d score{0, 0, 0}, rows{0, 0, 0};
  };
  std::map<int, Group> axes;
  std::map<int, std::set<long>> columns;  // the pixel columns each axis's points lie in
  for (size_t k : use) {
    const Point& q = points[k];
    const cv::Vec3d j(q.y, 1, index[k]);
    const double r = s.axes.residual(q, index[k]);
    s.rss += q.w * r * r;
    s.weight += q.w;
    Group& g = axes[index[k]];
    g.score += q.w * r * j;
    g.rows += q.w * j;
    columns[index[k]].insert(std::lround(std::floor(q.x)));
  }
  // An axis's points share the mean of their quantisation errors: a sawtooth over the N columns the axis crosses,
  // whose whole periods average out; what is left, at most one period's, shared: (1/√12) / N.
  cv::Matx33d meat = cv::Matx33d::zeros(), shared = cv::Matx33d::zeros();
  for (const auto& [m, g] : axes) {
    meat += g.score * g.score.t();
    const double n = static_cast<double>(columns[m].size());
    shared += 1.0 / (n * n) * g.rows * g.rows.t();
  }
  const double n = static_cast<double>(use.size()), groupCount = static_cast<double>(axes.size());
  // The weights have mean 1 over the points: Σ w r² / (n − 3) is the residual variance of a point of mean weight.
  const cv::Matx33d plain = s.rss / std::max(1.0, n - 3) * inverse;
  const cv::Matx33d clustered = groupCount / std::max(1.0, groupCount - 3) * inverse * meat * inverse;
  const cv::Matx33d quantisation = 1.0 / 12 * inverse * shared * inverse;
  s.covariance = plain;
  for (int a = 0; a < 3; ++a) s.covariance(a, a) = std::max({plain(a, a), clustered(a, a), quantisation(a, a)});
  // The sawtooths of all the axes lie alike on the grid: at their ends what is left of them tilts every axis the
  // same way, by up to (1/√12) / N over half the points' height h (an axis along the columns: N = 1, no tilt).
  double columnsPerAxis = 0, yMin = 1e300, yMax = -1e300;
  for (const auto& [m, c] : columns)
    columnsPerAxis += static_cast<double>(c.size()) / static_cast<double>(columns.size());
  for (size_t k : use) yMin = std::min(yMin, points[k].y), yMax = std::max(yMax, points[k].y);
  if (columnsPerAxis >= 2 && yMax > yMin) {
    const double tilt = 1 / std::sqrt(12.0) / columnsPerAxis / (0.5 * (yMax - yMin));
    s.covariance(0, 0) = std::max(s.covariance(0, 0), tilt * tilt);
  }
  s.axesUsed = static_cast<int>(axes.size());
  return s;
}

}  // namespace

int AxisFit::nearestAxis(double xp, double yp) const {
  return static_cast<int>(std::lround((xp - yp * std::tan(slant_rad) - offset_px) / pitch_px));
}

AxisFit fitLensAxes(const std::vector<WeightedPoint>& in, double pixelPitch_mm, double nominalPitch_px,
                    double nominalSlant_rad, const AxisFitSettings& settings) {
  if (!(pixelPitch_mm > 0) || !std::isfinite(pixelPitch_mm))
    fail(Errc::InvalidArgument, "lens axis fit: pixel pitch {} mm must be positive", pixelPitch_mm);
  if (!(nominalPitch_px > 0) || !std::isfinite(nominalPitch_px))
    fail(Errc::InvalidArgument, "lens axis fit: nominal pitch {} px must be positive", nominalPitch_px);
  if (!(std::abs(nominalSlant_rad) < M_PI / 4))
    fail(Errc::InvalidArgument, "lens axis fit: nominal slant {} rad is outside ±π/4", nominalSlant_rad);
  if (!(settings.searchSlant_rad > 0 && settings.searchSlant_rad < 0.2) ||
      !(settings.searchPitch > 0 && settings.searchPitch < 0.2) || settings.minAxes < 3 ||
      !(settings.maxOutlierShare >= 0 && settings.maxOutlierShare < 1))
    fail(Errc::InvalidArgument,
         "lens axis fit: settings out of range (search slant in (0, 0.2) rad, search pitch in (0, 0.2), at least 3 "
         "axes, outlier share in [0, 1))");
  double total = 0;
  for (const WeightedPoint& p : in) {
    if (!(p.weight > 0) || !std::isfinite(p.weight) || !std::isfinite(p.position_mm.x) ||
        !std::isfinite(p.position_mm.y))
      fail(Errc::InvalidArgument, "lens axis fit: a point's position and weight must be finite, its weight positive");
    total += p.weight;
  }
  const auto tooFew = [&](int axes) {
    fail(Errc::Device,
         "lens axis fit: the panel points found lie on {} lens axes, fewer than {}: too little of the display in "
         "view, or what was found are not lens axes",
         axes, settings.minAxes);
  };
  if (in.empty()) tooFew(0);
  std::vector<Point> points;
  const double meanWeight = total / static_cast<double>(in.size());
  for (const WeightedPoint& p : in)
    points.push_back({p.position_mm.x / pixelPitch_mm, p.position_mm.y / pixelPitch_mm, p.weight / meanWeight});

  Axes axes = start(points, nominalPitch_px, nominalSlant_rad, settings);
  std::vector<int> index(points.size());
  std::vector<size_t> kept;
  double limit = 0.25 * axes.p;
  Solution solution;
  for (int round = 0; round < 10; ++round) {
    std::vector<size_t> use;
    for (size_t k = 0; k < points.size(); ++k) {
      index[k] = axes.index(points[k]);
      if (std::abs(axes.residual(points[k], index[k])) <= std::min(limit, 0.25 * axes.p)) use.push_back(k);
    }
    std::map<int, int> perAxis;
    for (size_t k : use) ++perAxis[index[k]];
    if (static_cast<int>(perAxis.size()) < settings.minAxes) tooFew(static_cast<int>(perAxis.size()));
    solution = solve(points, index, use);
    axes = solution.axes;
    std::vector<double> residuals;
    for (size_t k : use) residuals.push_back(std::abs(axes.residual(points[k], index[k])));
    limit = std::max(5 * 1.4826 * median(residuals), 0.5);
    if (use == kept) break;
    kept = std::move(use);
  }
  double keptWeight = 0;
  for (size_t k : kept) keptWeight += points[k].w;
  const double outlierShare = 1 - keptWeight / static_cast<double>(points.size());
  if (outlierShare > settings.maxOutlierShare)
    fail(Errc::Device,
         "lens axis fit: {:.0f} % of the light found lies off the best lens axes (more than {:.0f} %): the "
         "residual is too large for the model (a part in view, another slant or pitch than the stated ones)",
         100 * outlierShare, 100 * settings.maxOutlierShare);

  AxisFit fit;
  const double t = axes.t;
  fit.slant_rad = std::atan(t);
  fit.pitch_px = axes.p;
  // The axes' own errors: each axis's mean residual. They are not independent (a slit's edges step through the
  // pixels' phase from one axis to the next), so the offset is known no better than their RMS, and the pitch no
  // better than that over half the span of the axes.
  std::map<int, std::pair<double, double>> perAxis;  // Σ w r, Σ w
  for (size_t k : kept) {
    auto& [sum, weight] = perAxis[index[k]];
    sum += points[k].w * axes.residual(points[k], index[k]);
    weight += points[k].w;
  }
  double axisRms = 0;
  for (const auto& [m, sw] : perAxis)
    axisRms += std::pow(sw.first / sw.second, 2) / static_cast<double>(perAxis.size());
  axisRms = std::sqrt(axisRms);
  const double halfSpan = 0.5 * (perAxis.rbegin()->first - perAxis.begin()->first);
  solution.covariance(1, 1) = std::max(solution.covariance(1, 1), axisRms * axisRms);
  solution.covariance(2, 2) = std::max(solution.covariance(2, 2), std::pow(axisRms / halfSpan, 2));
  const double shift = std::round(axes.c / axes.p);  // axis 0 → the axis nearest the centre
  fit.offset_px = axes.c - shift * axes.p;
  fit.slantSigma_rad = std::sqrt(solution.covariance(0, 0)) / (1 + t * t);
  fit.offsetSigma_px = std::sqrt(solution.covariance(1, 1) + shift * shift * solution.covariance(2, 2));
  fit.pitchSigma_px = std::sqrt(solution.covariance(2, 2));
  fit.residualRms_px = std::sqrt(solution.rss / std::max(solution.weight, 1e-300));
  fit.points = static_cast<int>(kept.size());
  fit.outliers = static_cast<int>(points.size() - kept.size());
  fit.axes = solution.axesUsed;
  return fit;
}

}  // namespace lfi::calib
