// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/display_calibration.h"

#include "display_calibration_steps.h"

#include "lfi/calib/coded_patterns.h"
#include "lfi/calib/coded_reference.h"
#include "lfi/core/error.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

namespace lfi {

namespace {

using detail::Clock;
using detail::seconds;

void checkSettings(const DisplayCalibrationSettings& s) {
  const auto check = [](bool ok, const char* key, double value, const char* range) {
    if (!ok) fail(Errc::InvalidArgument, "display calibration: {} = {} is outside {}", key, value, range);
  };
  check(s.spotPeriod >= 2 && s.spotPeriod <= 16, "spot_period", s.spotPeriod, "2 .. 16");
  check(s.spotRadius > 0 && s.spotRadius < 0.5, "spot_radius", s.spotRadius, "(0, 0.5) pitches");
  check(s.minDecoded > 0 && s.minDecoded <= 1, "min_decoded", s.minDecoded, "(0, 1]");
  check(s.secondShare >= 0 && s.secondShare < 0.5, "second_share", s.secondShare, "[0, 0.5)");
  check(s.coverageFactor > 0 && s.coverageFactor <= 10, "coverage_factor", s.coverageFactor, "(0, 10]");
}

using LensIndex = std::array<int, 2>;
using detail::named;

// The decoded panel pixels, weighted by the light each link carries, clustered per lens; clusters of little
// light (a misdecoded pixel, not a lens) left out.
std::vector<calib::WeightedPoint> lensCentres(const calib::PanelLinks& links, const cv::Mat& light,
                                              const DisplayInfo& info) {
  std::map<int, double> panelWeight;
  for (const calib::PanelLinks::Link& link : links.links()) {
    const double w = link.share * light.at<float>(link.camera / light.cols, link.camera % light.cols);
    if (w > 0) panelWeight[link.panel] += w;
  }
  if (panelWeight.empty()) return {};
  std::vector<calib::WeightedPoint> points;
  for (const auto& [p, w] : panelWeight)
    points.push_back({detail::panelPixelCentre(info, p % info.panelWidth_px, p / info.panelWidth_px), w});
  std::vector<calib::WeightedPoint> centres = calib::clusterPoints(points, 0.25 * info.optics.arrayPitch_mm);
  std::vector<double> weights;
  for (const calib::WeightedPoint& c : centres) weights.push_back(c.weight);
  const double floor = 0.1 * detail::median(weights);
  std::erase_if(centres, [&](const calib::WeightedPoint& c) { return c.weight < floor; });
  return centres;
}

// A first camera scale from the decoded links: where each lens shows, weighted by its light.
std::vector<calib::CameraPoint> roughSpots(const calib::PanelLinks& links, const cv::Mat& light,
                                           const DisplayInfo& info, const calib::LatticeFit& lattice) {
  std::map<LensIndex, std::pair<Vec2, double>> seen;
  for (const calib::PanelLinks::Link& link : links.links()) {
    const int row = link.camera / light.cols, col = link.camera % light.cols;
    const double w = link.share * light.at<float>(row, col);
    const Vec2 p = detail::panelPixelCentre(info, link.panel % info.panelWidth_px, link.panel / info.panelWidth_px);
    const LensIndex lens = lattice.nearestIndex(p);
    if (!(w > 0) || (p - lattice.centre(lens[0], lens[1])).length() > 0.25 * lattice.pitch_mm) continue;
    auto& [sum, weight] = seen.try_emplace(lens, Vec2(0, 0), 0.0).first->second;
    sum += w * Vec2(col, row);
    weight += w;
  }
  std::vector<calib::CameraPoint> rough;
  for (const auto& [lens, s] : seen) rough.push_back({s.first / s.second, lattice.centre(lens[0], lens[1]), lens});
  return rough;
}

// The panel of spot frame (a, b): a disc of `radius_mm` about every lens (i, j) with i ≡ a, j ≡ b (mod s) whose
// cell lies on the panel; those lenses in `lit`.
cv::Mat spotPanel(const DisplayInfo& info, const calib::LatticeFit& lattice, int s, int a, int b, double radius_mm,
                  std::vector<LensIndex>& lit) {
  const cv::Size panel(info.panelWidth_px, info.panelHeight_px);
  const double q = info.pixelPitch_mm;
  const double halfWidth = 0.5 * panel.width * q, halfHeight = 0.5 * panel.height * q;
  const double inside = 0.5 * lattice.pitch_mm;
  int iMin = 1 << 30, iMax = -(1 << 30), jMin = 1 << 30, jMax = -(1 << 30);
  for (const Vec2& corner : {Vec2(-halfWidth, -halfHeight), Vec2(halfWidth, -halfHeight), Vec2(-halfWidth, halfHeight),
                             Vec2(halfWidth, halfHeight)}) {
    const LensIndex k = lattice.nearestIndex(corner);
    iMin = std::min(iMin, k[0] - 2), iMax = std::max(iMax, k[0] + 2);
    jMin = std::min(jMin, k[1] - 2), jMax = std::max(jMax, k[1] + 2);
  }
  const int reach = static_cast<int>(std::ceil(radius_mm / q));
  cv::Mat levels = cv::Mat::zeros(panel, CV_8UC1);
  lit.clear();
  for (int i = iMin; i <= iMax; ++i)
    for (int j = jMin; j <= jMax; ++j) {
      if (((i % s) + s) % s != a || ((j % s) + s) % s != b) continue;
      const Vec2 centre = lattice.centre(i, j);
      if (std::abs(centre.x) > halfWidth - inside || std::abs(centre.y) > halfHeight - inside) continue;
      lit.push_back({i, j});
      const int col = static_cast<int>(centre.x / q + 0.5 * panel.width - 0.5);
      const int row = static_cast<int>(0.5 * panel.height - 0.5 - centre.y / q);
      for (int y = std::max(0, row - reach); y <= std::min(panel.height - 1, row + reach + 1); ++y)
        for (int x = std::max(0, col - reach); x <= std::min(panel.width - 1, col + reach + 1); ++x)
          if ((detail::panelPixelCentre(info, x, y) - centre).length() <= radius_mm)
            levels.at<std::uint8_t>(y, x) = 255;
    }
  return levels;
}

// A lens or pinhole array's steps after the Gray code: the lattice, the spots, the camera's scale.
void measureArray(DisplayCalibration& out, detail::FrameTaker& take, const detail::GrayCodeView& view,
                  const DisplayInfo& info, const DisplayCalibrationSettings& settings, Clock::duration& compute) {
  const std::string& name = info.deviceId;
  const cv::Size panel(info.panelWidth_px, info.panelHeight_px);
  auto computeStart = Clock::now();
  const calib::PanelCorrespondence& c = view.correspondence;
  const cv::Mat& black = view.black;
  const cv::Mat& light = view.light;
  calib::PanelLinks links(out.image, panel);
  links.add(c, {}, 0);
  const std::vector<calib::WeightedPoint> centres = lensCentres(links, light, info);
  out.lattice = named(name, [&] {
    return calib::fitLensLattice(centres, info.optics.packing, info.optics.arrayPitch_mm, info.optics.rotation_rad,
                                 info.pixelPitch_mm);
  });
  const calib::LatticeFit& lattice = out.lattice;
  const calib::CameraScaleFit first =
      named(name, [&] { return calib::fitCameraScale(roughSpots(links, light, info, lattice), out.image); });
  compute += Clock::now() - computeStart;

  // Spots: every s-th lens along each lattice axis, s² frames; each found about where the first scale puts it.
  const int s = settings.spotPeriod;
  const double radius_mm = std::max(settings.spotRadius * lattice.pitch_mm, 1.5 * info.pixelPitch_mm);
  const double window_px = std::max(1.5, 0.45 * s * lattice.pitch_mm / first.objectPixel_mm);
  std::vector<std::pair<calib::CameraPoint, double>> spots;  // and each one's light
  std::vector<LensIndex> lit;
  for (int a = 0; a < s; ++a)
    for (int b = 0; b < s; ++b) {
      const cv::Mat image = take(spotPanel(info, lattice, s, a, b, radius_mm, lit), "spots") - black;
      computeStart = Clock::now();
      for (const LensIndex& lens : lit) {
        const Vec2 centre = lattice.centre(lens[0], lens[1]);
        if (auto spot = calib::spotCentroid(image, first.map.cameraPoint(centre, out.image), window_px, 0))
          spots.push_back({{spot->centre_px, centre, lens}, spot->light});
      }
      compute += Clock::now() - computeStart;
    }
  computeStart = Clock::now();
  // A spot of a lens the image or the panel's edge cuts holds less light.
  std::vector<calib::CameraPoint> spotPoints;
  if (!spots.empty()) {
    std::vector<double> lights;
    for (const auto& spot : spots) lights.push_back(spot.second);
    const double least = 0.5 * detail::median(lights);
    for (const auto& [point, spotLight] : spots)
      if (spotLight >= least) spotPoints.push_back(point);
  }
  out.spots = static_cast<int>(spotPoints.size());
  out.camera = named(name, [&] {
    return calib::fitCameraScale(spotPoints, out.image,
                                 {lattice.pitchSigma_mm / lattice.pitch_mm, lattice.offsetSigma_mm});
  });
  compute += Clock::now() - computeStart;

  out.optics = info.optics;
  out.optics.arrayPitch_mm = lattice.pitch_mm;
  out.optics.rotation_rad = lattice.rotation_rad;
  out.optics.arrayOffsetX_mm = lattice.offset_mm.x;
  out.optics.arrayOffsetY_mm = lattice.offset_mm.y;
}

}  // namespace

DisplayCalibration calibrateDisplay(BenchProbe& bench, const DisplayCalibrationSettings& settings,
                                    const std::function<void(double)>& progress) {
  checkSettings(settings);
  const auto start = Clock::now();
  Clock::duration compute{};
  DisplayCalibration out;
  out.coverageFactor = settings.coverageFactor;
  const DisplayInfo info = bench.display();
  info.validate();
  out.nominal = info;
  const bool array = fullParallax(info.optics.type);
  const int totalFrames = calib::GrayCodeLayout::forPanel(info.panelWidth_px, info.panelHeight_px).frameCount() +
                          (array ? settings.spotPeriod * settings.spotPeriod : detail::axesFrames(info, settings));
  detail::FrameTaker take(bench, "display calibration", info.deviceId, totalFrames, progress);

  // Which panel pixels each camera pixel sees along the axis.
  const detail::GrayCodeView view = detail::takeGrayCode(
      take, info, bench.cameraFullScale_dn(), settings.secondShare, settings.minDecoded, "display calibration",
      array ? "the patterns blur, or something in the camera's view scatters the light"
            : "a lenticular sheet or line barrier must lie in the camera's focus for this step, and the camera's "
              "pixels must be no larger than the panel's: along its axes nothing else keeps the panel's pixels "
              "apart (or something in the camera's view scatters the light)");
  compute += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(view.decodeSeconds));
  out.image = view.white.size();
  out.lit = view.correspondence.lit;
  out.decoded = view.correspondence.decoded;
  if (array)
    measureArray(out, take, view, info, settings, compute);
  else
    detail::measureAxes(out, take, view, info, settings, compute);
  out.frames = take.frames();
  if (progress) progress(1);
  out.seconds = seconds(Clock::now() - start);
  out.computeSeconds = seconds(compute);
  return out;
}

}  // namespace lfi
