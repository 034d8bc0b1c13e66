// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/part_calibration.h"

#include "gray_code_view.h"

#include "lfi/calib/axis_code.h"

#include "lfi/core/error.h"
#include "lfi/drivers/display_optics.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <random>

namespace lfi {

namespace {

using detail::Clock;
using detail::seconds;

constexpr int kMinPixels = 50;
constexpr int kMostSteps = 30;
constexpr double kLateralStep_mm = 0.01;  // the offsets' derivative in L, by differences

// A decoded camera pixel through the part.
struct Pixel {
  Vec2 x;       // where the camera pixel looks on the display's plane
  Vec2 offset;  // o = p − c: the decoded panel point within its lens
  Vec2 lens;    // c
  int lensId = 0;
  bool confident = false;  // decoded with at least min_confidence: its offset counts
};

void checkSettings(const PartCalibrationSettings& s) {
  const auto check = [](bool ok, const char* key, double value, const char* range) {
    if (!ok) fail(Errc::InvalidArgument, "part calibration: {} = {} is outside {}", key, value, range);
  };
  check(s.search > 0 && s.search < 1, "search", s.search, "(0, 1)");
  check(s.minConfidence >= 0 && s.minConfidence <= 1, "min_confidence", s.minConfidence, "[0, 1]");
  check(s.minDecoded > 0 && s.minDecoded <= 1, "min_decoded", s.minDecoded, "(0, 1]");
  check(s.bootstrap >= 10 && s.bootstrap <= 100000, "bootstrap", s.bootstrap, "10 .. 100000");
  check(s.coverageFactor > 0 && s.coverageFactor <= 10, "coverage_factor", s.coverageFactor, "(0, 10]");
}

// The exit rays of every pixel's camera ray with the part's reference point at L.
std::vector<std::optional<PartRay>> traceAll(const PartModel& part, const std::vector<Pixel>& pixels, const Vec2& L) {
  std::vector<std::optional<PartRay>> out(pixels.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(pixels.size())), [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) out[static_cast<size_t>(i)] = part.exit(pixels[static_cast<size_t>(i)].x - L);
  });
  return out;
}

Vec2 slope(const PartRay& ray) {
  return {ray.direction.x / ray.direction.z, ray.direction.y / ray.direction.z};
}

// The exit rays at L and a small step from it along x and y: the offsets' derivatives in L.
struct Traces {
  std::vector<std::optional<PartRay>> at, x, y;
};

Traces traceAround(const PartModel& part, const std::vector<Pixel>& pixels, const Vec2& L) {
  return {traceAll(part, pixels, L), traceAll(part, pixels, L + Vec2(kLateralStep_mm, 0)),
          traceAll(part, pixels, L + Vec2(0, kLateralStep_mm))};
}

// Pixel i's offset residual r = o + g m and its Jacobian rows in θ = (g, L_x, L_y); empty where a ray misses.
struct Row {
  Vec2 r;
  cv::Vec3d jx, jy;
};

// The directions the offsets are measured in: both for a lens or pinhole array; across the axes (its normal n)
// for a lenticular sheet or line barrier, whose lenses (slits) say nothing along them. For the latter a
// residual's and a row's first component is along n, the second 0.
// The part's place is fitted in x and y for an array; for a sheet or barrier only across its axes (θ's second
// component along n, the third held at 0): the slopes across tell where the part lies across them, hardly where
// along.
struct Directions {
  bool across = false;
  Vec2 n{1, 0};
  Vec2 project(const Vec2& v) const { return across ? Vec2(v.dot(n), 0) : v; }
  int count() const { return across ? 1 : 2; }
  // The part's move for θ's lateral components (a, b), and the derivatives in them from those in x and y.
  Vec2 move(double a, double b) const { return across ? a * n : Vec2(a, b); }
  std::pair<Vec2, Vec2> lateralDerivatives(const Vec2& dx, const Vec2& dy) const {
    if (!across) return {dx, dy};
    return {n.x * dx + n.y * dy, Vec2(0, 0)};
  }
  // The normal matrix with the held component's zero row and column made regular (its step and covariance are
  // then 0 and unused).
  void hold(cv::Matx33d& jtj) const {
    if (across) jtj(2, 2) = 1;
  }
};

std::optional<Row> row(const Pixel& pixel, double gap, const Traces& t, size_t i, const Directions& d) {
  if (!t.at[i] || !t.x[i] || !t.y[i]) return std::nullopt;
  const Vec2 m = slope(*t.at[i]);
  const Vec2 dmx = (slope(*t.x[i]) - m) / kLateralStep_mm, dmy = (slope(*t.y[i]) - m) / kLateralStep_mm;
  const auto [da, db] = d.lateralDerivatives(dmx, dmy);
  const Vec2 pm = d.project(m), px = d.project(da), py = d.project(db);
  return Row{d.project(pixel.offset + gap * m), {pm.x, gap * px.x, gap * py.x}, {pm.y, gap * px.y, gap * py.y}};
}

// The offsets' fit: θ = (g, L_x, L_y).
struct OffsetFit {
  double gap = 0;
  Vec2 lateral{0, 0};
  cv::Vec3d sigma{0, 0, 0};  // of θ
  double rms = 0;
  std::vector<size_t> kept;
  std::vector<std::optional<PartRay>> rays;  // at `lateral`
};

OffsetFit fitOffsets(const PartModel& part, const std::vector<Pixel>& pixels, const Vec2& lateral0, double gap0,
                     double pixelPitch_mm, const std::string& display, const Directions& d) {
  OffsetFit fit;
  fit.gap = gap0;
  fit.lateral = lateral0;
  for (size_t i = 0; i < pixels.size(); ++i)
    if (pixels[i].confident) fit.kept.push_back(i);
  for (int round = 0; round < 3; ++round) {
    bool converged = false;
    for (int step = 0; step < kMostSteps && !converged; ++step) {
      const Traces t = traceAround(part, pixels, fit.lateral);
      cv::Matx33d jtj = cv::Matx33d::zeros();
      cv::Vec3d jtr(0, 0, 0);
      for (size_t i : fit.kept)
        if (const auto w = row(pixels[i], fit.gap, t, i, d)) {
          jtj += w->jx * w->jx.t() + w->jy * w->jy.t();
          jtr += w->jx * w->r.x + w->jy * w->r.y;
        }
      d.hold(jtj);
      cv::Vec3d delta = -(jtj.inv(cv::DECOMP_SVD) * jtr);
      // A step that raises the offsets' squared residual (the pixels the part takes change as it moves) halved,
      // up to 6 times.
      const auto cost = [&](const std::vector<std::optional<PartRay>>& rays, double gap) {
        double sum = 0;
        for (size_t i : fit.kept)
          if (rays[i]) sum += d.project(pixels[i].offset + gap * slope(*rays[i])).length2();
        return sum;
      };
      const double before = cost(t.at, fit.gap);  // (the rays at the start of the step, traced already)
      for (int halving = 0; halving < 6 && cost(traceAll(part, pixels, fit.lateral + d.move(delta[1], delta[2])),
                                                fit.gap + delta[0]) > before;
           ++halving)
        delta *= 0.5;
      fit.gap += delta[0];
      fit.lateral += d.move(delta[1], delta[2]);
      if (!(fit.gap > 0.5 * gap0 && fit.gap < 2 * gap0) || !std::isfinite(fit.lateral.x) ||
          !std::isfinite(fit.lateral.y))
        fail(Errc::Device,
             "part calibration of display '{}': the fit did not converge (the gap went to {:.4g} mm, "
             "outside half to twice the stated {:.4g} mm): the part is not the model's, or not where the bench "
             "expects it",
             display, fit.gap, gap0);
      // Converged: a step of less than 10 nm, far below what the offsets tell (a panel pixel is 30 µm).
      converged = std::abs(delta[0]) < 1e-5 && std::abs(delta[1]) < 1e-5 && std::abs(delta[2]) < 1e-5;
    }
    if (!converged)
      fail(Errc::Device, "part calibration of display '{}': the fit did not converge in {} steps", display, kMostSteps);
    // Residuals at the solution; pixels beyond five robust standard deviations (at least half a panel pixel) out.
    fit.rays = traceAll(part, pixels, fit.lateral);
    std::vector<double> components;
    for (size_t i = 0; i < pixels.size(); ++i)
      if (fit.rays[i] && pixels[i].confident) {
        const Vec2 r = d.project(pixels[i].offset + fit.gap * slope(*fit.rays[i]));
        components.push_back(std::abs(r.x));
        if (!d.across) components.push_back(std::abs(r.y));
      }
    const double limit = std::max(5 * 1.4826 * detail::median(components), 0.5 * pixelPitch_mm);
    std::vector<size_t> kept;
    for (size_t i = 0; i < pixels.size(); ++i)
      if (fit.rays[i] && pixels[i].confident &&
          d.project(pixels[i].offset + fit.gap * slope(*fit.rays[i])).length() <= limit)
        kept.push_back(i);
    const bool same = kept == fit.kept;
    fit.kept = std::move(kept);
    if (fit.kept.size() < static_cast<size_t>(kMinPixels))
      fail(Errc::Device, "part calibration of display '{}': {} camera pixels fit the part's model, fewer than {}",
           display, fit.kept.size(), kMinPixels);
    if (same) break;
  }
  // Uncertainties: for each parameter the largest of the plain covariance, the one clustered by decoded lens,
  // and that of a panel pixel's quantisation (/ √12) shared by the pixels of a lens, per axis.
  const Traces t = traceAround(part, pixels, fit.lateral);
  cv::Matx33d jtj = cv::Matx33d::zeros(), meat = cv::Matx33d::zeros(), shared = cv::Matx33d::zeros();
  double rss = 0;
  struct Lens {
    cv::Vec3d score, jx, jy;  // Σ Jᵀ r, and the sums of its pixels' x and y rows
  };
  std::map<int, Lens> lenses;
  size_t n = 0;
  for (size_t i : fit.kept)
    if (const auto w = row(pixels[i], fit.gap, t, i, d)) {
      jtj += w->jx * w->jx.t() + w->jy * w->jy.t();
      rss += w->r.length2();
      Lens& lens = lenses[pixels[i].lensId];
      lens.score += w->jx * w->r.x + w->jy * w->r.y;
      lens.jx += w->jx;
      lens.jy += w->jy;
      ++n;
    }
  for (const auto& [id, lens] : lenses) {
    meat += lens.score * lens.score.t();
    shared += lens.jx * lens.jx.t() + lens.jy * lens.jy.t();
  }
  d.hold(jtj);
  const cv::Matx33d inverse = jtj.inv(cv::DECOMP_SVD);
  const double groups = static_cast<double>(lenses.size());
  const double components = d.count() * static_cast<double>(n);
  const cv::Matx33d plain = rss / std::max(1.0, components - 3) * inverse;
  const cv::Matx33d clustered = groups / std::max(1.0, groups - 3) * inverse * meat * inverse;
  const cv::Matx33d quantisation = pixelPitch_mm * pixelPitch_mm / 12 * inverse * shared * inverse;
  for (int a = 0; a < 3; ++a) fit.sigma[a] = std::sqrt(std::max({plain(a, a), clustered(a, a), quantisation(a, a)}));
  fit.rms = std::sqrt(rss / std::max(1.0, components));
  return fit;
}

// How far q lies outside the cell of the lens at `centre` (0 inside), capped at half a pitch: the cell's
// sides are perpendicular to the directions of the neighbouring lenses, half a pitch from the centre.
struct Cells {
  std::vector<Vec2> normals;
  double half = 0;
  double outside(const Vec2& q, const Vec2& centre) const {
    const Vec2 v = q - centre;
    double sum = 0;
    for (const Vec2& n : normals) {
      const double excess = std::max(0.0, std::abs(v.dot(n)) - half);
      sum += excess * excess;
    }
    return std::min(std::sqrt(sum), half);
  }
};

Cells cellsOf(const DisplayInfo& info, const Directions& d) {
  const DisplayOpticsParams& o = info.optics;
  Cells cells;
  if (d.across) {  // a sheet's lens, a barrier's slit: the strip half a pitch either side of its axis
    cells.normals = {d.n};
    cells.half = 0.5 * o.lensPitch_px * info.pixelPitch_mm * std::cos(o.slant_rad);
    return cells;
  }
  cells.half = 0.5 * o.arrayPitch_mm;
  const int sides = o.packing == LensPacking::Square ? 2 : 3;
  const double step = o.packing == LensPacking::Square ? M_PI / 2 : M_PI / 3;
  for (int k = 0; k < sides; ++k)
    cells.normals.push_back({std::cos(o.rotation_rad + k * step), std::sin(o.rotation_rad + k * step)});
  return cells;
}

// Δ's objective: each pixel's q(Δ) = a + Δ b against its decoded lens, weighted.
struct Membership {
  std::vector<Vec2> a, b, lens;
  std::vector<int> lensId;
  Cells cells;
  double cost(double distance, const std::vector<double>& weight) const {
    double sum = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      const double d = cells.outside(a[i] + distance * b[i], lens[i]);
      sum += weight[i] * d * d;
    }
    return sum;
  }
  // The minimum over [from, to]: a grid of `step`, then golden-section search about the best node.
  double minimise(double from, double to, double step, const std::vector<double>& weight) const {
    double best = from, bestCost = cost(from, weight);
    for (double d = from + step; d <= to + 1e-12; d += step)
      if (const double c = cost(d, weight); c < bestCost) best = d, bestCost = c;
    double lo = std::max(from, best - step), hi = std::min(to, best + step);
    const double ratio = (std::sqrt(5.0) - 1) / 2;
    double x1 = hi - ratio * (hi - lo), x2 = lo + ratio * (hi - lo);
    double f1 = cost(x1, weight), f2 = cost(x2, weight);
    while (hi - lo > 1e-5) {
      if (f1 < f2) {
        hi = x2, x2 = x1, f2 = f1;
        x1 = hi - ratio * (hi - lo), f1 = cost(x1, weight);
      } else {
        lo = x1, x1 = x2, f1 = f2;
        x2 = lo + ratio * (hi - lo), f2 = cost(x2, weight);
      }
    }
    return 0.5 * (lo + hi);
  }
};

// A decoded camera pixel: the panel point its light comes from (for a sheet or barrier a point of the line
// across its axes the code names), and how surely.
struct Decoded {
  Vec2 camera_px;
  Vec2 panel;
  float confidence = 0;
};

// Each decoded camera pixel's place on the display's plane, its panel point
// within its lens, and its lens (ids in `lensIds`). Errc::Device when no ray
// is deflected: the part is missing.
std::vector<Pixel> decodedPixels(const std::vector<Decoded>& decoded, const DisplayInfo& info, const Directions& d,
                                 const calib::CameraMap& camera, cv::Size image, double minConfidence,
                                 std::map<std::pair<long long, long long>, int>& lensIds) {
  const DisplayOptics optics(info);
  std::vector<Pixel> pixels;
  int deflected = 0;
  for (const Decoded& p : decoded) {
    const Vec2 lens = optics.apertureCentre(p.panel);
    const Vec2 offset = p.panel - lens;
    if (offset.length() > 2 * info.pixelPitch_mm) ++deflected;
    // A lens by its centre; a sheet's lens or a barrier's slit by its axis's place across.
    const auto key = d.across ? std::make_pair(std::llround(lens.dot(d.n) * 1e6), 0LL)
                              : std::make_pair(std::llround(lens.x * 1e6), std::llround(lens.y * 1e6));
    const int id = lensIds.try_emplace(key, static_cast<int>(lensIds.size())).first->second;
    pixels.push_back({camera.displayPoint(p.camera_px, image), offset, lens, id, p.confidence >= minConfidence});
  }
  if (deflected <= 0.01 * static_cast<double>(pixels.size()))
    fail(Errc::Device,
         "part calibration: every ray the camera sees leaves display '{}' within two panel pixels of "
         "its lens's centre: nothing deflects them, is the part missing?",
         info.deviceId);
  return pixels;
}

// The pixels whose rays the model takes through the part where the bench puts
// it; Errc::Device when too few are left.
std::vector<Pixel> throughThePart(const PartModel& part, const std::vector<Pixel>& pixels, Vec2 stated) {
  const auto rays = traceAll(part, pixels, stated);
  std::vector<Pixel> through;
  for (size_t i = 0; i < pixels.size(); ++i)
    if (rays[i]) through.push_back(pixels[i]);
  if (through.size() < static_cast<size_t>(kMinPixels))
    fail(Errc::Device,
         "part calibration: {} decoded camera pixels look through the part, fewer than {}: too few "
         "decoded pixels (is the part in the camera's view, where the bench expects it?)",
         through.size(), kMinPixels);
  return through;
}

// Δ's objective from the rays the offset fit traced.
Membership membership(const std::vector<Pixel>& pixels, const OffsetFit& fit, const DisplayInfo& info,
                      const Directions& d) {
  Membership m;
  m.cells = cellsOf(info, d);
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (!fit.rays[i]) continue;
    const PartRay& ray = *fit.rays[i];
    const Vec2 s = slope(ray);
    m.a.push_back(Vec2(ray.point.x, ray.point.y) + fit.lateral - ray.point.z * s);
    m.b.push_back(-s);
    m.lens.push_back(pixels[i].lens);
    m.lensId.push_back(pixels[i].lensId);
  }
  return m;
}

// Δ's standard uncertainty: the decoded lenses resampled (`lenses` of them), Δ fitted again each time.
double distanceSigma(const Membership& m, std::size_t lenses, double distance_mm, double step,
                     const PartCalibrationSettings& settings) {
  std::vector<std::vector<size_t>> byLens(lenses);
  for (size_t i = 0; i < m.lensId.size(); ++i) byLens[static_cast<size_t>(m.lensId[i])].push_back(i);
  std::erase_if(byLens, [](const std::vector<size_t>& v) { return v.empty(); });
  std::mt19937_64 random(settings.seed);
  std::uniform_int_distribution<size_t> pick(0, byLens.size() - 1);
  double sum = 0, sum2 = 0;
  for (int b = 0; b < settings.bootstrap; ++b) {
    std::vector<double> weight(m.a.size(), 0.0);
    for (size_t k = 0; k < byLens.size(); ++k)
      for (size_t i : byLens[pick(random)]) weight[i] += 1;
    const double d = m.minimise(distance_mm - 1, distance_mm + 1, 0.5 * step, weight);
    sum += d;
    sum2 += d * d;
  }
  const double n = settings.bootstrap;
  return std::sqrt(std::max(0.0, (sum2 - sum * sum / n) / (n - 1)));
}

}  // namespace

PartCalibration calibratePart(BenchProbe& bench, const PartModel& part, const calib::CameraMap& camera,
                              double statedDistance_mm, std::optional<Vec2> statedPartCentre_px,
                              const PartCalibrationSettings& settings, const std::function<void(double)>& progress) {
  checkSettings(settings);
  if (!(statedDistance_mm > 0) || !std::isfinite(statedDistance_mm))
    fail(Errc::InvalidArgument, "part calibration: the stated distance {} mm must be positive", statedDistance_mm);
  const auto start = Clock::now();
  PartCalibration out;
  out.coverageFactor = settings.coverageFactor;
  out.statedDistance_mm = statedDistance_mm;
  const DisplayInfo info = bench.display();
  info.validate();
  out.nominal = info;
  const std::string& name = info.deviceId;
  if (info.optics.type == OpticsType::LineBarrier)
    fail(Errc::Device,
         "part calibration: display '{}' is a line barrier: the light a camera pixel takes through the part passes "
         "a slit narrower than the camera's blur at the display, along other rays than the model traces from the "
         "pixel; its part calibration is not built",
         name);
  // A lens or pinhole array: the panel pixel each camera pixel sees (coded_patterns.h). A sheet: the
  // band across its axes (axis_code.h), which the camera's blur along them leaves whole.
  Directions d;
  if (!fullParallax(info.optics.type)) d = {true, {std::cos(info.optics.slant_rad), -std::sin(info.optics.slant_rad)}};
  const int totalFrames =
      d.across
          ? 2 + static_cast<int>(calib::axisCodePatterns(info.panelWidth_px, info.panelHeight_px, info.optics.slant_rad)
                                     .patterns.size())
          : calib::GrayCodeLayout::forPanel(info.panelWidth_px, info.panelHeight_px).frameCount();
  detail::FrameTaker take(bench, "part calibration", name, totalFrames, progress);
  const char* why = "the patterns blur, or the part scatters more light than it refracts";
  std::vector<Decoded> decoded;
  cv::Size image;
  double decodeSeconds = 0;
  if (d.across) {
    const detail::AxisCodeView view =
        detail::takeAxisCode(take, info, bench.cameraFullScale_dn(), settings.minDecoded, "part calibration", why);
    out.lit = view.correspondence.lit;
    out.decoded = view.correspondence.decoded;
    image = view.white.size();
    decodeSeconds = view.decodeSeconds;
    for (int row = 0; row < image.height; ++row)
      for (int col = 0; col < image.width; ++col)
        if (const float xi = view.correspondence.xi.at<float>(row, col); !std::isnan(xi))
          decoded.push_back(
              {Vec2(col, row), Vec2(xi * info.pixelPitch_mm, 0), view.correspondence.confidence.at<float>(row, col)});
  } else {
    const detail::GrayCodeView view =
        detail::takeGrayCode(take, info, bench.cameraFullScale_dn(), 0, settings.minDecoded, "part calibration", why);
    const calib::PanelCorrespondence& c = view.correspondence;
    out.lit = c.lit;
    out.decoded = c.decoded;
    image = view.white.size();
    decodeSeconds = view.decodeSeconds;
    for (int row = 0; row < image.height; ++row)
      for (int col = 0; col < image.width; ++col)
        if (const cv::Vec2i p = c.panel.at<cv::Vec2i>(row, col); p[0] >= 0)
          decoded.push_back(
              {Vec2(col, row), detail::panelPixelCentre(info, p[0], p[1]), c.confidence.at<float>(row, col)});
  }
  const auto computeStart = Clock::now();

  std::map<std::pair<long long, long long>, int> lensIds;
  const Vec2 stated =
      camera.displayPoint(statedPartCentre_px.value_or(Vec2(0.5 * (image.width - 1), 0.5 * (image.height - 1))), image);
  const std::vector<Pixel> pixels =
      throughThePart(part, decodedPixels(decoded, info, d, camera, image, settings.minConfidence, lensIds), stated);

  // g and L from the offsets within each lens.
  const OffsetFit fit = fitOffsets(part, pixels, stated, info.optics.gap_mm, info.pixelPitch_mm, name, d);
  out.gap_mm = fit.gap;
  out.lateral_mm = fit.lateral;
  out.lateralMeasured = !d.across;
  out.gapSigma_mm = fit.sigma[0];
  out.lateralSigma_mm = d.across ? Vec2(std::abs(d.n.x) * fit.sigma[1], std::abs(d.n.y) * fit.sigma[1])
                                 : Vec2(fit.sigma[1], fit.sigma[2]);
  out.offsetRms_mm = fit.rms;
  out.pixels = static_cast<int>(fit.kept.size());
  out.outliers = static_cast<int>(
      std::count_if(pixels.begin(), pixels.end(), [](const Pixel& p) { return p.confident; }) - fit.kept.size());
  if (fit.rms > 3 * info.pixelPitch_mm)
    fail(Errc::Device,
         "part calibration of display '{}': the panel points decoded through the part lie {:.3g} mm "
         "(RMS) from where the part's model sends the rays, more than three panel pixels: the residual is too "
         "large for the model (another part, a part tilted, or the wrong model)",
         name, fit.rms);

  // Δ from which lens each ray lands in.
  const Membership m = membership(pixels, fit, info, d);
  const double from = statedDistance_mm * (1 - settings.search), to = statedDistance_mm * (1 + settings.search);
  const double step = std::min(0.05, 0.01 * statedDistance_mm);
  const std::vector<double> ones(m.a.size(), 1.0);
  out.distance_mm = m.minimise(from, to, step, ones);
  if (out.distance_mm < from + step || out.distance_mm > to - step)
    fail(Errc::Device,
         "part calibration of display '{}': the fit did not converge: Δ = {:.3f} mm lies at the edge "
         "of the search ({:.3f} .. {:.3f} mm, the stated {} mm ± {} %)",
         name, out.distance_mm, from, to, statedDistance_mm, 100 * settings.search);
  for (size_t i = 0; i < m.a.size(); ++i)
    if (m.cells.outside(m.a[i] + out.distance_mm * m.b[i], m.lens[i]) > 0.5 * m.cells.half) ++out.otherLens;
  if (out.otherLens > static_cast<int>(m.a.size()) / 3)
    fail(Errc::Device,
         "part calibration of display '{}': at the best Δ = {:.3f} mm, {} of {} rays land in another "
         "lens than the one decoded: the residual is too large for the model",
         name, out.distance_mm, out.otherLens, m.a.size());

  out.distanceSigma_mm = distanceSigma(m, lensIds.size(), out.distance_mm, step, settings);
  out.partCentre_px = camera.cameraPoint(out.lateral_mm, image);
  out.frames = take.frames();
  if (progress) progress(1);
  out.computeSeconds = seconds(Clock::now() - computeStart) + decodeSeconds;
  out.seconds = seconds(Clock::now() - start);
  return out;
}

}  // namespace lfi
