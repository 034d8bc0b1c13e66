// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/light_field.h"

#include "lfi/core/error.h"
#include "lfi/core/image.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lfi {

void LightFieldGeometry::validate() const {
  constexpr int kMaxElements = 1 << 15;
  constexpr int kMaxAngular = 1024;
  if (spatialX < 1 || spatialX > kMaxElements)
    fail(Errc::InvalidArgument, "light field spatialX = {} is outside [1, {}]", spatialX, kMaxElements);
  if (spatialY < 1 || spatialY > kMaxElements)
    fail(Errc::InvalidArgument, "light field spatialY = {} is outside [1, {}]", spatialY, kMaxElements);
  if (angular < 1 || angular > kMaxAngular)
    fail(Errc::InvalidArgument, "light field angular = {} is outside [1, {}]", angular, kMaxAngular);
  // At most 2^17 pixels a side and 2^30 in all (4 GiB of float32): a bigger
  // image is a mistake, and would otherwise exhaust memory rather than fail.
  const long long side = kMaxElements * 4LL, w = static_cast<long long>(spatialX) * angular,
                  h = static_cast<long long>(spatialY) * angular;
  if (w > side || h > side || w * h > (1LL << 30))
    fail(Errc::InvalidArgument, "light field lenslet image {}x{} is too large (at most {} a side and 2^30 pixels)", w,
         h, side);
  if (!(pixelPitch_mm > 0) || !std::isfinite(pixelPitch_mm) || pixelPitch_mm > 1000)
    fail(Errc::InvalidArgument, "light field pixelPitch_mm = {} is outside (0, 1000]", pixelPitch_mm);
  if (!(distance_mm >= 0) || !std::isfinite(distance_mm))
    fail(Errc::InvalidArgument, "light field distance_mm = {} must be finite and >= 0", distance_mm);
}

LightField::LightField(const LightFieldGeometry& geometry) : geometry_(geometry) {
  geometry_.validate();
  lenslet_ = cv::Mat::zeros(geometry_.height(), geometry_.width(), CV_32FC1);
}

LightField::LightField(const LightFieldGeometry& geometry, cv::Mat lensletImage)
    : geometry_(geometry), lenslet_(std::move(lensletImage)) {
  geometry_.validate();
  if (lenslet_.type() != CV_32FC1)
    fail(Errc::InvalidArgument, "light field lenslet image must be CV_32FC1 (got type {})", lenslet_.type());
  if (lenslet_.cols != geometry_.width() || lenslet_.rows != geometry_.height())
    fail(Errc::InvalidArgument, "light field lenslet image is {}x{} but {}x{} elements of {}x{} need {}x{}",
         lenslet_.cols, lenslet_.rows, geometry_.spatialX, geometry_.spatialY, geometry_.angular, geometry_.angular,
         geometry_.width(), geometry_.height());
  // (One NaN would spread to every interpolated lookup that weighs it, even by 0.)
  if (const auto bad = firstNonFinite(lenslet_))
    fail(Errc::InvalidArgument, "light field lenslet pixel ({}, {}) is {}; radiance must be finite", bad->x, bad->y,
         lenslet_.at<float>(*bad));
  if (const auto bad = firstNegative(lenslet_))
    fail(Errc::InvalidArgument, "light field lenslet pixel ({}, {}) is {}; radiance cannot be negative", bad->x, bad->y,
         lenslet_.at<float>(*bad));
}

Vec2 LightField::elementCentre(int ex, int ey) const {
  const double e = geometry_.elementPitch_mm();
  return {(ex + 0.5 - 0.5 * geometry_.spatialX) * e, (ey + 0.5 - 0.5 * geometry_.spatialY) * e};
}

Vec2 LightField::angularCentre(int u, int v) const {
  const double n = geometry_.angular;
  return {(2 * u + 1) / n - 1, (2 * v + 1) / n - 1};
}

Vec3 LightField::directionFromDisc(const Vec2& p) {
  const double r2 = p.x * p.x + p.y * p.y;
  return {-p.x, -p.y, std::sqrt(std::max(0.0, 1 - r2))};
}

bool LightField::discFromDirection(const Vec3& d, Vec2& p) {
  const double len = d.length();
  if (!(len > 0 && len < std::numeric_limits<double>::infinity()) || !(d.z > 0)) return false;
  p = {-d.x / len, -d.y / len};
  return true;
}

namespace {

// Continuous index whose integers are cell centres, split into a base cell and
// a weight for the next one; clamped so that values beyond the outer centres
// hold the outer value.
struct Lerp {
  int i0;
  int i1;
  double t;
};

Lerp lerpIndex(double coordinate, int count) {
  if (count == 1 || !(coordinate > 0)) return {0, 0, 0};  // (NaN too: no cast of it to int)
  if (coordinate >= count - 1) return {count - 1, count - 1, 0};
  const int i0 = static_cast<int>(coordinate);
  return {i0, i0 + 1, coordinate - i0};
}

}  // namespace

double LightField::nearestSample(int ex, int ey, const Vec2& disc) const {
  const int n = geometry_.angular;
  const double ax = 0.5 * (disc.x + 1) * n;  // in pixel units, 0..n across the element
  const double ay = 0.5 * (disc.y + 1) * n;
  // floor, clamped to the element; NaN and values past int's range never cast
  const int u = ax > 0 ? (ax < n ? static_cast<int>(ax) : n - 1) : 0;
  const int v = ay > 0 ? (ay < n ? static_cast<int>(ay) : n - 1) : 0;
  return at(ex, ey, u, v);
}

double LightField::radiance(const Vec2& q, const Vec3& d, LightFieldLookup mode) const {
  Vec2 disc;
  if (!discFromDirection(d, disc) || disc.x * disc.x + disc.y * disc.y >= 1) return 0;
  return radianceFromDisc(q, disc, mode);
}

double LightField::radianceAt(double sx, double sy, const Vec2& disc, LightFieldLookup mode) const {
  if (lenslet_.data == nullptr) return 0;  // (a geometry's image is never empty; Mat::empty() is a call)
  if (!(sx >= 0 && sx < geometry_.spatialX && sy >= 0 && sy < geometry_.spatialY)) return 0;
  if (mode == LightFieldLookup::Nearest) return nearestSample(static_cast<int>(sx), static_cast<int>(sy), disc);
  // Bilinear in angle within each of the four elements around (sx, sy), then
  // bilinear across them. The angular cell and weights are the same in every
  // element: found once.
  const int n = geometry_.angular;
  const double ax = 0.5 * (disc.x + 1) * n, ay = 0.5 * (disc.y + 1) * n;  // pixel units, 0..n across an element
  const Lerp lu = lerpIndex(ax - 0.5, n), lv = lerpIndex(ay - 0.5, n);
  auto element = [&](int ex, int ey) {
    const float* v0 = lenslet_.ptr<float>(ey * n + lv.i0) + ex * n;
    const float* v1 = lenslet_.ptr<float>(ey * n + lv.i1) + ex * n;
    return (1 - lv.t) * ((1 - lu.t) * v0[lu.i0] + lu.t * v0[lu.i1]) +
           lv.t * ((1 - lu.t) * v1[lu.i0] + lu.t * v1[lu.i1]);
  };
  const Lerp lx = lerpIndex(sx - 0.5, geometry_.spatialX), ly = lerpIndex(sy - 0.5, geometry_.spatialY);
  return (1 - ly.t) * ((1 - lx.t) * element(lx.i0, ly.i0) + lx.t * element(lx.i1, ly.i0)) +
         ly.t * ((1 - lx.t) * element(lx.i0, ly.i1) + lx.t * element(lx.i1, ly.i1));
}

LightField binaryDrive(const LightField& captured, double threshold) {
  if (!(threshold > 0 && threshold <= 1))
    fail(Errc::InvalidArgument, "binary drive threshold {} is outside (0, 1]", threshold);
  double brightest = 0;
  cv::minMaxLoc(captured.lensletImage(), nullptr, &brightest);
  if (!(brightest > 0)) fail(Errc::InvalidArgument, "binary drive: the captured light field holds no light");
  cv::Mat lit;
  cv::compare(captured.lensletImage(), threshold * brightest, lit, cv::CMP_GE);
  cv::Mat drive;
  lit.convertTo(drive, CV_32FC1, 1.0 / 255);
  return LightField(captured.geometry(), std::move(drive));
}

}  // namespace lfi
