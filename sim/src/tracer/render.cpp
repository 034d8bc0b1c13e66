// SPDX-License-Identifier: Apache-2.0
// render(): the image cut into tiles, rendered in parallel on TBB (each by the
// packet renderer, tile_renderer.cpp), with progress reports and cancellation.

#include "lfi/sim/render.h"

#include "lfi/core/error.h"

#include "../parallel_for.h"
#include "tile_renderer.h"

#include <algorithm>
#include <atomic>
#include <mutex>
#include <variant>

namespace lfi::sim {

cv::Mat render(const Scene& scene, const Sensor& sensor, const RenderOptions& options) {
  if (options.samplesPerPixel < 1) fail(Errc::InvalidArgument, "render: samplesPerPixel must be >= 1");
  if (options.splitDepth < 0 || options.splitDepth > RenderOptions::kMaxSplitDepth)
    fail(Errc::InvalidArgument, "render: splitDepth = {} is outside [0, {}]", options.splitDepth,
         RenderOptions::kMaxSplitDepth);
  if (options.tileSize < 1) fail(Errc::InvalidArgument, "render: tileSize must be >= 1");
  if (options.maxDepth < 1) fail(Errc::InvalidArgument, "render: maxDepth = {} must be >= 1", options.maxDepth);
  // A pixel's sample s has the random stream (pixel << 24) ^ s: more samples would share the next pixel's streams.
  if (options.samplesPerPixel > (1 << 24))
    fail(Errc::InvalidArgument, "render: samplesPerPixel = {} is above 2^24", options.samplesPerPixel);
  if (const auto* cam = std::get_if<TelecentricCamera>(&sensor)) cam->validate();
  if (const auto* lfs = std::get_if<LightFieldSensor>(&sensor)) lfs->geometry.validate();
  const int width = sensorWidth(sensor), height = sensorHeight(sensor);
  cv::Mat image(height, width, CV_32FC1, cv::Scalar(0));
  const int ts = options.tileSize;
  const int tilesX = (width + ts - 1) / ts, tilesY = (height + ts - 1) / ts, tiles = tilesX * tilesY;
  int done = 0;
  std::mutex progressMutex;  // (fractions reported in order: a bar never steps back)
  std::atomic<bool> stopped{false};

  auto renderTile = [&](int tile) {
    if (options.cancel && options.cancel->load(std::memory_order_relaxed)) {
      stopped = true;
      return;
    }
    const int x0 = (tile % tilesX) * ts, y0 = (tile / tilesX) * ts;
    detail::renderTile(scene, sensor, options, x0, y0, std::min(x0 + ts, width), std::min(y0 + ts, height), image);
    std::lock_guard lock(progressMutex);
    ++done;
    if (options.progress) options.progress(static_cast<double>(done) / tiles);
  };

  detail::parallelFor(tiles, options.threads, renderTile);
  if (stopped) fail(Errc::Cancelled, "render cancelled");
  return image;
}

}  // namespace lfi::sim
