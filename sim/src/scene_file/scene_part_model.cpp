// SPDX-License-Identifier: Apache-2.0
#include "lfi/sim/scene_part_model.h"

#include "lfi/core/error.h"
#include "lfi/sim/render.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/scene_file.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace lfi::sim {

namespace {

constexpr double kEscape_mm = 1e4;  // refractionPath's last vertex, this far along a ray that leaves the scene

}  // namespace

ScenePartModel::ScenePartModel(const std::filesystem::path& sceneFile) {
  SceneDescription d = loadSceneFile(sceneFile);
  std::vector<Object> part;
  std::vector<std::string> names;
  Bounds bounds;
  for (size_t k = 0; k < d.objects.size(); ++k) {
    if (static_cast<int>(k) == d.displayObject || d.objects[k].emission) continue;
    bounds = bounds.unite(worldBounds(d.objects[k]));
    names.push_back(d.objects[k].name);
    part.push_back(std::move(d.objects[k]));
  }
  if (part.empty())
    fail(Errc::Config,
         "{}: no part in the scene (every object is the display or an emitter): a part model needs "
         "one",
         sceneFile.string());
  if (!bounds.finite()) fail(Errc::Config, "{}: the part's objects are unbounded", sceneFile.string());
  top_mm_ = bounds.hi.z + 1;
  scene_ = std::make_unique<Scene>(std::move(part), d.ambientIor);
  description_ = fmt::format("scene {} ({})", sceneFile.string(), fmt::join(names, ", "));
}

ScenePartModel::~ScenePartModel() = default;

std::optional<PartRay> ScenePartModel::exit(const Vec2& x) const {
  const std::vector<Vec3> path = refractionPath(*scene_, Ray{Vec3(x.x, x.y, top_mm_), Vec3(0, 0, -1)}, 64, kEscape_mm);
  // A ray that met the part and left it: three vertices or more, the last one kEscape_mm along its last segment.
  if (path.size() < 3) return std::nullopt;
  const Vec3 from = path[path.size() - 2], to = path.back();
  const double length = (to - from).length();
  if (!(std::abs(length - kEscape_mm) < 1e-6 * kEscape_mm)) return std::nullopt;  // absorbed, or stopped
  const Vec3 direction = (to - from) / length;
  if (!(direction.z < 0)) return std::nullopt;
  return PartRay{from, direction};
}

std::optional<Vec2> ScenePartModel::atDepth(const Vec2& x, double z) const {
  if (!(z < top_mm_)) return x;  // above the part: the ray is still straight
  const std::vector<Vec3> path = refractionPath(*scene_, Ray{Vec3(x.x, x.y, top_mm_), Vec3(0, 0, -1)}, 64, kEscape_mm);
  for (std::size_t i = 1; i < path.size(); ++i) {
    const Vec3 &from = path[i - 1], &to = path[i];
    if ((from.z - z) * (to.z - z) > 0 || from.z == to.z) continue;
    if (!(to.z < from.z)) return std::nullopt;  // the first crossing goes up: turned back above the plane
    const double t = (from.z - z) / (from.z - to.z);
    return Vec2(from.x + t * (to.x - from.x), from.y + t * (to.y - from.y));
  }
  return std::nullopt;  // absorbed, or stopped, above it
}

}  // namespace lfi::sim
