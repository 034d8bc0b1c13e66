// SPDX-License-Identifier: Apache-2.0
// lfi inspect BENCH: one part inspected against the bench's reference package,
// blind (no ground truth): its record, image and overlay in a folder of their
// own under the bench's output folder, and the verdict as the exit status.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/core/error.h"

#include <fmt/format.h>

#include <memory>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

struct InspectArgs {
  fs::path bench, part, out;
  bool json = false;
};

int runInspect(const InspectArgs& a, const GlobalOptions&) {
  const lfi::BenchFile bench = lfi::readBenchFile(a.bench);
  // The devices: the bench's, or those of --part's scene on a simulated bench (a bench that cannot take
  // --part is the first thing to say).
  const lfi::BenchFile devices = a.part.empty() ? bench : lfi::withSimulatedPart(bench, a.part);
  const lfi::InspectResult r = lfi::inspectOnePart(bench, devices, a.out);
  const lfi::PartInspection& part = r.part;
  const fs::path& folder = r.folder;
  const std::string json = lfi::recordText(r.record, 2) + "\n";
  if (a.json) {
    fmt::print("{}", json);
  } else {
    fmt::print("{}: {}\n", part.verdict.pass ? "PASS" : "FAIL", (folder / "record.json").string());
    for (const std::string& reason : part.verdict.reasons) fmt::print("  {}\n", reason);
    int n = 0;
    for (const lfi::PartDefect& d : part.verdict.defects) {
      fmt::print("  defect {}: ({:.2f}, {:.2f}) mm ± ({:.2f}, {:.2f}), {:.3g} mm², contrast {:+.2f}\n", ++n,
                 d.centroid_mm.x, d.centroid_mm.y, d.centroidU_mm.x, d.centroidU_mm.y, d.area_mm2,
                 d.image.peakContrast);
      if (d.inside_mm)
        fmt::print("    inside the part at z = {:g} mm: ({:.2f}, {:.2f}) mm\n", bench.defectDepth_mm, d.inside_mm->x,
                   d.inside_mm->y);
    }
  }
  return part.verdict.pass ? 0 : kExitPartFailed;
}

}  // namespace

Command addInspectCommand(CLI::App& app) {
  auto* command = app.add_subcommand(
      "inspect", "Inspect one part against the bench's reference package: defects and a verdict (exit 0 pass, 3 fail)");
  auto a = std::make_shared<InspectArgs>();
  addBenchArgument(*command, a->bench);
  command->add_option("--part", a->part, "Simulated bench: inspect the part of this scene file")
      ->check(CLI::ExistingFile);
  command->add_option("--out", a->out, "Folder for the record and images (default: a new one in [output] folder)");
  command->add_flag("--json", a->json, "Print the record (JSON) to stdout");
  return {command, [a](const GlobalOptions& global) { return runInspect(*a, global); }};
}

}  // namespace lfi::cli
