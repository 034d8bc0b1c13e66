// SPDX-License-Identifier: Apache-2.0
// A lenticular sheet's or line barrier's display calibration after the Gray
// code (display_calibration.h): the axes; the camera's scale from a sheet's
// stripes or a barrier's decoded pixels; a barrier's slit.

#include "display_calibration_steps.h"

#include "lfi/calib/axis_fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <vector>

namespace lfi::detail {

namespace {

// The axes in the display frame (mm): axis m passes through origin(m) along `along`; `across` the in-plane normal.
struct AxisFrame {
  Vec2 along, across;
  double q;  // panel pixel, mm
  const calib::AxisFit& fit;
  AxisFrame(const calib::AxisFit& f, double pixel_mm)
      : along(std::sin(f.slant_rad), std::cos(f.slant_rad)),
        across(std::cos(f.slant_rad), -std::sin(f.slant_rad)),
        q(pixel_mm),
        fit(f) {}
  Vec2 origin(int m) const { return {fit.x(m, 0) * q, 0}; }
  int axis(const Vec2& p) const { return fit.nearestAxis(p.x / q, p.y / q); }
  // The point of axis m at `u` along it (u = p · along for a point p of the axis).
  Vec2 point(int m, double u) const { return origin(m) + (u - origin(m).dot(along)) * along; }
  double perpPitch_mm() const { return fit.pitch_px * q * std::cos(fit.slant_rad); }
};

using Segment = std::array<int, 2>;  // axis, and the segment of it (`length` long) a point lies in

Segment segmentOf(const AxisFrame& frame, const Vec2& p, double length) {
  return {frame.axis(p), static_cast<int>(std::floor(p.dot(frame.along) / length))};
}

// A first camera scale from the decoded pixels: per segment of an axis, where its camera pixels lie against where
// the panel points they decoded lie, weighted by light.
std::vector<calib::CameraPoint> roughPoints(const calib::PanelCorrespondence& c, const cv::Mat& light,
                                            const DisplayInfo& info, const AxisFrame& frame, double length) {
  struct Sum {
    Vec2 camera{0, 0}, display{0, 0};
    double weight = 0;
  };
  std::map<Segment, Sum> sums;
  for (int row = 0; row < light.rows; ++row)
    for (int col = 0; col < light.cols; ++col) {
      const cv::Vec2i p = c.panel.at<cv::Vec2i>(row, col);
      const double w = light.at<float>(row, col);
      if (p[0] < 0 || !(w > 0)) continue;
      const Vec2 d = panelPixelCentre(info, p[0], p[1]);
      Sum& s = sums[segmentOf(frame, d, length)];
      s.camera += w * Vec2(col, row);
      s.display += w * d;
      s.weight += w;
    }
  std::vector<calib::CameraPoint> out;
  for (const auto& [segment, s] : sums) out.push_back({s.camera / s.weight, s.display / s.weight, segment});
  return out;
}

// The panel of stripe frame a: the cells of every axis m ≡ a (mod s) lit.
cv::Mat stripePanel(const DisplayInfo& info, const AxisFrame& frame, int s, int a) {
  cv::Mat levels = cv::Mat::zeros(info.panelHeight_px, info.panelWidth_px, CV_8UC1);
  for (int row = 0; row < levels.rows; ++row)
    for (int col = 0; col < levels.cols; ++col) {
      const int m = frame.axis(panelPixelCentre(info, col, row));
      if (((m % s) + s) % s == a) levels.at<std::uint8_t>(row, col) = 255;
    }
  return levels;
}

// A stripe's point: the light's centroid in a square window about `guess`, moved to the centroid until it moves
// less than 0.01 pixel (at most 5 times). A square about a point of a straight stripe holds a part of it
// symmetric about that point, so across the stripe the centroid finds its middle; along it, it stays where it is.
// `u` is the mean of the decoded panel points' place along the axis, with the same weights: where along the axis
// the centroid lies. Empty when the window leaves the image or less than half its light is decoded.
struct StripePoint {
  Vec2 centre_px;
  double u = 0, light = 0;
};

std::optional<StripePoint> stripeCentroid(const cv::Mat& image, const calib::PanelCorrespondence& c,
                                          const DisplayInfo& info, const AxisFrame& frame, Vec2 guess, double radius) {
  StripePoint out;
  for (int iteration = 0; iteration < 5; ++iteration) {
    if (!(std::abs(guess.x) < 1e9 && std::abs(guess.y) < 1e9)) return std::nullopt;
    const int x0 = static_cast<int>(std::ceil(guess.x - radius)), x1 = static_cast<int>(std::floor(guess.x + radius));
    const int y0 = static_cast<int>(std::ceil(guess.y - radius)), y1 = static_cast<int>(std::floor(guess.y + radius));
    if (x0 < 0 || y0 < 0 || x1 >= image.cols || y1 >= image.rows) return std::nullopt;
    Vec2 sum(0, 0);
    double weight = 0, uSum = 0, uWeight = 0;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double w = image.at<float>(y, x);  // (the dark's noise unclipped: it averages out)
        sum += w * Vec2(x, y);
        weight += w;
        if (const cv::Vec2i p = c.panel.at<cv::Vec2i>(y, x); p[0] >= 0) {
          uSum += w * panelPixelCentre(info, p[0], p[1]).dot(frame.along);
          uWeight += w;
        }
      }
    if (!(weight > 0) || uWeight < 0.5 * weight) return std::nullopt;
    const Vec2 centre = sum / weight;
    out = {centre, uSum / uWeight, weight};
    const double moved = (centre - guess).length();
    guess = centre;
    if (moved < 0.01) break;
  }
  return out;
}

// A line barrier's slit from the light of a band of n panel pixels along each axis against the all-white panel's:
// behind a slit every point of the band is seen whole (the band lies within the slit, by the camera's aperture),
// and of the white panel the slit's width; so per unit of axis length band / white = n q cos s / slit. Measured
// per axis over the camera pixels nearest it; the slit's standard uncertainty is the axes' spread over √axes.
struct Slit {
  double width_mm = 0, sigma_mm = 0;
  double band_mm = 0;
  int axes = 0;
};

cv::Mat bandPanel(const DisplayInfo& info, const AxisFrame& frame, int n) {
  cv::Mat levels = cv::Mat::zeros(info.panelHeight_px, info.panelWidth_px, CV_8UC1);
  const double halfWidth = 0.5 * info.panelWidth_px, halfHeight = 0.5 * info.panelHeight_px;
  for (int row = 0; row < levels.rows; ++row) {
    const double y = halfHeight - row - 0.5;
    const int first = frame.fit.nearestAxis(-halfWidth - frame.fit.pitch_px, y);
    const int last = frame.fit.nearestAxis(halfWidth + frame.fit.pitch_px, y);
    for (int m = first; m <= last; ++m) {
      // The n columns whose centres lie nearest the axis on this row.
      const int start = static_cast<int>(std::lround(frame.fit.x(m, y) + halfWidth - 0.5 - 0.5 * (n - 1)));
      for (int col = std::max(0, start); col < std::min(levels.cols, start + n); ++col)
        levels.at<std::uint8_t>(row, col) = 255;
    }
  }
  return levels;
}

Slit measureSlit(FrameTaker& take, const GrayCodeView& view, const DisplayInfo& info, const AxisFrame& frame,
                 const calib::CameraMap& camera, Clock::duration& compute) {
  const double cosS = std::cos(frame.fit.slant_rad);
  // A band a third of the stated slit wide (at least a pixel): with the pixel's phase it stays within the slit
  // with the camera's aperture's blur to spare.
  const int n = std::max(1, static_cast<int>(std::floor(info.optics.slitWidth_mm / (3 * info.pixelPitch_mm * cosS))));
  const cv::Mat band = take(bandPanel(info, frame, n), "slit band") - view.black;
  const auto start = Clock::now();
  Slit slit;
  slit.band_mm = n * info.pixelPitch_mm * cosS;
  std::map<int, std::pair<double, double>> perAxis;  // band, white light
  double bandSum = 0, whiteSum = 0;
  const cv::Mat white = view.white - view.black;
  for (int row = 0; row < band.rows; ++row)
    for (int col = 0; col < band.cols; ++col) {
      const int m = frame.axis(camera.displayPoint(Vec2(col, row), band.size()));
      auto& [b, w] = perAxis[m];
      b += band.at<float>(row, col);
      w += white.at<float>(row, col);
      bandSum += band.at<float>(row, col);
      whiteSum += white.at<float>(row, col);
    }
  if (!(bandSum > 0) || !(whiteSum > 0))
    fail(Errc::Device,
         "display calibration: the camera sees no light through the slits of display '{}' from a band "
         "of {} panel pixel(s) along each axis",
         info.deviceId, n);
  slit.width_mm = slit.band_mm * whiteSum / bandSum;
  // The axes the image holds whole: white light at least half the median axis's.
  std::vector<double> whites;
  for (const auto& [m, s] : perAxis) whites.push_back(s.second);
  const double least = 0.5 * median(whites);
  double sum = 0, sum2 = 0;
  for (const auto& [m, s] : perAxis)
    if (s.second >= least && s.first > 0) {
      const double w = slit.band_mm * s.second / s.first;
      sum += w, sum2 += w * w;
      ++slit.axes;
    }
  if (slit.axes < 3)
    fail(Errc::Device, "display calibration: {} slits of display '{}' whole in the camera's view, fewer than 3",
         slit.axes, info.deviceId);
  const double a = slit.axes;
  slit.sigma_mm = std::sqrt(std::max(0.0, (sum2 - sum * sum / a) / (a - 1)) / a);
  // The band must lie within the slit, pixel phase (up to a pixel off the axis) and the aperture's blur included.
  if (slit.width_mm < slit.band_mm + 2 * info.pixelPitch_mm)
    fail(Errc::Device,
         "display calibration: the slits of display '{}' measure {:.4g} mm, too narrow for a band of {} panel "
         "pixel(s) ({:.4g} mm) and its pixel's phase to lie within them: the slit is not measurable on this panel",
         info.deviceId, slit.width_mm, n, slit.band_mm);
  compute += Clock::now() - start;
  return slit;
}

}  // namespace

int axesFrames(const DisplayInfo& info, const DisplayCalibrationSettings& settings) {
  return info.optics.type == OpticsType::LineBarrier ? 1 : settings.spotPeriod;
}

void measureAxes(DisplayCalibration& out, FrameTaker& take, const GrayCodeView& view, const DisplayInfo& info,
                 const DisplayCalibrationSettings& settings, Clock::duration& compute) {
  const std::string& name = info.deviceId;
  const calib::PanelCorrespondence& c = view.correspondence;
  auto computeStart = Clock::now();
  // The axes from the panel points the camera pixels see along the axis, weighted by their light. Left out: on
  // each panel row, the points within a slit's width (and a pixel) of the row's first and last point seen: there
  // the image's border or the panel's edge cuts a slit's width on one side, and its points' mean moves off the
  // axis.
  std::map<int, std::pair<int, int>> seenColumns;  // per panel row
  for (int row = 0; row < view.light.rows; ++row)
    for (int col = 0; col < view.light.cols; ++col)
      if (const cv::Vec2i p = c.panel.at<cv::Vec2i>(row, col); p[0] >= 0 && view.light.at<float>(row, col) > 0) {
        auto [it, added] = seenColumns.try_emplace(p[1], p[0], p[0]);
        it->second = {std::min(it->second.first, p[0]), std::max(it->second.second, p[0])};
      }
  const double slit_px = info.optics.type == OpticsType::LineBarrier
                             ? info.optics.slitWidth_mm / (info.pixelPitch_mm * std::cos(info.optics.slant_rad))
                             : 0;
  // A first fit from every point names each point's axis; the second keeps the axes' rows seen whole.
  const auto fit = [&](const calib::AxisFit* first) {
    std::vector<calib::WeightedPoint> points;
    for (int row = 0; row < view.light.rows; ++row)
      for (int col = 0; col < view.light.cols; ++col) {
        const cv::Vec2i p = c.panel.at<cv::Vec2i>(row, col);
        const double w = view.light.at<float>(row, col);
        if (p[0] < 0 || !(w > 0)) continue;
        const Vec2 centre = panelPixelCentre(info, p[0], p[1]);
        if (first) {
          // The axis in panel columns on this row, and the first and last column seen.
          const double x = first->x(first->nearestAxis(centre.x / info.pixelPitch_mm, centre.y / info.pixelPitch_mm),
                                    centre.y / info.pixelPitch_mm) +
                           0.5 * info.panelWidth_px - 0.5;
          const auto [from, to] = seenColumns.at(p[1]);
          if (x - 0.5 * slit_px - 1 < from || x + 0.5 * slit_px + 1 > to) continue;
        }
        points.push_back({centre, w});
      }
    return named(name, [&] {
      return calib::fitLensAxes(points, info.pixelPitch_mm, info.optics.lensPitch_px, info.optics.slant_rad);
    });
  };
  const calib::AxisFit firstFit = fit(nullptr);
  out.axes = fit(&firstFit);
  const int s = settings.spotPeriod;
  // A stripe's window: a lens pitch about the axis holds the stripe (half a pitch each side) and what the rough
  // scale misplaces; its corners stay clear of the next lit stripe, s pitches away. Segments a window long.
  const AxisFrame frame(out.axes, info.pixelPitch_mm);
  const double halfWindow_mm = std::min(1.0, 0.45 * s) * frame.perpPitch_mm();
  const double length = 2 * halfWindow_mm;
  compute += Clock::now() - computeStart;

  // The points' places on the panel are as good as the axes they give: their pitch's and offset's uncertainties.
  const double offsetSigma_mm = out.axes.offsetSigma_px * info.pixelPitch_mm * std::cos(out.axes.slant_rad);
  const calib::DisplayFrameSigma displaySigma = {
      out.axes.pitchSigma_px / out.axes.pitch_px,
      {offsetSigma_mm * std::abs(frame.across.x), offsetSigma_mm * std::abs(frame.across.y)}};
  std::vector<calib::CameraPoint> cameraPoints;
  if (info.optics.type == OpticsType::LineBarrier) {
    // A slit shows the panel straight under it: every decoded camera pixel sees a panel pixel of known place (to
    // its quantum, which the pixels' many phases average out).
    computeStart = Clock::now();
    for (int row = 0; row < view.light.rows; ++row)
      for (int col = 0; col < view.light.cols; ++col)
        if (const cv::Vec2i p = c.panel.at<cv::Vec2i>(row, col); p[0] >= 0 && view.light.at<float>(row, col) > 0) {
          const Vec2 d = panelPixelCentre(info, p[0], p[1]);
          cameraPoints.push_back({Vec2(col, row), d, segmentOf(frame, d, length)});
        }
    compute += Clock::now() - computeStart;
  } else {
    // Stripes: the cells of every s-th axis lit, s frames; each stripe's points found about the segments' rough
    // places, which a first camera scale from the decoded pixels gives.
    computeStart = Clock::now();
    const calib::CameraScaleFit first =
        named(name, [&] { return calib::fitCameraScale(roughPoints(c, view.light, info, frame, length), out.image); });
    compute += Clock::now() - computeStart;
    const double window_px = std::max(1.5, halfWindow_mm / first.objectPixel_mm);
    std::vector<std::pair<calib::CameraPoint, double>> found;  // and each one's light
    for (int a = 0; a < s; ++a) {
      const cv::Mat image = take(stripePanel(info, frame, s, a), "stripes") - view.black;
      computeStart = Clock::now();
      std::set<Segment> seen;
      for (int row = 0; row < image.rows; ++row)
        for (int col = 0; col < image.cols; ++col)
          if (const cv::Vec2i p = c.panel.at<cv::Vec2i>(row, col); p[0] >= 0) {
            const Segment segment = segmentOf(frame, panelPixelCentre(info, p[0], p[1]), length);
            if (((segment[0] % s) + s) % s == a) seen.insert(segment);
          }
      for (const Segment& segment : seen) {
        const int m = segment[0];
        const Vec2 middle = frame.point(m, (segment[1] + 0.5) * length);
        if (auto point = stripeCentroid(image, c, info, frame, first.map.cameraPoint(middle, out.image), window_px))
          found.push_back({{point->centre_px, frame.point(m, point->u), segment}, point->light});
      }
      compute += Clock::now() - computeStart;
    }
    computeStart = Clock::now();
    // A stripe the image's or the panel's edge cuts holds less light.
    if (!found.empty()) {
      std::vector<double> lights;
      for (const auto& f : found) lights.push_back(f.second);
      const double least = 0.5 * median(lights);
      for (const auto& [point, pointLight] : found)
        if (pointLight >= least) cameraPoints.push_back(point);
    }
    compute += Clock::now() - computeStart;
  }
  computeStart = Clock::now();
  out.camera = named(name, [&] { return calib::fitCameraScale(cameraPoints, out.image, displaySigma); });
  // Points further than five robust standard deviations (at least a panel pixel) from the fit left out (a pixel
  // whose code a bit misread), and the camera fitted again.
  std::vector<double> misses;
  for (const calib::CameraPoint& p : cameraPoints)
    misses.push_back((out.camera.map.displayPoint(p.camera_px, out.image) - p.display_mm).length());
  const double limit = std::max(5 * 1.4826 * median(misses), info.pixelPitch_mm);
  std::vector<calib::CameraPoint> kept;
  for (size_t k = 0; k < cameraPoints.size(); ++k)
    if (misses[k] <= limit) kept.push_back(cameraPoints[k]);
  if (kept.size() < cameraPoints.size())
    out.camera = named(name, [&] { return calib::fitCameraScale(kept, out.image, displaySigma); });
  out.spots = static_cast<int>(kept.size());
  compute += Clock::now() - computeStart;

  out.optics = info.optics;
  out.optics.lensPitch_px = out.axes.pitch_px;
  out.optics.slant_rad = out.axes.slant_rad;
  out.optics.offset_px = out.axes.offset_px;
  if (info.optics.type == OpticsType::LineBarrier) {
    const Slit slit = measureSlit(take, view, info, frame, out.camera.map, compute);
    out.optics.slitWidth_mm = slit.width_mm;
    out.slitWidthSigma_mm = slit.sigma_mm;
  }
}

}  // namespace lfi::detail
