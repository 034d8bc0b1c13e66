// SPDX-License-Identifier: Apache-2.0
#pragma once
// Analytic solids and constructive solid geometry, intersected exactly in
// double precision. A solid is a closed set; along a line it is a sorted list
// of disjoint intervals [t_enter, t_exit], each end carrying the solid's
// outward surface normal. Booleans combine those lists, so union, intersection
// and difference are exact for any nesting (no tessellation).
//
// Primitives, in the node's local frame (mm):
//   kind       parameters        set
//   Sphere     radius r          |p| <= r
//   Cylinder   radius r          x^2 + y^2 <= r^2 (infinite along z)
//   HalfSpace  -                 z <= 0 (outward normal +z)
// Every node carries parentFromLocal, so any subtree can be placed.

#include "lfi/core/geometry.h"

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lfi::sim {

// z of a spherical lens face (radius as Solid::sphericalLens, 0: flat) whose
// vertex is at z0, at radial distance r <= |radius| from the axis.
double sphericalFaceZ(double radius, double z0, double r);

// Why no spherical lens (Solid::sphericalLens) has this shape, or nothing:
// which value is at fault and why. A face's |radius| must reach the
// semi-diameter, and the faces must not meet inside the diameter (the edge
// thickness, backZ - frontZ at the semi-diameter, must be >= 0; the thickness
// is monotonic in r, so the centre and the edge bound it). File readers use
// the part to name their own key.
struct LensFault {
  enum class Part { Thickness, Diameter, FrontRadius, BackRadius, Edge };
  Part part;
  std::string why;
};
std::optional<LensFault> sphericalLensFault(double frontRadius, double backRadius, double centreThickness,
                                            double diameter);

// Whether the ball of `radius` about `centre` (the lens's frame) lies wholly
// inside the spherical lens of these faces (as Solid::sphericalLens builds it,
// its rim planes included), exactly.
bool sphericalLensHolds(double frontRadius, double backRadius, double centreThickness, double diameter,
                        const Vec3& centre, double radius);

struct Ray {
  Vec3 origin;
  Vec3 direction;  // unit length
  Vec3 at(double t) const { return origin + direction * t; }
};

// Up to kSize rays as a structure of arrays, one lane per ray: the form the
// lane-parallel queries (packets of the tracer, a solid's convex kernel) read.
struct RayLanes {
  static constexpr int kSize = 16;
  alignas(64) double ox[kSize], oy[kSize], oz[kSize], dx[kSize], dy[kSize], dz[kSize];
  Ray ray(int k) const { return {{ox[k], oy[k], oz[k]}, {dx[k], dy[k], dz[k]}}; }
  void set(int k, const Ray& r) {
    ox[k] = r.origin.x, oy[k] = r.origin.y, oz[k] = r.origin.z;
    dx[k] = r.direction.x, dy[k] = r.direction.y, dz[k] = r.direction.z;
  }
};
// Every lane of `in` in another frame: out = x applied to in (points and directions).
void transformRays(const Rigid3& x, const RayLanes& in, RayLanes& out);

// No default member initialisers: interval lists live on the hot path and
// must cost nothing to create.
struct SurfacePoint {
  double t;
  Vec3 normal;  // outward normal of the solid, unit
};

struct Interval {
  SurfacePoint enter;
  SurfacePoint exit;
};

// Fixed-capacity interval list: no allocation on the hot path. Shapes in this
// project produce at most a handful of intervals per line.
class IntervalList {
 public:
  static constexpr int kCapacity = 16;
  int size() const { return size_; }
  const Interval& operator[](int i) const { return items_[i]; }
  Interval& operator[](int i) { return items_[i]; }
  void push(const Interval& interval);  // throws if the capacity is exceeded
  void clear() { size_ = 0; }

 private:
  std::array<Interval, kCapacity> items_;
  int size_ = 0;
};

struct Bounds {
  Vec3 lo{std::numeric_limits<double>::infinity()};
  Vec3 hi{-std::numeric_limits<double>::infinity()};
  bool finite() const;
  Bounds transformed(const Rigid3& parentFromLocal) const;
  Bounds intersect(const Bounds& other) const;
  Bounds unite(const Bounds& other) const;
  // How a ball (centre, radius) lies against the box: clear of it, holding all
  // of it, or neither. A cut-out clear of a part's box changes nothing, one
  // holding it leaves nothing (Solid::bounds is a box around the part).
  enum class Ball { Clear, HoldsAll, Overlaps };
  Ball ball(const Vec3& centre, double radius) const;
  std::string text() const;  // "[x, y, z] to [x, y, z] mm"
};

class Solid {
 public:
  enum class Kind { Sphere, Cylinder, HalfSpace, Union, Intersection, Difference };

  static std::shared_ptr<Solid> sphere(double radius, const Rigid3& parentFromLocal = {});
  static std::shared_ptr<Solid> cylinder(double radius, const Rigid3& parentFromLocal = {});
  static std::shared_ptr<Solid> halfSpace(const Rigid3& parentFromLocal = {});
  static std::shared_ptr<Solid> combine(Kind op, std::shared_ptr<const Solid> a, std::shared_ptr<const Solid> b,
                                        const Rigid3& parentFromLocal = {});

  // A spherical lens in optics sign convention: front vertex at z = -tc/2,
  // back vertex at z = +tc/2, radius > 0 when the centre of curvature lies on
  // the +z side of the vertex, 0 for a flat face; diameter is the edge cylinder.
  // Throws Errc::InvalidArgument for a shape sphericalLensFault() refuses.
  static std::shared_ptr<Solid> sphericalLens(double frontRadius, double backRadius, double centreThickness,
                                              double diameter);

  // All intervals of the line origin + t direction (any t), in the parent frame.
  void intervals(const Ray& ray, IntervalList& out) const;
  // For each of n <= kBatch rays (parent frame): the nearest crossing of the
  // solid's boundary with tMin < t < infinity, as t[k] and the outward unit
  // normal[k]; t[k] = infinity when there is none. The same crossings as
  // intervals(), to the bit, many rays at once: an intersection of convex
  // primitives (a lens) and a difference of two convex solids (a part with a
  // cut-out) are computed lane-parallel, in SIMD where the CPU has it.
  static constexpr int kBatch = RayLanes::kSize;
  void nearestCrossings(int n, const Ray* rays, double tMin, double* t, Vec3* normal) const;
  // The same for the lanes of `rays` whose bits are set in `lanes`: t[k] and
  // normal[k] for lane k; other lanes' results are not written.
  void nearestCrossings(const RayLanes& rays, std::uint32_t lanes, double tMin, double* t, Vec3* normal) const;
  Bounds bounds() const;                   // in the parent frame
  bool contains(const Vec3& point) const;  // in the parent frame
  Kind kind() const { return kind_; }
  // Convex (a sphere, a cylinder, a half space or an intersection of them): a
  // line meets it in one interval, so a ray leaving it does not meet it again.
  bool convex() const;

 private:
  Solid(Kind kind, double radius, const Rigid3& parentFromLocal);
  void localIntervals(const Ray& local, IntervalList& out) const;

  // An intersection of convex primitives (a lens, a cylinder cut by planes) is
  // one interval along any line: [latest entry, earliest exit]. Such nodes keep
  // their primitives flattened here, each with its frame relative to this
  // node, and skip the general event merge.
  struct ConvexPart {
    Kind kind;
    double radius;
    Rigid3 localFromPart;
    Rigid3 partFromLocal;
    bool identity;
    // The part in this node's frame, for its normals: its origin (a sphere's
    // centre, a point of a cylinder's axis or a plane), its z axis (the
    // cylinder's axis, the plane's outward normal), 1 / radius.
    Vec3 origin;
    Vec3 axis;
    double invRadius;
    static ConvexPart make(Kind kind, double radius, const Rigid3& localFromPart);
    // Outward normal where a ray (this node's frame) meets the part at t.
    Vec3 normal(const Ray& ray, double t, bool entering) const;
  };
  static constexpr size_t kMaxConvexParts = 8;  // longer chains take the general path
  void convexIntervals(const Ray& local, IntervalList& out) const;

  // A convex solid's (convex()) interval on every lane of rays given in its
  // parent's frame, lane-parallel: [enter, exit], empty unless present(k), and
  // each part's own span, to tell which part a crossing lies on.
  struct LaneSpans {
    const RayLanes* local;  // the rays in the solid's frame: the parent's, or `transformed`
    RayLanes transformed;
    double enter[RayLanes::kSize], exit[RayLanes::kSize];
    double t0[kMaxConvexParts][RayLanes::kSize], t1[kMaxConvexParts][RayLanes::kSize];
    bool primitive;
    bool present(int k) const { return primitive ? t0[0][k] <= t1[0][k] : exit[k] > enter[k]; }
  };
  void laneSpans(const RayLanes& rays, LaneSpans& out) const;
  // The outward normal (parent frame) where lane k crosses the solid at t, an
  // end of its span (entering: the start).
  Vec3 spanNormal(const LaneSpans& spans, int k, double t, bool entering) const;
  // A difference of two convex solids (a part with a cut-out), lane-parallel.
  void differenceCrossings(const RayLanes& rays, std::uint32_t lanes, double tMin, double* t, Vec3* normal) const;

  Kind kind_;
  double radius_ = 0;
  Rigid3 parentFromLocal_;
  Rigid3 localFromParent_;
  bool identity_ = true;
  std::shared_ptr<const Solid> a_, b_;
  std::vector<ConvexPart> convex_;  // empty unless the node is such an intersection
  bool convexDifference_ = false;   // a difference of two convex solids
};

}  // namespace lfi::sim
