// SPDX-License-Identifier: Apache-2.0
#pragma once
// The simulated bench that the `sim:` devices of one process share: a SimCamera
// and a SimDisplay opened on the same scene file see each other, so that what the
// display shows is what the camera's ray tracer emits from.
//
// One SimBench per canonical scene-file path, held by the devices opened on it
// (a process-wide registry of weak references: the file is loaded when the first
// device opens and again after the last one closed). It holds the parsed scene
// and the display's state; every change of what the display emits (show, blank,
// backlight level) bumps version(), and a renderer that cached radiance for an
// older version renders again (SimImager does). Each version's state is an
// immutable DisplayState, so a frame exposed before a change can still be
// rendered as it was: before every change the bench calls its change
// listeners on the changing thread (a free-running SimCamera exposes the
// frames due until then with the state about to end).
//
//   state          meaning
//   panel          the last shown panel image as drive levels (PanelEmission), dark after open/blank
//   lit            false after blank(): the display emits nothing
//   backlight      level in info.brightnessMin..brightnessMax; emitted radiance scales with
//                  backlight / brightnessMax (brightness at brightnessMax, the level at load)
//   version        starts at 1, +1 per change
//
// Thread-safe: devices may drive the bench from different threads. Units and
// frames: the scene file's (mm, world +z towards the camera; display frame in display.h).

#include "lfi/sim/scene.h"
#include "lfi/sim/scene_file.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

namespace lfi::sim {

class SimBench : public std::enable_shared_from_this<SimBench> {
 public:
  // The bench of `sceneFile` (shared while any holder keeps it). Throws
  // Errc::NotFound for a missing file, Errc::Config for a bad one; `device`
  // names the caller in messages ("camera 'sim:...'").
  static std::shared_ptr<SimBench> open(const std::filesystem::path& sceneFile, const std::string& device);

  explicit SimBench(const std::filesystem::path& sceneFile);
  SimBench(const SimBench&) = delete;
  SimBench& operator=(const SimBench&) = delete;

  const std::filesystem::path& sceneFile() const { return sceneFile_; }
  // The scene as loaded (the display's object emitting a dark panel).
  const SceneDescription& description() const { return description_; }
  bool hasDisplay() const { return description_.display.has_value(); }

  std::uint64_t version() const;

  // What the display emits as of one version (immutable; the panel is shared).
  struct DisplayState {
    std::uint64_t version = 1;
    std::optional<PanelEmission> emission;  // none without a [display]
  };
  std::shared_ptr<const DisplayState> displayState() const;

  // Sets the display object's emission in `scene` (built from description().objects)
  // to the current display state, or to `state`, and returns the version it
  // reflects. No-op without a display.
  std::uint64_t applyDisplay(Scene& scene) const;
  static std::uint64_t applyDisplay(Scene& scene, int displayObject, const DisplayState& state);

  // Calls `listener` just before each change of the display state (and before
  // show/blank/backlight calls that turn out to change nothing), on the
  // changing thread, until the returned handle is destroyed; destroying it
  // waits for a change in progress. A listener must not change the display or
  // destroy a handle (that would deadlock); it may read displayState() (still
  // the old one).
  using ChangeListener = std::function<void()>;
  [[nodiscard]] std::shared_ptr<void> onDisplayChange(ChangeListener listener);

  // The display's one driver: a SimDisplay claims the panel at open and
  // releases it at close. False when another holds it (a second display on the
  // file would blank the first's frame under it; the `usb:` backend refuses a
  // second claim of its interface likewise).
  bool claimDisplay();
  void releaseDisplay();

  // Display side (require hasDisplay()). `panel` as makePanelEmission() takes it.
  void showPanel(const cv::Mat& panel);
  void blankPanel();
  void setBacklight(int level);
  int backlight() const;
  bool lit() const;
  // Current emission (for tests and tools).
  PanelEmission emission() const;

 private:
  PanelEmission emissionLocked() const;
  // Runs `mutate` (under mutex_; returns whether it changed anything) after
  // telling the listeners, then publishes the new state.
  void change(const std::function<bool()>& mutate);

  std::filesystem::path sceneFile_;
  SceneDescription description_;
  std::shared_ptr<const PanelOptics> optics_;
  mutable std::mutex mutex_;
  std::shared_ptr<const cv::Mat> levels_;
  bool lit_ = false;
  int backlight_ = 0;
  bool displayClaimed_ = false;
  std::shared_ptr<const DisplayState> state_ = std::make_shared<const DisplayState>();  // version 1
  std::mutex changeMutex_;  // one change at a time: listeners see them in order
  std::mutex listenersMutex_;
  std::vector<std::pair<std::uint64_t, ChangeListener>> listeners_;
  std::uint64_t nextListener_ = 0;
};

}  // namespace lfi::sim
