// SPDX-License-Identifier: Apache-2.0
#include "lfi/session/bench_session.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/part_records.h"
#include "lfi/core/error.h"
#include "lfi/core/output_folder.h"
#include "lfi/drivers/device_uri.h"
#include "lfi/sim/scene_part_model.h"

#include <algorithm>

namespace fs = std::filesystem;

namespace lfi {

namespace {

DeviceUri replaceScene(DeviceUri uri, const char* kind, const fs::path& scene) {
  if (uri.scheme != "sim")
    fail(Errc::Config,
         "--part replaces the part of a simulated bench; the {} '{}' is not sim: (a physical bench "
         "inspects the part that is under its camera)",
         kind, uri);
  uri.path = fs::absolute(scene).lexically_normal().string();
  return uri;
}

}  // namespace

BenchFile withSimulatedPart(BenchFile bench, const fs::path& scene) {
  bench.cameraUri = replaceScene(bench.cameraUri, "camera", scene);
  bench.displayUri = replaceScene(bench.displayUri, "display", scene);
  return bench;
}

std::shared_ptr<const PartModel> benchPartModel(const BenchFile& bench) {
  if (bench.partModel.empty()) return nullptr;
  return std::make_shared<const sim::ScenePartModel>(bench.partModel);
}

std::string timedFolderName(const char* prefix, const std::string& timeUtc) {
  std::string name = std::string(prefix) + "-" + timeUtc;
  name.erase(std::remove(name.begin(), name.end(), ':'), name.end());
  return name;
}

CaptureResult captureReference(const BenchFile& bench, Overwrite overwrite,
                               const std::function<void(const char*, double)>& progress) {
  refuseExisting({bench.referenceFolder}, overwrite, "capture");
  auto capture = openBenchCapture(bench);
  auto display = openBenchDisplay(bench);
  auto camera = openBenchCamera(bench, BenchExposures::OnRequest);
  requireOutputFolder(bench.referenceFolder.parent_path(), "capture", "[reference] folder");
  CaptureResult out;
  out.package = takeReference(bench, *capture, *display, *camera, progress, &out.coverage);
  out.captureDevice = capture->description();
  writeReferencePackage(bench.referenceFolder, out.package, overwrite);
  return out;
}

int trainGoldenModel(const BenchFile& bench, const BenchFile& devices, int images,
                     const std::function<bool(int)>& beforeEach) {
  if (images < 1) fail(Errc::InvalidArgument, "train: {} images; at least one", images);
  ReferencePackage package = readReferencePackage(bench.referenceFolder, &bench);
  auto display = openBenchDisplay(devices);
  auto camera = openBenchCamera(devices);
  Inspector inspector(bench, package, *display, *camera);
  inspector.showReference();
  for (int i = 0; i < images; ++i) {
    if (beforeEach && !beforeEach(i)) fail(Errc::Cancelled, "train: stopped at part {}; nothing written", i + 1);
    package.trainer.add(inspector.takeImage());
  }
  package.info.updated_utc = utcNow();
  writeReferencePackage(bench.referenceFolder, package, Overwrite::Allow);
  return package.trainer.count();
}

InspectResult inspectOnePart(const BenchFile& bench, const BenchFile& devices, const fs::path& folder) {
  const ReferencePackage package = readReferencePackage(bench.referenceFolder, &bench);
  auto display = openBenchDisplay(devices);
  auto camera = openBenchCamera(devices);
  Inspector inspector(devices, package, *display, *camera, benchPartModel(bench));
  inspector.showReference();
  InspectResult out;
  out.part = inspector.inspectPart();
  const std::string time = utcNow();
  out.folder = folder.empty() ? bench.outputFolder / timedFolderName("inspect", time) : folder;
  requireOutputFolder(out.folder, "inspect", folder.empty() ? "[output] folder" : "--out");
  out.record = partRecord(bench, inspector, out.part, 1, time, out.folder, "part");
  writeFileAtomically(out.folder / "record.json", Overwrite::Refuse, recordText(out.record, 2) + "\n");
  return out;
}

}  // namespace lfi
