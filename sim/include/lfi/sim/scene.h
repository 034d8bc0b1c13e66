// SPDX-License-Identifier: Apache-2.0
#pragma once
// A bench scene for the ray tracer: objects (a shape, where it is, what it is
// made of, whether it emits) in the world frame, with Embree doing the ray
// queries (rays inside an isolated solid, which only it can meet, excepted).
// Analytic solids and rectangles are Embree user geometry intersected exactly
// in double precision; triangle meshes are Embree's own (float) geometry.
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
//   LightFieldEmission  light field, lookup               the light field emitter; the
//                                                         object's local frame is the plane frame
//   PanelEmission       panel optics, drive levels,       the physical light field display: panel
//                       brightness                        pixels behind lenslets or a barrier (below);
//                                                         the object's local frame is the display frame
// World frame: mm, +z along the optical axis towards the camera.

#include "lfi/core/geometry.h"
#include "lfi/core/light_field.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/sim/solid.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
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

// The physical model of a light field display: every class of display.h's
// OpticsType, followed back through its own lens, slit or pinhole
// (DisplayOptics::sourceOfRay; the classes' models and what they leave out are
// in lfi/drivers/optics/). Frame: the display frame of display.h (origin at the
// panel's centre, x along columns, y up, z = 0 the lens/barrier plane, +z the
// emitting side); the pixel plane is at z = -gap. Millimetres, radians.
//
// A ray leaving the plane at q in direction d (dz > 0) gets the radiance of the
// subpixel it comes from: subpixels are pitch/3 wide stripes (RGB/BGR) or whole
// pixels (mono), 100 % fill factor, each a uniform emitter; the bezel around the
// panel and the opaque parts of a barrier or pinhole array are black. Pixels
// under the neighbouring lens are reached at steep angles (the repeated view
// zones of a real display). Finite angular resolution (a subpixel spans
// ≈ pitch / gap), defocus blur, crosstalk and barrier loss follow from this geometry.
class PanelOptics {
 public:
  // Validates `info` (Errc::InvalidArgument naming the field).
  explicit PanelOptics(const DisplayInfo& info) : optics_(info) {}
  const DisplayInfo& info() const { return optics_.info(); }
  // Column in the level image (col · subpixels + subpixel) and row of the subpixel
  // that the ray (q on z = 0, direction d, display frame) comes from; false when the
  // array blocks it, d points backwards or the pixel is off the panel.
  bool subpixelOfRay(const Vec2& q, const Vec3& d, int& column, int& row) const;

 private:
  DisplayOptics optics_;
};

// Emission of a display object: the level image is what the panel shows, one float
// per subpixel (CV_32FC1, panelHeight x panelWidth · subpixels, drive level 0..1;
// empty for a dark panel), `brightness` the radiance at drive level 1. Build it
// with makePanelEmission().
struct PanelEmission {
  std::shared_ptr<const PanelOptics> optics;
  std::shared_ptr<const cv::Mat> levels;
  double brightness = 1;
  // Radiance along the ray leaving the display plane at q with direction d (display frame).
  double radiance(const Vec2& q, const Vec3& d) const;
};

// How the simulated panel turns drive into light (the truth a measured
// lfi::PanelResponse is tested against, kept apart from it): relative radiance R(v) at drive level v
// (0..1 of full drive; an 8-bit level / 255), from a power law v^gamma or a
// table of R at equally spaced levels 0, 1/(n-1), .., 1 (linear between,
// non-decreasing, R(1) = 1), times the backlight, 1 - f (r / r_corner)^2 at a
// pixel whose centre is r from the panel's centre (r_corner: its half
// diagonal; 1 at the centre, 1 - f at the corners). The default is linear and
// uniform.
struct PanelLight {
  double gamma = 1;
  std::vector<double> table;  // used when not empty
  double backlightFalloff = 0;
  bool linear() const { return table.empty() && gamma == 1 && backlightFalloff == 0; }
  // R(v) for v in [0, 1] (clamped to it), the backlight left out.
  double at(double level) const;
};

// `panel`: panelWidth x panelHeight, channels = subpixels per pixel in subpixel order,
// CV_8U (level / 255) or CV_32F (level as is, clamped to >= 0); empty = a dark panel,
// whose level image is empty too. With `light`, each level becomes the
// relative radiance it drives (levels above 1 take R(1) · level). Throws
// Errc::InvalidArgument for a wrong size or type.
cv::Mat panelLevels(const DisplayInfo& info, const cv::Mat& panel, const PanelLight& light = {});
PanelEmission makePanelEmission(std::shared_ptr<const PanelOptics> optics, const cv::Mat& panel, double brightness);

using Emission = std::variant<ParallelEmission, LambertianEmission, LightFieldEmission, PanelEmission>;

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

// The world-frame box of an object's surface: its solid's bounds (conservative
// for CSG), its rectangle or its mesh's vertices, placed by worldFromObject.
Bounds worldBounds(const Object& object);

// What the tracer needs of an object where a path meets it, flattened from the
// object's shape, material and emission variants (Scene keeps one per object).
struct Surface {
  enum class Kind : std::uint8_t { Emitter, Absorber, Diffuse, Dielectric };
  Kind kind = Kind::Absorber;  // an emitting object is opaque: Emitter whatever its material
  bool exact = true;           // a solid or a rectangle (double precision); meshes are float
  double ior = 1;              // Dielectric
  double absorption_per_mm = 0;
  double albedo = 0;  // Diffuse
  // Parallel and Lambertian emission, worked out once: `radiance` into the
  // directions with cos θ >= cosHalfAngle (θ from the normal; Lambertian: the
  // open hemisphere, cosHalfAngle the least double above 0).
  bool uniformEmission = false;
  double radiance = 0;
  double cosHalfAngle = 1;
};

// What a ray hit: the object, the distance and the surface there.
struct Hit {
  int object = -1;
  double t = 0;
  Vec3 point;
  Vec3 normal;  // outward (for solids and meshes) or +z local (rectangles), world frame, unit
  bool valid() const { return object >= 0; }
};

class Scene {
 public:
  explicit Scene(std::vector<Object> objects, double ambientIor = 1.0);
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  // Nearest hit with t in (tMin, tMax); invalid Hit when there is none. The
  // default tMin keeps a ray leaving a surface from hitting it again at t ~ 0.
  static constexpr double kTMin = 1e-6;
  Hit intersect(const Ray& ray, double tMin = kTMin, double tMax = std::numeric_limits<double>::infinity()) const;
  // The same for up to kPacket rays at once, traced as one Embree packet: much
  // cheaper per ray when the rays are coherent (a pixel's samples). hits[k] is
  // rays[k]'s nearest hit with t > tMin. `starts`, empty or one per ray, says
  // where each ray starts as the tracer knows it (RayStart), which lets the
  // query skip work: a solid whose bounds meet no other object's answers the
  // rays inside it without a traversal (the tracer's rays inside a lens), and
  // a convex solid is not tested against the rays leaving it.
  static constexpr size_t kPacket = 16;
  struct RayStart {
    int inside = -1;  // the innermost object the ray starts inside (-1: the ambient medium); a hint
    int on = -1;      // the object whose surface the ray leaves from (-1: none); must be true
  };
  void intersect(std::span<const Ray> rays, std::span<Hit> hits, double tMin = kTMin,
                 std::span<const RayStart> starts = {}) const;
  // The same packet query in structures of arrays, the tracer's form: the
  // rays of the lanes set in `lanes` (bit k: lane k), each with its RayStart,
  // and their hits in the same lanes (a hit's point is rays.ray(k).at(t)).
  // Lanes not set get no hit; their rays only take part in lane-parallel
  // arithmetic whose results are dropped (any finite values will do). A
  // RayStart naming no object (outside -1 .. objects - 1) is
  // Errc::InvalidArgument.
  struct RayPacket {
    RayLanes rays;  // world frame
    int inside[kPacket], on[kPacket];
  };
  struct HitPacket {
    alignas(64) double t[kPacket];
    alignas(64) double nx[kPacket], ny[kPacket], nz[kPacket];  // as Hit::normal
    int object[kPacket];                                       // -1: no hit
    Vec3 normal(int k) const { return {nx[k], ny[k], nz[k]}; }
  };
  void intersect(const RayPacket& rays, std::uint32_t lanes, HitPacket& hits, double tMin = kTMin) const;

  const std::vector<Object>& objects() const { return objects_; }
  const Object& object(int index) const { return objects_[static_cast<size_t>(index)]; }
  const Rigid3& objectFromWorld(int index) const;
  // Whether an object is a solid whose bounds meet no other object's: a ray
  // starting inside it meets it before anything else, and the packet query
  // answers such rays (RayStart::inside) without a traversal.
  bool isolated(int index) const;
  const Surface& surface(int index) const { return surfaces_[static_cast<size_t>(index)]; }
  // Replaces what an object emits (geometry and material stay). For the display's
  // changing panel; not while another thread renders this scene.
  void setEmission(int index, std::optional<Emission> emission);
  // Index of refraction of the medium around every object (air: 1.0). Paths
  // start in this medium: sensors sit outside the parts.
  double ambientIor() const { return ambientIor_; }

 private:
  // A mesh's hit (Embree's; `tfar` from the ray's own origin: Embree's float t
  // plus where its copy of the ray started) of a ray along `direction` where it
  // is nearer than the analytic objects' in `hits`.
  void meshHit(int k, const Vec3& direction, unsigned geomID, unsigned primID, double tfar, const Vec3& ng, float u,
               float v, HitPacket& hits) const;

  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<Object> objects_;
  std::vector<Surface> surfaces_;  // one per object
  double ambientIor_;
};

}  // namespace lfi::sim
