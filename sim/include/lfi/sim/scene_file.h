#pragma once
// Scene files: a whole bench for the ray tracer in one human-editable TOML
// file (docs/scene-files.md). Errors name the file, line and key; unknown keys
// are errors.

#include "lfi/sim/render.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include <filesystem>
#include <string>
#include <vector>

namespace lfi::sim {

struct SceneDescription {
  std::string name;
  std::vector<Object> objects;
  double ambientIor = 1.0;
  Sensor sensor;
  RenderOptions render;
};

SceneDescription loadSceneFile(const std::filesystem::path& path);

// A Wavefront OBJ triangle mesh (polygons are fan-triangulated) with smooth
// per-vertex normals averaged from the faces around each vertex (area-weighted).
// Units: the file's units are taken as millimetres.
TriangleMesh loadObjMesh(const std::filesystem::path& path);

// position (mm) and rotation (degrees, applied about x, then y, then z).
Rigid3 placement(const std::vector<double>& position_mm, const std::vector<double>& rotation_deg);

}  // namespace lfi::sim
