// SPDX-License-Identifier: Apache-2.0
#pragma once
// A part model (lfi/core/part_model.h) from a scene file: its objects other
// than the display and the emitters, placed as the file places them, the
// file's world frame taken as the part's frame (origin at the part's
// reference point, axes those of the display frame). The study's and the
// inspection bench's scenes place the lens so: data/scenes/inspection_bench.toml
// is the model of its own part.

#include "lfi/core/part_model.h"

#include <filesystem>
#include <memory>
#include <string>

namespace lfi::sim {

class Scene;

class ScenePartModel final : public PartModel {
 public:
  // Errc::NotFound, Errc::Config (the scene file's errors); Errc::Config
  // naming the file when it has no object that is not an emitter.
  explicit ScenePartModel(const std::filesystem::path& sceneFile);
  ~ScenePartModel() override;

  std::optional<PartRay> exit(const Vec2& x) const override;
  std::optional<Vec2> atDepth(const Vec2& x, double z) const override;
  std::string description() const override { return description_; }

 private:
  std::unique_ptr<Scene> scene_;
  double top_mm_ = 0;  // above every object
  std::string description_;
};

}  // namespace lfi::sim
