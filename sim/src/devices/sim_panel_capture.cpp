// SPDX-License-Identifier: Apache-2.0
// The reference in the display's own ray space (sim_light_field_capture.h,
// capturePanelReference): every panel subpixel's rays traced backwards through
// the parts to the capture beam.

#include "lfi/core/error.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/sim/devices/sim_light_field_capture.h"
#include "lfi/sim/render.h"
#include "lfi/sim/scene_file.h"

#include "capture_beam.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>

namespace lfi::sim {

cv::Mat capturePanelReference(const std::filesystem::path& sceneFile, const SimCaptureSettings& settings,
                              const std::function<void(double)>& progress) {
  SceneDescription d = loadSceneFile(sceneFile);
  if (!d.display) fail(Errc::Config, "'{}': a panel reference needs the scene's [display]", sceneFile.string());
  const DisplayOptics optics(d.display->info);
  const DisplayInfo& info = optics.info();
  const DisplayOpticsParams& o = info.optics;
  if (!fullParallax(o.type))
    fail(Errc::Config,
         "'{}': [display]: a panel reference is traced through a lenslet or pinhole array; {} optics "
         "are not supported",
         sceneFile.string(), toString(o.type));
  if (settings.samplesPerPixel < 1 || settings.samplesPerPixel > kMostSamplesPerPixel)
    fail(Errc::InvalidArgument, "panel reference of '{}': spp = {} is outside 1 .. 2^20", sceneFile.string(),
         settings.samplesPerPixel);
  std::vector<Object> parts;
  for (Object& object : d.objects)
    if (!object.emission) parts.push_back(std::move(object));
  if (parts.empty()) fail(Errc::Config, "'{}': no part to capture (every object emits)", sceneFile.string());
  const Rigid3 worldFromDisplay = d.display->worldFromDisplay;
  const double panelSize = std::max(info.panelWidth_px, info.panelHeight_px) * info.pixelPitch_mm;
  const Scene scene = detail::captureScene(std::move(parts), d.ambientIor, settings.beamDistance_mm,
                                           settings.beamHalfAngle_rad, 4 * panelSize + 200);

  const PanelGrid& grid = optics.grid();
  const int sub = grid.subpixels();
  const double gap = o.gap_mm, subWidth = info.pixelPitch_mm / sub, height = info.pixelPitch_mm;
  const LensArrayOptics& array = *optics.model<LensArrayOptics>();
  const double reach = array.apertureReach_mm(), power = array.power_per_mm();
  const std::uint64_t seed = d.render.seed ^ 0x50414e45ull;  // "PANE"
  cv::Mat levels(info.panelHeight_px, info.panelWidth_px * sub, CV_32FC1);
  std::atomic<int> rowsDone = 0;
  cv::parallel_for_(cv::Range(0, info.panelHeight_px), [&](const cv::Range& rows) {
    for (int row = rows.start; row < rows.end; ++row) {
      float* out = levels.ptr<float>(row);
      for (int col = 0; col < info.panelWidth_px; ++col)
        for (int k = 0; k < sub; ++k) {
          const Vec2 centre = grid.subpixelCentre(col, row, k);
          const Vec2 c = array.apertureCentre(centre);
          Sampler sampler(seed, (static_cast<std::uint64_t>(row) * info.panelWidth_px + col) * sub + k);
          double sum = 0;
          for (int n = 0; n < settings.samplesPerPixel; ++n) {
            // A point of the subpixel, and a point of its own lens's clear aperture
            // (the cell shrunk by the fill factor) or pinhole, both uniform.
            const Vec2 p = centre + Vec2((sampler.next() - 0.5) * subWidth, (sampler.next() - 0.5) * height);
            Vec2 q;
            do q = c + reach * Vec2(2 * sampler.next() - 1, 2 * sampler.next() - 1);
            while (!array.insideAperture(q, c));
            // From p through the thin lens at q (a pinhole bends nothing).
            const Vec2 slope = (q - p) / gap - (q - c) * power;
            const Ray ray{worldFromDisplay.point({q.x, q.y, 0}),
                          worldFromDisplay.vector(Vec3(slope.x, slope.y, 1).normalized())};
            sum += traceRadiance(scene, ray, sampler, 64, 4);
          }
          out[col * sub + k] = static_cast<float>(sum / settings.samplesPerPixel);
        }
      if (progress) progress(static_cast<double>(++rowsDone) / info.panelHeight_px);
    }
  });
  return levels;
}

}  // namespace lfi::sim
