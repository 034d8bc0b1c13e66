// SPDX-License-Identifier: Apache-2.0
#pragma once
// The ray-traced light field display: "sim:<scene-file>" (display_registry.h).
// It drives the scene file's [display] (docs/scene-files.md): show() puts the
// panel image on the simulated panel, whose light the ray tracer emits through
// the physical lenslet or barrier model (PanelEmission, scene.h). A SimCamera
// opened on the same scene file in this process renders what the display shows
// (the shared SimBench, sim_bench.h).
//
//   Display call     effect on the bench
//   open()           panel dark (blank), backlight at brightnessMax
//   show(panel)      panel levels = panel / 255, lit; PresentStatus::Presented, sequence + 1
//   blank()          dark (the panel keeps its image for the next show)
//   setBrightness(l) emitted radiance = brightness · l / brightnessMax · level / 255
//   close()          dark
//
// info(): vendor "lfi", model "SimDisplay", serial = scene name, deviceId = the
// scene file path; panel and optics from [display]. Follows display.h's state
// machine; the device never vanishes and never rejects a well-formed frame.
// Units and frames: display.h's display frame, placed in the world by [display].

#include "lfi/drivers/display.h"

#include <filesystem>
#include <memory>

namespace lfi::sim {

// Opens "sim:<scene-file>" (state Open). Throws Errc::NotFound for a missing file,
// Errc::Config for a bad one or one without [display].
std::unique_ptr<Display> openSimDisplay(const std::filesystem::path& sceneFile);

// Adds the "sim" scheme to the display registry. Idempotent (registerSimBackends() calls it).
void registerSimDisplayBackend();

}  // namespace lfi::sim
