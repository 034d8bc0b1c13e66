#include "lfi/calib/display_distance.h"

#include "lfi/core/error.h"

#include <algorithm>
#include <cmath>

namespace lfi::calib {

LightField propagateLightField(const LightField& lightField, double dz, LightFieldLookup lookup) {
  if (!std::isfinite(dz)) fail(Errc::InvalidArgument, "propagateLightField: dz = {} is not finite", dz);
  const LightFieldGeometry& g = lightField.geometry();
  LightFieldGeometry out = g;
  out.distance_mm = std::max(0.0, g.distance_mm - dz);
  LightField result(out);
  for (int ey = 0; ey < g.spatialY; ++ey)
    for (int ex = 0; ex < g.spatialX; ++ex) {
      const Vec2 q = lightField.elementCentre(ex, ey);
      for (int v = 0; v < g.angular; ++v)
        for (int u = 0; u < g.angular; ++u) {
          const Vec2 disc = lightField.angularCentre(u, v);
          if (disc.x * disc.x + disc.y * disc.y >= 1) continue;
          const Vec3 d = LightField::directionFromDisc(disc);
          // The ray through q on the new plane crossed the old one dz earlier.
          const Vec2 source(q.x - dz * d.x / d.z, q.y - dz * d.y / d.z);
          result.at(ex, ey, u, v) = static_cast<float>(lightField.radiance(source, d, lookup));
        }
    }
  return result;
}

DisplayDistanceScan calibrateDisplayDistance(const LightField& captured, const InspectFunction& inspect,
                                             const std::vector<double>& candidates, const cv::Mat& roi) {
  if (candidates.size() < 3)
    fail(Errc::InvalidArgument, "display distance calibration needs at least 3 candidates (got {})", candidates.size());
  if (!std::is_sorted(candidates.begin(), candidates.end()) ||
      std::adjacent_find(candidates.begin(), candidates.end()) != candidates.end())
    fail(Errc::InvalidArgument, "display distance calibration: candidates must be strictly increasing");
  DisplayDistanceScan scan;
  scan.candidates_mm = candidates;
  for (double epsilon : candidates) {
    // The display is ε further away: show the field as it is ε further away.
    cv::Mat image = inspect(propagateLightField(captured, -epsilon));
    if (image.empty()) fail(Errc::Device, "display distance calibration: the camera returned no image");
    cv::Mat f;
    image.convertTo(f, CV_32F);
    if (f.channels() != 1) fail(Errc::InvalidArgument, "display distance calibration needs a single-channel image");
    if (!roi.empty() && roi.size() != f.size())
      fail(Errc::InvalidArgument, "display distance calibration: ROI {}x{} does not match the image {}x{}", roi.cols,
           roi.rows, f.cols, f.rows);
    scan.brightness.push_back(roi.empty() ? cv::mean(f)[0] : cv::mean(f, roi)[0]);
  }
  const auto best = static_cast<size_t>(
      std::max_element(scan.brightness.begin(), scan.brightness.end()) - scan.brightness.begin());
  scan.estimate_mm = candidates[best];
  if (best > 0 && best + 1 < candidates.size()) {
    // Vertex of the parabola through the best point and its neighbours.
    const double x0 = candidates[best - 1], x1 = candidates[best], x2 = candidates[best + 1];
    const double y0 = scan.brightness[best - 1], y1 = scan.brightness[best], y2 = scan.brightness[best + 1];
    const double denom = (x0 - x1) * (x0 - x2) * (x1 - x2);
    const double a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / denom;
    const double b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / denom;
    if (a < 0) scan.estimate_mm = std::clamp(-b / (2 * a), x0, x2);
  }
  return scan;
}

}  // namespace lfi::calib
