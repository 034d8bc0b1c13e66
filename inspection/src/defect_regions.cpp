// SPDX-License-Identifier: Apache-2.0
// The regions of the off pixels (defect_regions.h).

#include "defect_regions.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

namespace lfi::detail {

// The runs in groups that the closing cannot join: a closing of radius r
// (then the mask) turns each group into regions within r of it, so groups
// more than 2r + 1 apart (Chebyshev) give regions that neither overlap nor
// touch. Runs are grouped through the tiles of a grid they fall in, joined
// with every tile near enough to hold a pixel within 2r + 1.
std::vector<std::vector<Run>> separateGroups(const std::vector<Run>& runs, cv::Size size, int closing) {
  constexpr int kTile = 16;
  const int tilesX = (size.width + kTile - 1) / kTile, tilesY = (size.height + kTile - 1) / kTile;
  std::vector<int> parent(static_cast<size_t>(tilesX) * static_cast<size_t>(tilesY), -1), marked;
  for (const Run& run : runs)
    for (int tx = run.begin / kTile; tx <= (run.end - 1) / kTile; ++tx) {
      const int t = run.row / kTile * tilesX + tx;
      if (parent[static_cast<size_t>(t)] < 0) parent[static_cast<size_t>(t)] = t, marked.push_back(t);
    }
  const auto root = [&](int t) {
    while (parent[static_cast<size_t>(t)] != t)
      t = parent[static_cast<size_t>(t)] = parent[static_cast<size_t>(parent[static_cast<size_t>(t)])];
    return t;
  };
  // Tiles m apart hold pixels (m - 1) · kTile + 1 apart at the least. (A run's own tiles are neighbours.)
  const int reach = (2 * closing + 1) / kTile + 1;
  for (const int t : marked) {
    const int tx = t % tilesX, ty = t / tilesX;
    for (int dy = 0; dy <= reach && ty + dy < tilesY; ++dy)
      for (int dx = -reach; dx <= reach; ++dx) {
        if ((dy == 0 && dx <= 0) || tx + dx < 0 || tx + dx >= tilesX) continue;
        const int u = (ty + dy) * tilesX + tx + dx;
        if (parent[static_cast<size_t>(u)] < 0) continue;
        const int a = root(t), b = root(u);
        if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
      }
  }
  std::vector<int> groupOf(parent.size(), -1);
  std::vector<std::vector<Run>> groups;
  for (const Run& run : runs) {
    int& g = groupOf[static_cast<size_t>(root(run.row / kTile * tilesX + run.begin / kTile))];
    if (g < 0) g = static_cast<int>(groups.size()), groups.emplace_back();
    groups[static_cast<size_t>(g)].push_back(run);
  }
  return groups;
}

// The window a group's regions are found in: wide enough (2r + 2 beyond its
// runs) that the window's edges change nothing.
cv::Rect windowOf(const std::vector<Run>& runs, cv::Size size, int closing) {
  int x0 = INT_MAX, x1 = INT_MIN, y0 = INT_MAX, y1 = INT_MIN;
  for (const Run& run : runs) {
    x0 = std::min(x0, run.begin), x1 = std::max(x1, run.end);
    y0 = std::min(y0, run.row), y1 = std::max(y1, run.row + 1);
  }
  const int margin = 2 * closing + 2;
  return cv::Rect(x0 - margin, y0 - margin, x1 - x0 + 2 * margin, y1 - y0 + 2 * margin) & cv::Rect(cv::Point(), size);
}

// The regions of one group: its runs closed, masked and labelled in its
// window, then each region's statistics over the unsmoothed difference.
void addRegions(const std::vector<Run>& group, const cv::Mat& values, DifferenceRow difference,
                const GoldenModel& model, const cv::Mat& mask, const DetectionSettings& settings,
                std::vector<Defect>& defects) {
  const cv::Rect window = windowOf(group, values.size(), settings.closing_px);
  cv::Mat off = cv::Mat::zeros(window.size(), CV_8UC1);
  for (const Run& run : group)
    std::memset(off.ptr<std::uint8_t>(run.row - window.y) + (run.begin - window.x), 255,
                static_cast<size_t>(run.end - run.begin));
  if (settings.closing_px > 0) {
    const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE,
                                                   cv::Size(2 * settings.closing_px + 1, 2 * settings.closing_px + 1));
    cv::morphologyEx(off, off, cv::MORPH_CLOSE, disc);
  }
  if (!mask.empty())
    for (int row = 0; row < window.height; ++row) {
      std::uint8_t* o = off.ptr<std::uint8_t>(row);
      const std::uint8_t* m = mask.ptr<std::uint8_t>(window.y + row) + window.x;
      for (int col = 0; col < window.width; ++col) o[col] = m[col] != 0 ? o[col] : 0;
    }

  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(off, labels, stats, centroids, 8, CV_32S);
  const auto n = static_cast<size_t>(count);
  std::vector<double> sum(n, 0.0), contrastSum(n, 0.0), peak(n, 0.0), sumX(n, 0.0), sumY(n, 0.0);
  std::vector<char> kept(n, 0);
  for (int k = 1; k < count; ++k)
    kept[static_cast<size_t>(k)] = stats.at<int>(k, cv::CC_STAT_AREA) >= settings.minArea_px;
  // Each region's sums in raster order: the same whichever window holds it.
  std::vector<float> d(static_cast<size_t>(window.width));
  for (int row = 0; row < window.height; ++row) {
    const int y = window.y + row;
    const int* label = labels.ptr<int>(row);
    const float* ideal = model.ideal.ptr<float>(y) + window.x;
    difference(values.ptr(y), model.ideal.ptr<float>(y), window.x, window.x + window.width, d.data());
    for (int col = 0; col < window.width; ++col) {
      const auto k = static_cast<size_t>(label[col]);
      if (!kept[k]) continue;
      const float dk = d[static_cast<size_t>(col)];
      const double contrast = ideal[col] > 0 ? dk / ideal[col] : 0.0;
      sum[k] += dk;
      contrastSum[k] += contrast;
      if (std::abs(contrast) > std::abs(peak[k])) peak[k] = contrast;
      sumX[k] += window.x + col;
      sumY[k] += y;
    }
  }
  for (int k = 1; k < count; ++k) {
    const auto i = static_cast<size_t>(k);
    if (!kept[i]) continue;
    const int area = stats.at<int>(k, cv::CC_STAT_AREA);
    Defect defect;
    defect.centroid_px = {sumX[i] / area, sumY[i] / area};
    defect.area_px = area;
    defect.bounds_px = cv::Rect(stats.at<int>(k, cv::CC_STAT_LEFT), stats.at<int>(k, cv::CC_STAT_TOP),
                                stats.at<int>(k, cv::CC_STAT_WIDTH), stats.at<int>(k, cv::CC_STAT_HEIGHT)) +
                       window.tl();
    defect.peakContrast = peak[i];
    defect.meanContrast = contrastSum[i] / area;
    defect.dark = sum[i] < 0;
    defects.push_back(defect);
  }
}

}  // namespace lfi::detail
