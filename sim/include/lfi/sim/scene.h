#pragma once
// A bench scene for the ray tracer: objects (a shape, where it is, what it is
// made of, whether it emits) in the world frame, with Embree doing every ray
// query. Analytic solids are Embree user geometry intersected exactly in double
// precision; triangle meshes and rectangles are Embree's own geometry.
//
// Materials:
//   material     parameters                    behaviour
//   Dielectric   ior n, absorption_per_mm a    Fresnel reflection/refraction, Snell, TIR;
//                                              Beer-Lambert attenuation exp(-a s) inside
//   Absorber     -                             absorbs everything (opaque inclusion)
//   Diffuse      albedo                        Lambertian reflection
// Emitters (radiance in relative units; an emitting object is opaque):
//   ParallelEmission    radiance L, halfAngle_rad θmax   L into the cone around the surface normal
//   LambertianEmission  radiance L                        L into the whole outer hemisphere
//   LightFieldEmission  light field, lookup               SPEC §2 light field emitter; the
//                                                         object's local frame is the plane frame
// World frame: mm, +z along the optical axis towards the camera.

#include "lfi/core/geometry.h"
#include "lfi/core/light_field.h"
#include "lfi/sim/solid.h"

#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace lfi::sim {

struct Dielectric {
  double ior = 1.5;
  double absorption_per_mm = 0;
};
struct Absorber {};
struct Diffuse {
  double albedo = 0.8;
};
using Material = std::variant<Dielectric, Absorber, Diffuse>;

struct ParallelEmission {
  double radiance = 1;
  double halfAngle_rad = 0.01;
};
struct LambertianEmission {
  double radiance = 1;
};
struct LightFieldEmission {
  std::shared_ptr<const LightField> lightField;
  LightFieldLookup lookup = LightFieldLookup::Nearest;
};
using Emission = std::variant<ParallelEmission, LambertianEmission, LightFieldEmission>;

// A rectangle in its local xy plane, centred at the origin, normal +z.
struct Rectangle {
  double sizeX = 1;
  double sizeY = 1;
};
// A closed triangle mesh (outward winding) with optional per-vertex normals.
struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<Vec3> normals;  // empty, or one per vertex (smooth shading)
  std::vector<std::array<unsigned, 3>> triangles;
};
using Shape = std::variant<std::shared_ptr<const Solid>, Rectangle, TriangleMesh>;

struct Object {
  std::string name;
  Shape shape;
  Rigid3 worldFromObject;
  Material material = Absorber{};
  std::optional<Emission> emission;
};

// What a ray hit: the object, the distance and the surface there.
struct Hit {
  int object = -1;
  double t = 0;
  Vec3 point;
  Vec3 normal;        // outward (for solids and meshes) or +z local (rectangles), world frame, unit
  Vec3 localPoint;    // in the object's frame
  bool valid() const { return object >= 0; }
};

class Scene {
public:
  explicit Scene(std::vector<Object> objects, double ambientIor = 1.0);
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  // Nearest hit with t in (tMin, tMax); invalid Hit when there is none.
  Hit intersect(const Ray& ray, double tMin = 1e-6, double tMax = std::numeric_limits<double>::infinity()) const;

  const std::vector<Object>& objects() const { return objects_; }
  const Object& object(int index) const { return objects_[static_cast<size_t>(index)]; }
  const Rigid3& objectFromWorld(int index) const;
  // Index of refraction of the medium around every object (air: 1.0). Paths
  // start in this medium: sensors sit outside the parts.
  double ambientIor() const { return ambientIor_; }

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<Object> objects_;
  double ambientIor_;
};

}  // namespace lfi::sim
