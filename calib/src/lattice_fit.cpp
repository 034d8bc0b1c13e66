// SPDX-License-Identifier: Apache-2.0
#include "lfi/calib/lattice_fit.h"

#include "lfi/core/error.h"
#include "lfi/drivers/optics/lens_lattice.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <set>
#include <tuple>
#include <unordered_map>

namespace lfi::calib {

namespace {

// The starting lattice's pitch and angle come from neighbour vectors quantised to the panel's pixels (a 1 mm
// pitch on 0.0315 mm pixels: to 3 %, and to 0.03 rad): within this many pitches of its origin it still names each
// centre's lens.
constexpr double kStartReach = 5;
constexpr double kRowHeight = 0.86602540378443864676;  // √3 / 2: a hexagonal lattice's row spacing per pitch

// Points in square buckets of a given side, for neighbour searches.
class Buckets {
 public:
  Buckets(const std::vector<Vec2>& points, double side) : side_(side) {
    for (size_t k = 0; k < points.size(); ++k) cells_[key(cell(points[k].x), cell(points[k].y))].push_back(k);
  }
  // Calls f(k) for every point in the 3 × 3 buckets around p.
  template <typename F>
  void near(const Vec2& p, F&& f) const {
    const long cx = cell(p.x), cy = cell(p.y);
    for (long dy = -1; dy <= 1; ++dy)
      for (long dx = -1; dx <= 1; ++dx)
        if (auto it = cells_.find(key(cx + dx, cy + dy)); it != cells_.end())
          for (size_t k : it->second) f(k);
  }

 private:
  long cell(double v) const { return static_cast<long>(std::floor(v / side_)); }
  static long long key(long x, long y) { return (static_cast<long long>(x) << 32) ^ (y & 0xffffffffLL); }
  double side_;
  std::unordered_map<long long, std::vector<size_t>> cells_;
};

size_t findRoot(std::vector<size_t>& parent, size_t k) {
  while (parent[k] != k) k = parent[k] = parent[parent[k]];
  return k;
}

double median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The lattice's unit coordinates of index (i, j).
Vec2 unitPoint(LensPacking packing, double i, double j) {
  return packing == LensPacking::Square ? Vec2(i, j) : Vec2(i + 0.5 * j, kRowHeight * j);
}

// A lattice c = o + M L, M = [[a, -b], [b, a]].
struct Lattice {
  LensPacking packing;
  Vec2 o;
  double a, b;

  Vec2 point(int i, int j) const {
    const Vec2 l = unitPoint(packing, i, j);
    return {o.x + a * l.x - b * l.y, o.y + b * l.x + a * l.y};
  }
  // The index of the lattice point nearest `p`: the lens whose cell (optics/lens_lattice.h) holds it.
  std::array<int, 2> nearest(const Vec2& p) const {
    const double p2 = a * a + b * b;
    const Vec2 r = LensLattice(packing, std::sqrt(p2), std::atan2(b, a), o).nearestCentre(p) - o;
    const Vec2 v((a * r.x + b * r.y) / p2, (-b * r.x + a * r.y) / p2);  // M⁻¹ r: the unit coordinates
    const double j = packing == LensPacking::Square ? v.y : v.y / kRowHeight;
    const double i = packing == LensPacking::Square ? v.x : v.x - 0.5 * j;
    return {static_cast<int>(std::lround(i)), static_cast<int>(std::lround(j))};
  }
};

double symmetryAngle(LensPacking packing) {
  return packing == LensPacking::Square ? M_PI / 2 : M_PI / 3;
}

// The starting lattice from the vectors between neighbouring centres.
Lattice startingLattice(const std::vector<Vec2>& c, LensPacking packing, double pitch0, double rotation0) {
  const Buckets buckets(c, pitch0);
  const double sym = symmetryAngle(packing);
  std::vector<double> lengths, angles;
  for (size_t k = 0; k < c.size(); ++k)
    buckets.near(c[k], [&](size_t m) {
      if (m <= k) return;
      const Vec2 d = c[m] - c[k];
      const double length = d.length();
      if (length < 0.7 * pitch0 || length > 1.3 * pitch0) return;
      lengths.push_back(length);
      angles.push_back(rotation0 + std::remainder(std::atan2(d.y, d.x) - rotation0, sym));
    });
  if (lengths.empty())
    fail(Errc::Device,
         "lens array fit: no two of the {} lens centres found are neighbours at about the nominal "
         "pitch of {} mm (0.7 .. 1.3 of it): the display's pitch is far from its nominal one, or what was found "
         "are not lens centres",
         c.size(), pitch0);
  const double pitch = median(lengths), rotation = median(angles);
  // The origin: the centre nearest the centres' mean.
  Vec2 mean(0, 0);
  for (const Vec2& p : c) mean += p;
  mean /= static_cast<double>(c.size());
  const Vec2 origin = *std::min_element(
      c.begin(), c.end(), [&](const Vec2& p, const Vec2& q) { return (p - mean).length2() < (q - mean).length2(); });
  return {packing, origin, pitch * std::cos(rotation), pitch * std::sin(rotation)};
}

struct Solution {
  Lattice lattice;
  cv::Matx44d covariance;    // of (o_x, o_y, a, b), clustered
  cv::Matx44d quantisation;  // the same from a shared error of one quantum's σ per column and per row
  cv::Matx44d inverse;       // (JᵀJ)⁻¹
  double rss = 0;
};

// Least squares over the centres `use` with their indices, and the covariance clustered by lattice column (x)
// and row (y).
Solution solve(LensPacking packing, const std::vector<Vec2>& c, const std::vector<std::array<int, 2>>& index,
               const std::vector<size_t>& use, double quantum) {
  cv::Matx44d jtj = cv::Matx44d::zeros();
  cv::Vec4d jtr(0, 0, 0, 0);
  for (size_t k : use) {
    const Vec2 l = unitPoint(packing, index[k][0], index[k][1]);
    const cv::Vec4d rx(1, 0, l.x, -l.y), ry(0, 1, l.y, l.x);
    jtj += rx * rx.t() + ry * ry.t();
    jtr += rx * c[k].x + ry * c[k].y;
  }
  cv::Matx44d inverse;
  if (cv::invert(jtj, inverse, cv::DECOMP_SVD) <= 0) fail(Errc::Device, "lens array fit: the centres are degenerate");
  const cv::Vec4d x = inverse * jtr;
  Solution s{{packing, {x[0], x[1]}, x[2], x[3]}, cv::Matx44d::zeros(), cv::Matx44d::zeros(), inverse, 0};
  // Each group's score Σ Jᵀ r: x residuals by the lattice column a centre is in (half-pitch columns of a
  // hexagonal lattice), y residuals by its row.
  std::map<std::pair<int, int>, std::pair<cv::Vec4d, cv::Vec4d>> groups;  // Σ Jᵀ r and Σ Jᵀ
  for (size_t k : use) {
    const Vec2 l = unitPoint(packing, index[k][0], index[k][1]);
    const Vec2 r = c[k] - s.lattice.point(index[k][0], index[k][1]);
    s.rss += r.length2();
    const int column = packing == LensPacking::Square ? index[k][0] : 2 * index[k][0] + index[k][1];
    const cv::Vec4d jx(1, 0, l.x, -l.y), jy(0, 1, l.y, l.x);
    auto& gx = groups.try_emplace({0, column}).first->second;
    gx.first += jx * r.x;
    gx.second += jx;
    auto& gy = groups.try_emplace({1, index[k][1]}).first->second;
    gy.first += jy * r.y;
    gy.second += jy;
  }
  cv::Matx44d meat = cv::Matx44d::zeros(), shared = cv::Matx44d::zeros();
  for (const auto& [group, sums] : groups) {
    meat += sums.first * sums.first.t();
    shared += sums.second * sums.second.t();
  }
  const double n = static_cast<double>(groups.size());
  s.covariance = n / std::max(1.0, n - 2) * inverse * meat * inverse;
  s.quantisation = quantum * quantum / 12 * inverse * shared * inverse;
  return s;
}

}  // namespace

std::vector<WeightedPoint> clusterPoints(const std::vector<WeightedPoint>& points, double radius_mm) {
  if (!(radius_mm > 0) || !std::isfinite(radius_mm))
    fail(Errc::InvalidArgument, "clusterPoints: radius {} mm must be finite and positive", radius_mm);
  std::vector<Vec2> p;
  p.reserve(points.size());
  for (const WeightedPoint& w : points) {
    if (!(w.weight > 0) || !std::isfinite(w.weight) || !std::isfinite(w.position_mm.x) ||
        !std::isfinite(w.position_mm.y))
      fail(Errc::InvalidArgument,
           "clusterPoints: a point of weight {} at ({}, {}): weights must be finite and "
           "positive, positions finite",
           w.weight, w.position_mm.x, w.position_mm.y);
    p.push_back(w.position_mm);
  }
  std::vector<size_t> parent(p.size());
  std::iota(parent.begin(), parent.end(), size_t{0});
  const Buckets buckets(p, radius_mm);
  const double r2 = radius_mm * radius_mm;
  for (size_t k = 0; k < p.size(); ++k)
    buckets.near(p[k], [&](size_t m) {
      if (m > k && (p[m] - p[k]).length2() < r2) parent[findRoot(parent, m)] = findRoot(parent, k);
    });
  std::unordered_map<size_t, WeightedPoint> sums;
  for (size_t k = 0; k < p.size(); ++k) {
    WeightedPoint& s = sums.try_emplace(findRoot(parent, k), WeightedPoint{{0, 0}, 0}).first->second;
    s.position_mm += points[k].weight * points[k].position_mm;
    s.weight += points[k].weight;
  }
  std::vector<WeightedPoint> out;
  out.reserve(sums.size());
  for (auto& [root, s] : sums) out.push_back({s.position_mm / s.weight, s.weight});
  std::sort(out.begin(), out.end(), [](const WeightedPoint& a, const WeightedPoint& b) {
    return a.weight != b.weight
               ? a.weight > b.weight
               : std::tie(a.position_mm.x, a.position_mm.y) < std::tie(b.position_mm.x, b.position_mm.y);
  });
  return out;
}

Vec2 LatticeFit::centre(int i, int j) const {
  return Lattice{packing, offset_mm, pitch_mm * std::cos(rotation_rad), pitch_mm * std::sin(rotation_rad)}.point(i, j);
}

std::array<int, 2> LatticeFit::nearestIndex(const Vec2& p) const {
  return Lattice{packing, offset_mm, pitch_mm * std::cos(rotation_rad), pitch_mm * std::sin(rotation_rad)}.nearest(p);
}

LatticeFit fitLensLattice(const std::vector<WeightedPoint>& centres, LensPacking packing, double nominalPitch_mm,
                          double nominalRotation_rad, double quantum_mm, int minCentres, double maxOutlierShare) {
  if (!(nominalPitch_mm > 0) || !std::isfinite(nominalPitch_mm) || !std::isfinite(nominalRotation_rad) ||
      !(quantum_mm > 0) || !std::isfinite(quantum_mm))
    fail(Errc::InvalidArgument,
         "lens array fit: nominal pitch {} mm, rotation {} rad and quantum {} mm must be "
         "finite, the pitch and the quantum positive",
         nominalPitch_mm, nominalRotation_rad, quantum_mm);
  minCentres = std::max(minCentres, 3);
  if (static_cast<int>(centres.size()) < minCentres)
    fail(Errc::Device,
         "lens array fit: {} lens centres found, fewer than the {} a fit needs: the camera sees too "
         "little of the display, or too few of its pixels decoded",
         centres.size(), minCentres);
  std::vector<Vec2> c;
  c.reserve(centres.size());
  for (const WeightedPoint& w : centres) c.push_back(w.position_mm);

  Lattice lattice = startingLattice(c, packing, nominalPitch_mm, nominalRotation_rad);
  std::vector<std::array<int, 2>> index(c.size());
  std::vector<size_t> use;
  Solution s;
  for (int pass = 0; pass < 5; ++pass) {
    for (size_t k = 0; k < c.size(); ++k) index[k] = lattice.nearest(c[k]);
    // Residuals of every centre against the current lattice; the robust spread from the centres kept so far.
    std::vector<double> distance(c.size()), components;
    for (size_t k = 0; k < c.size(); ++k) {
      const Vec2 r = c[k] - lattice.point(index[k][0], index[k][1]);
      distance[k] = r.length();
      components.push_back(std::abs(r.x));
      components.push_back(std::abs(r.y));
    }
    const double pitch = std::hypot(lattice.a, lattice.b);
    const double robust = 1.4826 * median(components);
    const double limit = pass == 0 ? 0.25 * pitch : std::min(0.25 * pitch, std::max(5 * robust, 0.05 * pitch));
    std::vector<size_t> kept;
    for (size_t k = 0; k < c.size(); ++k)
      if (distance[k] <= limit && (pass > 0 || (c[k] - lattice.o).length() <= kStartReach * pitch)) kept.push_back(k);
    if (pass == 0) {
      // The starting lattice holds near its origin; the fit there holds across the display.
      s = solve(packing, c, index, kept, quantum_mm);
      lattice = s.lattice;
      continue;
    }
    if (pass > 1 && kept == use) break;
    use = std::move(kept);
    if (use.size() < static_cast<size_t>(minCentres) ||
        static_cast<double>(c.size() - use.size()) > maxOutlierShare * static_cast<double>(c.size()))
      fail(Errc::Device,
           "lens array fit: {} of the {} lens centres found lie on a {} lattice (within {:.3g} mm of "
           "one of its points), more than {} % are off it: the residual is too large for the model (a part or "
           "something else in the camera's view, or another packing than the display states)",
           use.size(), c.size(), toString(packing), limit, 100 * maxOutlierShare);
    std::set<int> columns, rows;
    for (size_t k : use) {
      columns.insert(index[k][0]);
      rows.insert(index[k][1]);
    }
    if (columns.size() < 2 || rows.size() < 2)
      fail(Errc::Device,
           "lens array fit: the {} lens centres kept span {} column(s) and {} row(s) of the array; a "
           "fit needs two of each",
           use.size(), columns.size(), rows.size());
    s = solve(packing, c, index, use, quantum_mm);
    lattice = s.lattice;
  }

  const size_t n = use.size();
  const cv::Matx44d plain = s.rss / std::max(1.0, static_cast<double>(2 * n) - 4) * s.inverse;
  const auto sigma = [&](const cv::Vec4d& g) {
    return std::sqrt(
        std::max({(g.t() * plain * g)(0), (g.t() * s.covariance * g)(0), (g.t() * s.quantisation * g)(0)}));
  };
  LatticeFit fit;
  fit.packing = packing;
  fit.centres = static_cast<int>(n);
  fit.outliers = static_cast<int>(c.size() - n);
  fit.residualRms_mm = std::sqrt(s.rss / static_cast<double>(2 * n));
  const double a = lattice.a, b = lattice.b, p2 = a * a + b * b;
  fit.pitch_mm = std::sqrt(p2);
  const cv::Vec4d dPitch(0, 0, a / fit.pitch_mm, b / fit.pitch_mm), dRotation(0, 0, -b / p2, a / p2);
  fit.pitchSigma_mm = sigma(dPitch);
  fit.rotationSigma_rad = sigma(dRotation);
  // Lens (0, 0): the lattice point nearest the panel's centre.
  const std::array<int, 2> zero = lattice.nearest({0, 0});
  const Vec2 l = unitPoint(packing, zero[0], zero[1]);
  const cv::Vec4d dx(1, 0, l.x, -l.y), dy(0, 1, l.y, l.x);
  fit.offset_mm = lattice.point(zero[0], zero[1]);
  fit.offsetSigma_mm = {sigma(dx), sigma(dy)};
  // The rotation within the packing's symmetry: the same lattice.
  const double sym = symmetryAngle(packing);
  fit.rotation_rad = std::remainder(std::atan2(b, a), sym);
  return fit;
}

}  // namespace lfi::calib
