// SPDX-License-Identifier: Apache-2.0
#pragma once
// A bench's reference package taken with its devices (what `lfi capture` does
// before it writes the package): the reference light field captured (or read)
// and shown with the display, the golden model of the intact part trained from
// `[reference] frames` inspections' images, the part's mask, and the
// package's description of the devices.

#include "lfi/controller/bench_file.h"
#include "lfi/controller/controller.h"
#include "lfi/controller/reference_package.h"
#include "lfi/drivers/camera.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/light_field_capture.h"

namespace lfi {

// How much of the part the reference lets the inspection see.
struct ReferenceCoverage {
  int partPixels = 0;       // the part's pixels (the mask's disc, lit or not)
  int inspectedPixels = 0;  // those lit to [reference] mask_lit_fraction: where defects are looked for
  double mean_dn = 0;       // the intact part's image there
  double cv = 0;            // and its coefficient of variation
};

// Takes the package (info.created_utc and updated_utc are now) with a capture
// that openBenchCapture opened (and so handed the bench's Δ). Throws what the
// devices and the capture throw.
ReferencePackage takeReference(const BenchFile& bench, LightFieldCapture& capture, Display& display, Camera& camera,
                               const Controller::Progress& progress = {}, ReferenceCoverage* coverage = nullptr);

}  // namespace lfi
