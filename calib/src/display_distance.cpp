// SPDX-License-Identifier: Apache-2.0
#include "lfi/calib/display_distance.h"

#include "lfi/core/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace lfi::calib {

LightField propagateLightField(const LightField& lightField, double dz, LightFieldLookup lookup) {
  if (!std::isfinite(dz)) fail(Errc::InvalidArgument, "propagateLightField: dz = {} is not finite", dz);
  const LightFieldGeometry& g = lightField.geometry();
  if (g.distance_mm - dz < 0)
    fail(Errc::InvalidArgument,
         "propagateLightField: moving the plane {} mm towards the part, which is {} mm away, would pass it", dz,
         g.distance_mm);
  LightFieldGeometry out = g;
  out.distance_mm = g.distance_mm - dz;
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

namespace {

constexpr double kPeakLevel = 0.25;            // the flanks' level: this fraction of the way down from the peak
constexpr double kClearAboveNoise = 10.0;      // the scan's rise must exceed this many times the noise of a mean
constexpr double kSecondPeakAboveNoise = 3.0;  // a second peak: this many times the noise above the level
constexpr double kDriftAboveNoise = 5.0;       // the brightest candidate's two means may differ by this many noises

std::string scanTable(const std::vector<double>& candidates, const std::vector<double>& brightness) {
  std::string table;
  for (size_t i = 0; i < brightness.size(); ++i)
    table += fmt::format("{}{:+g} mm: {:.6g}", i ? ", " : "", candidates[i], brightness[i]);
  return table;
}

}  // namespace

void checkDisplayDistanceCandidates(const LightFieldGeometry& reference, const std::vector<double>& candidates) {
  constexpr const char* kWhat = "display distance calibration";
  if (candidates.size() < 3)
    fail(Errc::InvalidArgument, "{} needs at least 3 candidates (got {})", kWhat, candidates.size());
  if (!std::all_of(candidates.begin(), candidates.end(), [](double c) { return std::isfinite(c); }) ||
      std::adjacent_find(candidates.begin(), candidates.end(), std::greater_equal<>()) != candidates.end())
    fail(Errc::InvalidArgument, "{}: candidates must be finite and strictly increasing", kWhat);
  if (reference.distance_mm <= 0)
    fail(Errc::InvalidArgument,
         "{}: the reference light field does not say how far from the part it was captured "
         "(its distance_mm, the file's lfi.distance_mm, is 0: not set); the scan moves the display from there",
         kWhat);
  if (const double distance = reference.distance_mm; distance + candidates.front() <= 0)
    fail(Errc::InvalidArgument, "{}: candidate {:+g} mm would put the display at or past the part ({} mm away)", kWhat,
         candidates.front(), distance);
}

DisplayDistanceScan calibrateDisplayDistance(const LightField& captured, const InspectFunction& inspect,
                                             const std::vector<double>& candidates, const cv::Mat& roi,
                                             double pixelNoiseFloor) {
  constexpr const char* kWhat = "display distance calibration";
  checkDisplayDistanceCandidates(captured.geometry(), candidates);
  if (!roi.empty() && roi.type() != CV_8UC1)
    fail(Errc::InvalidArgument, "{}: the ROI must be a CV_8UC1 mask (it is of OpenCV type {})", kWhat, roi.type());
  if (!roi.empty() && cv::countNonZero(roi) == 0)
    fail(Errc::InvalidArgument, "{}: the ROI has no non-zero pixel", kWhat);
  if (!(pixelNoiseFloor >= 0) || !std::isfinite(pixelNoiseFloor))
    fail(Errc::InvalidArgument, "{}: pixel noise floor {} must be finite and >= 0", kWhat, pixelNoiseFloor);
  // The image of `shown`, as float, checked against the region, and its mean over the region.
  struct Measured {
    cv::Mat image;
    double mean;
  };
  cv::Size size;  // the first image's: every other one must have it
  DisplayDistanceScan scan;
  scan.candidates_mm = candidates;
  auto measure = [&](const LightField& shown, const std::string& what) {
    cv::Mat image;
    try {
      image = inspect(shown);
    } catch (const Error& e) {  // (a camera that stalled, a display that vanished): what the scan had so far
      throw Error(e.code(), fmt::format("{}: the image {} failed: {}{}{}", kWhat, what, e.what(),
                                        scan.brightness.empty() ? "" : "; the scan so far: ",
                                        scanTable(candidates, scan.brightness)));
    }
    if (image.empty()) fail(Errc::Device, "{}: the camera returned no image {}", kWhat, what);
    if (image.channels() != 1)
      fail(Errc::InvalidArgument, "{} needs a single-channel image; the one {} has {}", kWhat, what, image.channels());
    cv::Mat f;
    image.convertTo(f, CV_32F);
    if (size.empty()) size = f.size();
    if (f.size() != size)
      fail(Errc::Device,
           "{}: the image {} is {}x{}, the first one (with the display dark) {}x{}: did the camera's "
           "region or binning change during the scan?",
           kWhat, what, f.cols, f.rows, size.width, size.height);
    if (!roi.empty() && roi.size() != f.size())
      fail(Errc::InvalidArgument, "{}: the ROI is {}x{}, the image {} {}x{}", kWhat, roi.cols, roi.rows, what, f.cols,
           f.rows);
    cv::Scalar mean, deviation;
    cv::meanStdDev(f, mean, deviation, roi);
    if (!std::isfinite(mean[0]) || !std::isfinite(deviation[0]))
      fail(Errc::Device, "{}: the image {} has non-finite values", kWhat, what);
    return Measured{f, mean[0]};
  };
  // The display dark first, twice: the spread of the difference of the two
  // images over the region is the frame-to-frame noise alone (whatever does
  // not change from one image to the next, stray light or a fixed pattern,
  // cancels, and it cancels between candidates too); over √2 and the square
  // root of the pixel count, it is the noise of a mean.
  const LightField darkField(captured.geometry());
  const std::string darkly = "with the display dark";
  const Measured dark1 = measure(darkField, darkly), dark2 = measure(darkField, darkly);
  scan.dark = 0.5 * (dark1.mean + dark2.mean);
  cv::Scalar unused, spread;
  cv::meanStdDev(dark1.image - dark2.image, unused, spread, roi);
  const double pixels = roi.empty() ? static_cast<double>(dark1.image.total()) : cv::countNonZero(roi);
  // Never below the caller's floor: identical dark images (an 8-bit camera with little read noise) do not make
  // every rise significant.
  scan.darkNoise = spread[0] / std::sqrt(2.0) / std::sqrt(pixels);
  scan.noise = std::max(spread[0] / std::sqrt(2.0), pixelNoiseFloor) / std::sqrt(pixels);
  // The display is ε further away: show the field as it is ε further away.
  auto shownFor = [&](double epsilon) { return propagateLightField(captured, -epsilon); };
  auto forCandidate = [](double epsilon) { return fmt::format("for candidate {:+g} mm", epsilon); };
  cv::Mat brightestImage;  // the first image of the brightest candidate so far
  for (double epsilon : candidates) {
    Measured m = measure(shownFor(epsilon), forCandidate(epsilon));
    if (scan.brightness.empty() || m.mean > *std::max_element(scan.brightness.begin(), scan.brightness.end()))
      brightestImage = m.image;
    scan.brightness.push_back(m.mean);
  }
  const auto lowest = std::min_element(scan.brightness.begin(), scan.brightness.end());
  const auto highest = std::max_element(scan.brightness.begin(), scan.brightness.end());
  // The brightest candidate again, last: the spread of the difference of its
  // two images is the noise where the signal is (the dark images lack its
  // shot noise, and a camera clips their noise at 0 DN), and its two means
  // must agree within it: the display's or the room's light drifting during
  // the scan would tilt the peak.
  {
    const double epsilon = candidates[static_cast<size_t>(highest - scan.brightness.begin())];
    const Measured again = measure(shownFor(epsilon), forCandidate(epsilon) + " again, after the scan");
    cv::meanStdDev(brightestImage - again.image, unused, spread, roi);
    scan.noise = std::max(scan.noise, spread[0] / std::sqrt(2.0) / std::sqrt(pixels));
    // (Noise-free images, a renderer's, may still differ in the last bits of their sums.)
    if (std::abs(again.mean - *highest) >
        std::max(kDriftAboveNoise * std::sqrt(2.0) * scan.noise, 1e-9 * std::abs(*highest)))
      fail(Errc::Device,
           "{}: candidate {:+g} mm gave {:.6g} at first and {:.6g} after the scan, apart by more than {} "
           "times their noise ({:.2g} each): is the display's or the room's light drifting? ({})",
           kWhat, epsilon, *highest, again.mean, kDriftAboveNoise, scan.noise, scanTable(candidates, scan.brightness));
  }
  if (*highest - *lowest <= kClearAboveNoise * scan.noise || *highest == *lowest)
    fail(Errc::Device,
         "{}: the part's brightness hardly changes across the scan ({}; with the display dark {:.6g}, "
         "the noise of a mean about {:.2g}): is the display showing, the camera unsaturated, the region on the part?",
         kWhat, scanTable(candidates, scan.brightness), scan.dark, scan.noise);
  // The centre of the peak: half-way between where the brightness falls, on
  // either side of the brightest candidate, below a quarter of the way down
  // to the scan's lowest (linear between candidates). A display's finite depth
  // of field makes the peak flat-topped, which only its flanks locate.
  scan.level = *highest - kPeakLevel * (*highest - *lowest);
  const auto best = highest - scan.brightness.begin();
  const auto last = static_cast<std::ptrdiff_t>(candidates.size()) - 1;
  auto crossing = [&](std::ptrdiff_t step) {
    for (std::ptrdiff_t i = best; i + step >= 0 && i + step <= last; i += step) {
      const auto k = static_cast<size_t>(i), j = static_cast<size_t>(i + step);
      const double yk = scan.brightness[k], yj = scan.brightness[j];
      if (yj < scan.level) return candidates[k] + (candidates[j] - candidates[k]) * (yk - scan.level) / (yk - yj);
    }
    fail(Errc::InvalidArgument,
         "{}: the brightness does not fall below {:.6g} on the {} side of the brightest "
         "candidate within the scan ({}): the display's error may lie beyond it; scan further that way",
         kWhat, scan.level, step < 0 ? "low" : "high", scanTable(candidates, scan.brightness));
  };
  const double low = crossing(-1), high = crossing(+1);
  // Outside the peak's flanks the brightness must stay below the level: a
  // second peak as bright makes the answer a guess between the two. A flank
  // that wavers about the level by the noise is not a second peak.
  for (size_t i = 0; i < candidates.size(); ++i)
    if ((candidates[i] < low || candidates[i] > high) &&
        scan.brightness[i] >= scan.level + kSecondPeakAboveNoise * scan.noise)
      fail(Errc::InvalidArgument,
           "{}: two peaks: the brightness rises to {:.6g} again at {:+g} mm, above {:.6g}, "
           "apart from the brightest one between {:+.3g} and {:+.3g} mm ({}); narrow the scan or the region to the "
           "part",
           kWhat, scan.brightness[i], candidates[i], scan.level, low, high, scanTable(candidates, scan.brightness));
  scan.estimate_mm = 0.5 * (low + high);
  scan.width_mm = high - low;
  return scan;
}

}  // namespace lfi::calib
