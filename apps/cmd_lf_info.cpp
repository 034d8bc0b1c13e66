// SPDX-License-Identifier: Apache-2.0
// lfi lf-info: a light field EXR validated and its parametrisation printed.

#include "commands.h"

#include "lfi/core/exr_io.h"

#include <fmt/format.h>

#include <filesystem>
#include <memory>

namespace fs = std::filesystem;

namespace lfi::cli {

Command addLfInfoCommand(CLI::App& app) {
  auto* lfInfo = app.add_subcommand("lf-info", "Validate a light field EXR and print its parametrisation");
  auto lfFile = std::make_shared<fs::path>();
  lfInfo->add_option("file", *lfFile, "Light field EXR")->required();
  return {lfInfo, [lfFile](const GlobalOptions&) {
            const lfi::LightField lf = lfi::readLightFieldExr(*lfFile);
            const auto& g = lf.geometry();
            fmt::print(
                "{}: valid light field\n  spatial {} x {} elements of {} x {} angular elements\n"
                "  pixel pitch {} mm, element pitch {} mm, extent {} x {} mm, distance {} mm\n",
                lfFile->string(), g.spatialX, g.spatialY, g.angular, g.angular, g.pixelPitch_mm, g.elementPitch_mm(),
                g.extentX_mm(), g.extentY_mm(), g.distance_mm);
            return 0;
          }};
}

}  // namespace lfi::cli
