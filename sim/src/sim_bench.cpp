#include "lfi/sim/sim_bench.h"

#include "lfi/core/error.h"

#include <map>

namespace lfi::sim {

namespace fs = std::filesystem;

std::shared_ptr<SimBench> SimBench::open(const fs::path& sceneFile, const std::string& device) {
  std::error_code ec;
  if (!fs::exists(sceneFile, ec)) fail(Errc::NotFound, "{}: no such scene file '{}'", device, sceneFile.string());
  const fs::path canonical = fs::canonical(sceneFile, ec);
  if (ec) fail(Errc::NotFound, "{}: cannot resolve scene file '{}': {}", device, sceneFile.string(), ec.message());
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<SimBench>> benches;
  // Loading under the lock: two devices opening the same file at once get one bench.
  std::lock_guard lock(mutex);
  std::erase_if(benches, [](const auto& entry) { return entry.second.expired(); });
  if (auto it = benches.find(canonical.string()); it != benches.end())
    if (auto bench = it->second.lock()) return bench;
  auto bench = std::make_shared<SimBench>(sceneFile);
  benches[canonical.string()] = bench;
  return bench;
}

SimBench::SimBench(const fs::path& sceneFile) : sceneFile_(sceneFile), description_(loadSceneFile(sceneFile)) {
  if (!description_.display) return;
  const auto& emission =
      std::get<PanelEmission>(*description_.objects[static_cast<size_t>(description_.displayObject)].emission);
  optics_ = emission.optics;
  levels_ = emission.levels;
  backlight_ = description_.display->info.brightnessMax;
}

std::uint64_t SimBench::version() const {
  std::lock_guard lock(mutex_);
  return version_;
}

PanelEmission SimBench::emissionLocked() const {
  const DisplayInfo& info = description_.display->info;
  const double scale = info.brightnessMax > 0 ? static_cast<double>(backlight_) / info.brightnessMax : 1.0;
  return PanelEmission{optics_, levels_, lit_ ? description_.display->brightness * scale : 0.0};
}

PanelEmission SimBench::emission() const {
  if (!hasDisplay()) fail(Errc::InvalidArgument, "'{}': the scene has no [display]", sceneFile_.string());
  std::lock_guard lock(mutex_);
  return emissionLocked();
}

std::uint64_t SimBench::applyDisplay(Scene& scene) const {
  std::lock_guard lock(mutex_);
  if (description_.display) scene.setEmission(description_.displayObject, emissionLocked());
  return version_;
}

void SimBench::showPanel(const cv::Mat& panel) {
  if (!hasDisplay()) fail(Errc::InvalidArgument, "'{}': the scene has no [display]", sceneFile_.string());
  // Convert outside the lock: a 4K panel takes milliseconds.
  auto levels = std::make_shared<const cv::Mat>(panelLevels(description_.display->info, panel));
  std::lock_guard lock(mutex_);
  levels_ = std::move(levels);
  lit_ = true;
  ++version_;
}

void SimBench::blankPanel() {
  if (!hasDisplay()) fail(Errc::InvalidArgument, "'{}': the scene has no [display]", sceneFile_.string());
  std::lock_guard lock(mutex_);
  if (!lit_) return;
  lit_ = false;
  ++version_;
}

void SimBench::setBacklight(int level) {
  if (!hasDisplay()) fail(Errc::InvalidArgument, "'{}': the scene has no [display]", sceneFile_.string());
  std::lock_guard lock(mutex_);
  if (level == backlight_) return;
  backlight_ = level;
  ++version_;
}

int SimBench::backlight() const {
  std::lock_guard lock(mutex_);
  return backlight_;
}

bool SimBench::lit() const {
  std::lock_guard lock(mutex_);
  return lit_;
}

}  // namespace lfi::sim
