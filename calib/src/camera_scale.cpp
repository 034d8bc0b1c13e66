// SPDX-License-Identifier: Apache-2.0
#include "lfi/calib/camera_scale.h"

#include "lfi/core/error.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace lfi::calib {

namespace {

constexpr int kParameters = 7;  // A (4), t (2), κ

Vec2 imageCentre(cv::Size image) {
  return {0.5 * (image.width - 1), 0.5 * (image.height - 1)};
}
double cornerRadius(cv::Size image) {
  return std::max(1.0, imageCentre(image).length());
}

// The model's display point and its Jacobian (rows x, y; columns A00 A01 A10 A11 tx ty κ).
struct Prediction {
  Vec2 point;
  cv::Matx<double, 2, kParameters> jacobian;
};

Prediction predict(const cv::Vec<double, kParameters>& p, const Vec2& d, double r2) {
  const double q = d.length2() / r2;
  const Vec2 g = d * (1 + p[6] * q);
  Prediction out;
  out.point = {p[0] * g.x + p[1] * g.y + p[4], p[2] * g.x + p[3] * g.y + p[5]};
  const Vec2 dg = d * q;                                                                            // ∂g/∂κ
  out.jacobian = cv::Matx<double, 2, kParameters>(g.x, g.y, 0, 0, 1, 0, p[0] * dg.x + p[1] * dg.y,  //
                                                  0, 0, g.x, g.y, 0, 1, p[2] * dg.x + p[3] * dg.y);
  return out;
}

struct Model {
  cv::Vec<double, kParameters> p = cv::Vec<double, kParameters>::all(0);
  cv::Matx<double, kParameters, kParameters> plain, clustered, shared;  // the covariances (camera_scale.h)
  double rss = 0;
  // A quantity's standard uncertainty from its gradient in the parameters: the largest of the three.
  double sigma(const cv::Vec<double, kParameters>& g) const {
    return std::sqrt(std::max({0.0, (g.t() * plain * g)(0), (g.t() * clustered * g)(0), (g.t() * shared * g)(0)}));
  }
};

// Gauss-Newton from A = 0, t = 0, κ = 0 (the first step is the affine least squares); κ stays 0 without
// `distortion`.
Model solveModel(const std::vector<CameraPoint>& points, const Vec2& centre, double r2, bool distortion,
                 double sharedSigma_px) {
  Model m;
  cv::Matx<double, kParameters, kParameters> inverse;
  for (int iteration = 0; iteration < 8; ++iteration) {
    cv::Matx<double, kParameters, kParameters> jtj = cv::Matx<double, kParameters, kParameters>::zeros();
    cv::Vec<double, kParameters> jtr = cv::Vec<double, kParameters>::all(0);
    for (const CameraPoint& point : points) {
      const Prediction f = predict(m.p, point.camera_px - centre, r2);
      const cv::Vec2d residual(point.display_mm.x - f.point.x, point.display_mm.y - f.point.y);
      jtj += f.jacobian.t() * f.jacobian;
      jtr += f.jacobian.t() * residual;
    }
    if (!distortion || iteration == 0) {
      // κ held: its row and column out. (At the start A = 0, so κ has no effect yet.)
      for (int q = 0; q < kParameters; ++q) jtj(6, q) = jtj(q, 6) = 0;
      jtj(6, 6) = 1;
      jtr[6] = 0;
    }
    const double condition = cv::invert(jtj, inverse, cv::DECOMP_SVD);
    if (!(condition > 1e-14)) fail(Errc::Device, "camera scale fit: the spots do not determine the camera's scale");
    const cv::Vec<double, kParameters> step = inverse * jtr;
    m.p += step;
    if (iteration > 0 && cv::norm(step) < 1e-12 * (1 + cv::norm(m.p))) break;
  }
  using Vec = cv::Vec<double, kParameters>;
  std::map<std::pair<int, int>, Vec> scores;  // Σ Jᵀ r of the x residuals per lens column, the y per row
  // Σ Jᵀ ∂r/∂u per column and Σ Jᵀ ∂r/∂v per row: what an error shared by a column's u (a row's v) moves.
  std::map<std::pair<int, int>, Vec> sensitivities;
  const cv::Vec2d du(m.p[0], m.p[2]), dv(m.p[1], m.p[3]);  // ∂(display point)/∂(u, v), the affine part
  for (const CameraPoint& point : points) {
    const Prediction f = predict(m.p, point.camera_px - centre, r2);
    const Vec2 r = point.display_mm - f.point;
    m.rss += r.length2();
    Vec jx, jy;
    for (int q = 0; q < kParameters; ++q) {
      jx[q] = f.jacobian(0, q);
      jy[q] = f.jacobian(1, q);
    }
    scores.try_emplace({0, point.lens[0]}, Vec::all(0)).first->second += jx * r.x;
    scores.try_emplace({1, point.lens[1]}, Vec::all(0)).first->second += jy * r.y;
    sensitivities.try_emplace({0, point.lens[0]}, Vec::all(0)).first->second += f.jacobian.t() * du;
    sensitivities.try_emplace({1, point.lens[1]}, Vec::all(0)).first->second += f.jacobian.t() * dv;
  }
  const int parameters = distortion ? kParameters : kParameters - 1;
  const double dof = 2 * static_cast<double>(points.size()) - parameters;
  m.plain = m.rss / std::max(1.0, dof) * inverse;
  cv::Matx<double, kParameters, kParameters> meat = cv::Matx<double, kParameters, kParameters>::zeros();
  for (const auto& [group, score] : scores) meat += score * score.t();
  const double groups = static_cast<double>(scores.size());
  m.clustered = groups / std::max(1.0, groups - parameters) * inverse * meat * inverse;
  cv::Matx<double, kParameters, kParameters> spread = cv::Matx<double, kParameters, kParameters>::zeros();
  for (const auto& [group, sensitivity] : sensitivities) spread += sensitivity * sensitivity.t();
  m.shared = sharedSigma_px * sharedSigma_px * inverse * spread * inverse;
  return m;
}

}  // namespace

Vec2 CameraMap::displayPoint(const Vec2& px, cv::Size image) const {
  const Vec2 d = px - imageCentre(image);
  const cv::Vec2d x = perPixel_mm * cv::Vec2d(d.x, d.y);
  return atImageCentre_mm + Vec2(x[0], x[1]);
}

Vec2 CameraMap::cameraPoint(const Vec2& q, cv::Size image) const {
  const cv::Vec2d d = perPixel_mm.inv() * cv::Vec2d(q.x - atImageCentre_mm.x, q.y - atImageCentre_mm.y);
  return imageCentre(image) + Vec2(d[0], d[1]);
}

CameraScaleFit fitCameraScale(const std::vector<CameraPoint>& points, cv::Size image, const DisplayFrameSigma& display,
                              double sharedSigma_px) {
  if (!(sharedSigma_px >= 0 && sharedSigma_px < 1e3))
    fail(Errc::InvalidArgument, "camera scale fit: a shared point uncertainty of {} px", sharedSigma_px);
  if (image.width <= 0 || image.height <= 0)
    fail(Errc::InvalidArgument, "camera scale fit: an empty image size {} x {}", image.width, image.height);
  if (points.size() < 6)
    fail(Errc::Device,
         "camera scale fit: {} spots found, fewer than the 6 a fit needs: the camera sees too little "
         "of the display",
         points.size());
  const Vec2 centre = imageCentre(image);
  const double r = cornerRadius(image), r2 = r * r;
  // Spanning two directions: the spots' second moments are not all along one line.
  cv::Matx22d moments = cv::Matx22d::zeros();
  Vec2 mean(0, 0);
  for (const CameraPoint& p : points) mean += p.camera_px;
  mean /= static_cast<double>(points.size());
  for (const CameraPoint& p : points) {
    const Vec2 d = p.camera_px - mean;
    moments += cv::Matx22d(d.x * d.x, d.x * d.y, d.x * d.y, d.y * d.y);
  }
  const double half = 0.5 * (moments(0, 0) + moments(1, 1));
  const double spread = std::sqrt(std::max(0.0, half * half - cv::determinant(moments)));
  if (!(half - spread > 1e-6 * (half + spread)))
    fail(Errc::Device, "camera scale fit: the {} spots found lie on one line of the image", points.size());

  const Model affine = solveModel(points, centre, r2, false, sharedSigma_px),
              full = solveModel(points, centre, r2, true, sharedSigma_px);
  const cv::Vec<double, kParameters>& p = affine.p;
  CameraScaleFit fit;
  fit.points = static_cast<int>(points.size());
  fit.map = {cv::Matx22d(p[0], p[1], p[2], p[3]), {p[4], p[5]}};
  fit.distortion_px = full.p[6] * r;
  const double det = p[0] * p[3] - p[1] * p[2];
  fit.mirrored = det < 0;
  fit.objectPixel_mm = fit.map.objectPixel_mm();
  fit.pixelX_mm = std::hypot(p[0], p[2]);
  fit.pixelY_mm = std::hypot(p[1], p[3]);
  fit.rotation_rad = std::atan2(p[2], p[0]);
  const double sign = det < 0 ? -1 : 1;
  cv::Vec<double, kParameters> dScale = cv::Vec<double, kParameters>::all(0);
  dScale[0] = sign * p[3] / (2 * fit.objectPixel_mm);
  dScale[1] = -sign * p[2] / (2 * fit.objectPixel_mm);
  dScale[2] = -sign * p[1] / (2 * fit.objectPixel_mm);
  dScale[3] = sign * p[0] / (2 * fit.objectPixel_mm);
  fit.objectPixelSigma_mm = std::hypot(affine.sigma(dScale), display.scale * fit.objectPixel_mm);
  cv::Vec<double, kParameters> unit = cv::Vec<double, kParameters>::all(0);
  unit[6] = r;
  fit.distortionSigma_px = full.sigma(unit);
  unit = cv::Vec<double, kParameters>::all(0);
  unit[4] = 1;
  fit.centreSigma_mm.x = std::hypot(affine.sigma(unit), display.shift_mm.x);
  unit[4] = 0;
  unit[5] = 1;
  fit.centreSigma_mm.y = std::hypot(affine.sigma(unit), display.shift_mm.y);
  for (int i = 0; i < 4; ++i) {
    unit = cv::Vec<double, kParameters>::all(0);
    unit[i] = 1;
    fit.perPixelSigma_mm(i / 2, i % 2) = std::hypot(affine.sigma(unit), display.scale * p[i]);
  }
  fit.residualRms_mm = std::sqrt(affine.rss / (2 * static_cast<double>(points.size())));
  return fit;
}

std::optional<Spot> spotCentroid(const cv::Mat& image, const Vec2& guess, double radius_px, double minLight) {
  if (image.type() != CV_32FC1 || !(radius_px > 0))
    fail(Errc::InvalidArgument, "spotCentroid: a CV_32FC1 image and a positive radius are needed");
  Vec2 centre = guess;
  Spot spot;
  for (int iteration = 0; iteration < 5; ++iteration) {
    // (Outside the image by far, or not a number: no window, and no integer conversion of it.)
    if (!(std::abs(centre.x) < 1e9 && std::abs(centre.y) < 1e9 && radius_px < 1e9)) return std::nullopt;
    const int x0 = static_cast<int>(std::ceil(centre.x - radius_px)),
              x1 = static_cast<int>(std::floor(centre.x + radius_px));
    const int y0 = static_cast<int>(std::ceil(centre.y - radius_px)),
              y1 = static_cast<int>(std::floor(centre.y + radius_px));
    if (x0 < 0 || y0 < 0 || x1 >= image.cols || y1 >= image.rows) return std::nullopt;
    double sum = 0, sx = 0, sy = 0;
    for (int y = y0; y <= y1; ++y) {
      const float* row = image.ptr<float>(y);
      for (int x = x0; x <= x1; ++x) {
        sum += row[x];
        sx += row[x] * x;
        sy += row[x] * y;
      }
    }
    if (!(sum >= minLight) || !(sum > 0)) return std::nullopt;
    const Vec2 next(sx / sum, sy / sum);
    spot = {next, sum};
    const bool settled = (next - centre).length() < 0.01;
    centre = next;
    if (settled) break;
  }
  return spot;
}

}  // namespace lfi::calib
