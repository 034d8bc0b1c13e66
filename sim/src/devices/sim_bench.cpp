// SPDX-License-Identifier: Apache-2.0
#include "lfi/sim/devices/sim_bench.h"

#include "lfi/core/error.h"

#include <map>
#include <utility>

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
  state_ = std::make_shared<const DisplayState>(DisplayState{1, emissionLocked()});
}

std::uint64_t SimBench::version() const {
  std::lock_guard lock(mutex_);
  return state_->version;
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

std::shared_ptr<const SimBench::DisplayState> SimBench::displayState() const {
  std::lock_guard lock(mutex_);
  return state_;
}

std::uint64_t SimBench::applyDisplay(Scene& scene) const {
  return applyDisplay(scene, description_.displayObject, *displayState());
}

std::uint64_t SimBench::applyDisplay(Scene& scene, int displayObject, const DisplayState& state) {
  if (state.emission) scene.setEmission(displayObject, *state.emission);
  return state.version;
}

std::shared_ptr<void> SimBench::onDisplayChange(ChangeListener listener) {
  std::lock_guard lock(listenersMutex_);
  const std::uint64_t id = nextListener_++;
  listeners_.emplace_back(id, std::move(listener));
  // The handle removes the listener, after any change in progress (so the
  // listener is not running once the handle is gone); it holds the bench.
  return std::shared_ptr<void>(nullptr, [bench = shared_from_this(), id](void*) {
    std::lock_guard changing(bench->changeMutex_);
    std::lock_guard listening(bench->listenersMutex_);
    std::erase_if(bench->listeners_, [id](const auto& l) { return l.first == id; });
  });
}

void SimBench::change(const std::function<bool()>& mutate) {
  std::lock_guard changing(changeMutex_);
  std::vector<ChangeListener> listeners;
  {
    std::lock_guard lock(listenersMutex_);
    for (const auto& [id, listener] : listeners_) listeners.push_back(listener);
  }
  for (const ChangeListener& listener : listeners) listener();
  std::lock_guard lock(mutex_);
  if (!mutate()) return;
  state_ = std::make_shared<const DisplayState>(DisplayState{state_->version + 1, emissionLocked()});
}

void SimBench::showPanel(const cv::Mat& panel) {
  if (!hasDisplay()) fail(Errc::InvalidArgument, "'{}': the scene has no [display]", sceneFile_.string());
  // Convert outside the lock: a 4K panel takes milliseconds.
  auto levels =
      std::make_shared<const cv::Mat>(panelLevels(description_.display->info, panel, description_.display->light));
  change([&] {
    levels_ = std::move(levels);
    lit_ = true;
    return true;
  });
}

bool SimBench::claimDisplay() {
  std::lock_guard lock(mutex_);
  return !std::exchange(displayClaimed_, true);
}

void SimBench::releaseDisplay() {
  std::lock_guard lock(mutex_);
  displayClaimed_ = false;
}

void SimBench::blankPanel() {
  if (!hasDisplay()) fail(Errc::InvalidArgument, "'{}': the scene has no [display]", sceneFile_.string());
  change([&] { return std::exchange(lit_, false); });
}

void SimBench::setBacklight(int level) {
  if (!hasDisplay()) fail(Errc::InvalidArgument, "'{}': the scene has no [display]", sceneFile_.string());
  change([&] { return std::exchange(backlight_, level) != level; });
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
