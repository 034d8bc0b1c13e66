// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim: the packet renderer of one tile (tile_renderer.cpp), which
// render()'s tile-parallel driver (render.cpp) runs for every tile.

#include "lfi/sim/render.h"

namespace lfi::sim::detail {

// Renders the pixels x0 <= i < x1, y0 <= j < y1 of `image` (CV_32FC1, the
// sensor's size): each pixel's mean over options.samplesPerPixel samples.
void renderTile(const Scene& scene, const Sensor& sensor, const RenderOptions& options, int x0, int y0, int x1, int y1,
                cv::Mat& image);

}  // namespace lfi::sim::detail
