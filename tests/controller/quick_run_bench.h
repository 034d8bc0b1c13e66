// SPDX-License-Identifier: Apache-2.0
#pragma once
// The shipped simulated bench made quick for runs (run_test.cpp,
// run_output_test.cpp): a 16 x 16 light field reference of 4 frames, 2 ms
// exposures, its reference and records in the bench file's folder, and the
// camera on the same scene through `cameraScheme` (sim, or a test's backend).

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/bench_file.h"
#include "lfi/controller/reference_capture.h"
#include "lfi/controller/reference_package.h"
#include "test_folder.h"
#include "text_edit.h"

#include <filesystem>
#include <string>

namespace lfi::testing_support {

// The bench's text, without its [run] table.
inline std::string quickRunBenchText(const std::string& cameraScheme) {
  const std::filesystem::path source = LFI_SOURCE_DIR;
  const std::filesystem::path scene = source / "data" / "scenes" / "inspection_bench.toml";
  std::string text = readText(source / "data" / "benches" / "inspection_sim.toml");
  replaceOnce(text, "[camera]\nuri = \"sim:../scenes/inspection_bench.toml\"",
              "[camera]\nuri = \"" + cameraScheme + ":" + scene.string() + "\"");
  replaceOnce(text, "[capture]\nuri = \"sim:../scenes/inspection_bench.toml\"",
              "[capture]\nuri = \"sim:" + scene.string() + "?spatial=16&angular=16&spp=8\"");
  replaceAll(text, "sim:../scenes/inspection_bench.toml", "sim:" + scene.string());
  replaceOnce(text, "exposure_us = 10000", "exposure_us = 2000");
  replaceOnce(text, "frames = 16 ", "frames = 4 ");
  replaceOnce(text, "\"../../out/bench/reference\"", "\"reference\"");
  replaceOnce(text, "\"../../out/bench/inspections\"", "\"inspections\"");
  replaceOnce(text, "[run]\non_device_loss = \"stop\"\n", "");
  return text;
}

// The reference of the bench `text`, written into `folder` as bench.toml.
inline ReferencePackage quickRunReference(const TestFolder& folder, const std::string& text) {
  const BenchFile bench = readBenchFile(folder.write("bench.toml", text));
  auto capture = openBenchCapture(bench);
  auto display = openBenchDisplay(bench);
  auto camera = openBenchCamera(bench, BenchExposures::OnRequest);
  return takeReference(bench, *capture, *display, *camera);
}

}  // namespace lfi::testing_support
