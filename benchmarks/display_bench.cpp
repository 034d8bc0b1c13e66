// SPDX-License-Identifier: Apache-2.0
// lfi-display-bench: light field → panel image encoding (encodeLightField, the
// display's optics model) for a 3840 x 2160 panel, next to a memcpy of the same
// number of bytes measured in the same run.
//
//   encode   best time of encodeLightField (interpolated light field lookup along
//            every subpixel's chief ray) on OpenCV's thread pool, and on 1 thread
//   memcpy   best time of copying the encoded panel's bytes (3840 x 2160 x 3 = 24.9 MB)
//            into a second, already touched buffer: the floor for any per-frame step
//   ratio    encode / memcpy
//   levels   the sim: display's conversion of the panel to emitter drive levels
//            (panelLevels, what SimDisplay::show adds on top of the encode), next to
//            a memset of as many bytes as the levels take (a float per subpixel)
//   check    before the figures, 2000 random subpixels of the encoded panel
//            against their chief rays' radiance (rayFromPixel, LightField::radiance):
//            a mismatch beyond the rounding fails the bench
//
// Displays: each class's default of display_optics.h on a 3840 x 2160 panel: the
// lenticular (7.22 px per lens, 10.5° slant, 40° cone, 0.0751 mm pixels, 289 x
// 162 mm), the lenslet array and the pinhole array (1 mm square lattice, 40°
// cone, 0.0315 mm pixels, 121 x 68 mm), RGB stripe unless --mono.
// Light field: 1 mm spatial elements covering the panel, 16 x 16 angular,
// random radiance.
//
// Usage: lfi-display-bench [--repeats N] [--mono] [--class lenticular|lenslet_array|pinhole_array]

#include "lfi/drivers/display_optics.h"
#include "lfi/sim/scene.h"

#include "bench_util.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

using namespace lfi;

using lfi::bench::bestSeconds;

namespace {

void benchClass(DisplayInfo info, bool mono, int repeats) {
  info.panelWidth_px = 3840;
  info.panelHeight_px = 2160;
  if (mono) info.subpixels = SubpixelLayout::Mono;
  const DisplayOptics optics(info);

  // 1 mm elements over the panel and a lens's reach beyond it.
  const auto elements = [](double extent_mm) { return static_cast<int>(std::ceil(extent_mm)) + 4; };
  LightFieldGeometry g{.spatialX = elements(info.panelWidth_px * info.pixelPitch_mm),
                       .spatialY = elements(info.panelHeight_px * info.pixelPitch_mm),
                       .angular = 16,
                       .pixelPitch_mm = 1.0 / 16,
                       .distance_mm = 30};
  LightField lightField(g);
  cv::RNG rng(1);
  rng.fill(lightField.lensletImage(), cv::RNG::UNIFORM, 0.0, 1.0);

  const int threads = cv::getNumThreads();
  cv::Mat panel, panel1;
  const double encode = bestSeconds(repeats, [&] { panel = encodeLightField(lightField, optics, 1.0); });
  cv::setNumThreads(1);
  const double encode1 =
      bestSeconds(std::max(1, repeats / 2), [&] { panel1 = encodeLightField(lightField, optics, 1.0); });
  cv::setNumThreads(threads);
  if (cv::norm(panel, panel1, cv::NORM_INF) != 0)
    throw std::runtime_error("self-check: the encode on OpenCV's threads differs from the encode on one");

  // Self-check: the timed encode (both are the same) against the model's own chief rays
  // (rayFromPixel and LightField::radiance), at random subpixels: a fast
  // encode that wrote the wrong levels would otherwise pass for the best time.
  const int sub = info.subpixelsPerPixel();
  int mismatches = 0;
  for (int i = 0; i < 2000; ++i) {
    const int col = rng.uniform(0, info.panelWidth_px), row = rng.uniform(0, info.panelHeight_px);
    const int k = rng.uniform(0, sub);
    const DisplayRay ray = optics.rayFromPixel(col, row, k);
    const double level =
        255.0 * lightField.radiance({ray.origin_mm.x, ray.origin_mm.y}, ray.direction, LightFieldLookup::Interpolated);
    if (std::abs(panel.ptr<std::uint8_t>(row)[col * sub + k] - level) > 0.5 + 1e-6) ++mismatches;
  }
  if (mismatches > 0)
    throw std::runtime_error(
        fmt::format("self-check ({}): {} of 2000 subpixels differ from the chief ray's "
                    "radiance by more than the rounding",
                    toString(info.optics.type), mismatches));

  const std::size_t bytes = panel.total() * panel.elemSize();
  std::vector<unsigned char> copy(bytes, 1);  // touched: no page faults inside the timing
  const double copyTime = bestSeconds(std::max(repeats, 20), [&] {
    std::memcpy(copy.data(), panel.data, bytes);
    asm volatile("" : : "r"(copy.data()) : "memory");
  });

  const double levels = bestSeconds(repeats, [&] {
    const cv::Mat l = sim::panelLevels(info, panel);
    asm volatile("" : : "r"(l.data) : "memory");
  });
  // The levels' bound: their writes alone, a fill of as many bytes as they take (a float per subpixel).
  const std::size_t levelBytes = panel.total() * panel.channels() * sizeof(float);
  std::vector<unsigned char> levelFill(levelBytes, 1);  // touched: no page faults inside the timing
  const double levelFillTime = bestSeconds(std::max(repeats, 5), [&] {
    std::memset(levelFill.data(), 0, levelBytes);
    asm volatile("" : : "r"(levelFill.data()) : "memory");
  });

  const double subpixels = static_cast<double>(info.panelWidth_px) * info.panelHeight_px * info.subpixelsPerPixel();
  fmt::print("{}: panel {} x {} {} ({:.1f} MB), light field {} x {} x {}^2, {} OpenCV threads, best of {}\n",
             toString(info.optics.type), info.panelWidth_px, info.panelHeight_px, toString(info.subpixels), bytes / 1e6,
             g.spatialX, g.spatialY, g.angular, threads, repeats);
  fmt::print("  encode ({} threads)  {:8.2f} ms  {:6.1f} M subpixels/s\n", threads, 1e3 * encode,
             subpixels / encode / 1e6);
  fmt::print("  encode (1 thread)    {:8.2f} ms  {:6.1f} M subpixels/s\n", 1e3 * encode1, subpixels / encode1 / 1e6);
  fmt::print("  memcpy same bytes    {:8.3f} ms  {:6.2f} GB/s\n", 1e3 * copyTime, bytes / copyTime / 1e9);
  fmt::print("  ratio encode/memcpy  {:8.0f} x ({} threads), {:.0f} x (1 thread)\n", encode / copyTime, threads,
             encode1 / copyTime);
  fmt::print("  sim panel levels     {:8.2f} ms  (panel → emitter drive levels, SimDisplay::show)\n", 1e3 * levels);
  fmt::print("  memset level bytes   {:8.2f} ms  {:6.2f} GB/s ({:.1f} MB: the levels' writes alone)\n",
             1e3 * levelFillTime, levelBytes / levelFillTime / 1e9, levelBytes / 1e6);
  fmt::print("  ratio levels/memset  {:8.2f} x\n", levels / levelFillTime);
}

int run(int argc, char** argv) {
  int repeats = 5;
  bool mono = false;
  std::string only;
  CLI::App app("lfi-display-bench: light field to panel encoding against a memcpy of the same bytes");
  app.add_option("--repeats", repeats, "Runs of each; the best counts")->check(CLI::Range(1, 1000));
  app.add_flag("--mono", mono, "A monochrome panel");
  app.add_option("--class", only, "Only this display class")
      ->check(CLI::IsMember({"lenticular", "lenslet_array", "pinhole_array"}));
  CLI11_PARSE(app, argc, argv);
  for (const DisplayInfo& info :
       {defaultLenticularDisplay(), defaultLensletArrayDisplay(), defaultPinholeArrayDisplay()})
    if (only.empty() || only == toString(info.optics.type)) benchClass(info, mono, repeats);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return lfi::bench::runGuarded("lfi-display-bench", [&] { return run(argc, argv); });
}
