// SPDX-License-Identifier: Apache-2.0
// Where rays meet solids: one ray's intervals through a solid (primitives, convex
// parts, the boolean event merge) and the nearest crossings of many rays at once,
// lane-parallel; both give the same bits.

#include "lfi/sim/solid.h"

#include "lfi/core/error.h"

#include "simd.h"
#include "solid_internal.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <utility>

namespace lfi::sim {

namespace {

using detail::isPrimitive;
using detail::kInf;

struct Event {
  double t;
  Vec3 normal;
  bool fromA;
  bool entering;
};

}  // namespace

namespace {

// The interval [t0, t1] of a primitive along a line in its own frame; false
// when the line misses it. Ends may be infinite (a line parallel to a
// cylinder's axis or a half space's plane, inside it).
bool primitiveSpan(Solid::Kind kind, double radius, const Ray& ray, double& t0, double& t1) {
  const Vec3& o = ray.origin;
  const Vec3& d = ray.direction;
  switch (kind) {
    case Solid::Kind::Sphere: {
      const double b = o.dot(d);
      const double c = o.dot(o) - radius * radius;
      const double disc = b * b - c;
      if (disc < 0) return false;
      const double sq = std::sqrt(disc);
      // Stable roots: avoid cancellation in -b +- sq.
      if (b > 0) {
        t0 = -b - sq;
        t1 = c / t0;
      } else {
        t1 = -b + sq;
        t0 = t1 != 0 ? c / t1 : -b - sq;
      }
      if (t0 > t1) std::swap(t0, t1);
      return true;
    }
    case Solid::Kind::Cylinder: {
      const double a = d.x * d.x + d.y * d.y;
      const double c = o.x * o.x + o.y * o.y - radius * radius;
      if (a < 1e-300) {
        t0 = -kInf, t1 = kInf;
        return c <= 0;
      }
      const double b = o.x * d.x + o.y * d.y;
      const double disc = b * b - a * c;
      if (disc < 0) return false;
      const double sq = std::sqrt(disc);
      const double q = b > 0 ? -(b + sq) : -(b - sq);
      t0 = q / a, t1 = q != 0 ? c / q : t0;
      if (t0 > t1) std::swap(t0, t1);
      return true;
    }
    case Solid::Kind::HalfSpace: {
      if (d.z == 0) {
        t0 = -kInf, t1 = kInf;
        return o.z <= 0;
      }
      const double t = -o.z / d.z;
      t0 = d.z > 0 ? -kInf : t;
      t1 = d.z > 0 ? t : kInf;
      return true;
    }
    default:
      return false;
  }
}

// Outward normal of a primitive where the line meets it at t (its own frame).
// At an infinite end there is no surface; the normal then just points along
// the line's way out (-z entering, +z leaving) and is never used for shading.
Vec3 primitiveNormal(Solid::Kind kind, double radius, const Ray& ray, double t, bool entering) {
  if (!std::isfinite(t)) return {0, 0, entering ? -1.0 : 1.0};
  switch (kind) {
    case Solid::Kind::Sphere:
      return ray.at(t) / radius;
    case Solid::Kind::Cylinder: {
      const Vec3 p = ray.at(t);
      return Vec3(p.x, p.y, 0) / radius;
    }
    default:
      return {0, 0, 1};
  }
}

}  // namespace

void IntervalList::push(const Interval& interval) {
  if (size_ == kCapacity) fail(Errc::InvalidArgument, "solid: more than {} intervals along one ray", kCapacity);
  items_[size_++] = interval;
}

void Solid::intervals(const Ray& ray, IntervalList& out) const {
  out.clear();
  if (identity_) {
    localIntervals(ray, out);
    return;
  }
  localIntervals({localFromParent_.point(ray.origin), localFromParent_.vector(ray.direction)}, out);
  for (int i = 0; i < out.size(); ++i) {
    out[i].enter.normal = parentFromLocal_.vector(out[i].enter.normal);
    out[i].exit.normal = parentFromLocal_.vector(out[i].exit.normal);
  }
}

[[gnu::always_inline]] inline Vec3 Solid::ConvexPart::normal(const Ray& ray, double t, bool entering) const {
  // (As primitiveNormal in the part's frame, turned into this node's.)
  if (!std::isfinite(t)) return axis * (entering ? -1.0 : 1.0);
  const Vec3 p = ray.at(t) - origin;
  switch (kind) {
    case Kind::Sphere:
      return p * invRadius;
    case Kind::Cylinder:
      return (p - axis * p.dot(axis)) * invRadius;
    default:
      return axis;
  }
}

void Solid::convexIntervals(const Ray& ray, IntervalList& out) const {
  double enter = -kInf, exit = kInf;
  int enterPart = -1, exitPart = -1;
  for (int i = 0; i < static_cast<int>(convex_.size()); ++i) {
    const ConvexPart& part = convex_[static_cast<size_t>(i)];
    const Ray local =
        part.identity ? ray : Ray{part.partFromLocal.point(ray.origin), part.partFromLocal.vector(ray.direction)};
    double t0, t1;
    if (!primitiveSpan(part.kind, part.radius, local, t0, t1)) return;
    if (t0 > enter || enterPart < 0) enter = t0, enterPart = i;
    if (t1 < exit || exitPart < 0) exit = t1, exitPart = i;
    if (exit <= enter) return;
  }
  out.push({{enter, convex_[static_cast<size_t>(enterPart)].normal(ray, enter, true)},
            {exit, convex_[static_cast<size_t>(exitPart)].normal(ray, exit, false)}});
}

namespace {

constexpr int kLanes = RayLanes::kSize;

// Rays into a part's frame: p' = R p + t, d' = R d.
LFI_SIMD_CLONES void transformLanes(const Rigid3& x, const RayLanes& __restrict in, RayLanes& __restrict out) {
  const double* r = x.r.data();
  for (int k = 0; k < kLanes; ++k) {
    out.ox[k] = r[0] * in.ox[k] + r[1] * in.oy[k] + r[2] * in.oz[k] + x.t.x;
    out.oy[k] = r[3] * in.ox[k] + r[4] * in.oy[k] + r[5] * in.oz[k] + x.t.y;
    out.oz[k] = r[6] * in.ox[k] + r[7] * in.oy[k] + r[8] * in.oz[k] + x.t.z;
    out.dx[k] = r[0] * in.dx[k] + r[1] * in.dy[k] + r[2] * in.dz[k];
    out.dy[k] = r[3] * in.dx[k] + r[4] * in.dy[k] + r[5] * in.dz[k];
    out.dz[k] = r[6] * in.dx[k] + r[7] * in.dy[k] + r[8] * in.dz[k];
  }
}

// One primitive's span [t0, t1] on every lane (primitiveSpan's arithmetic,
// branch-free; a miss is the empty span [inf, -inf]), folded into the running
// intersection [enter, exit].
LFI_SIMD_CLONES void foldSpan(Solid::Kind kind, double radius, const RayLanes& __restrict l, double* __restrict t0,
                              double* __restrict t1, double* __restrict enter, double* __restrict exit) {
  switch (kind) {
    case Solid::Kind::Sphere:
      for (int k = 0; k < kLanes; ++k) {
        const double b = l.ox[k] * l.dx[k] + l.oy[k] * l.dy[k] + l.oz[k] * l.dz[k];
        const double c = l.ox[k] * l.ox[k] + l.oy[k] * l.oy[k] + l.oz[k] * l.oz[k] - radius * radius;
        const double disc = b * b - c;
        const double sq = std::sqrt(disc > 0 ? disc : 0);
        const double q = b > 0 ? -b - sq : -b + sq;  // the root without cancellation
        const double other = q != 0 ? c / q : q;
        t0[k] = disc < 0 ? kInf : (q < other ? q : other);
        t1[k] = disc < 0 ? -kInf : (q < other ? other : q);
      }
      break;
    case Solid::Kind::Cylinder:
      for (int k = 0; k < kLanes; ++k) {
        const double a = l.dx[k] * l.dx[k] + l.dy[k] * l.dy[k];
        const double c = l.ox[k] * l.ox[k] + l.oy[k] * l.oy[k] - radius * radius;
        const double b = l.ox[k] * l.dx[k] + l.oy[k] * l.dy[k];
        const double disc = b * b - a * c;
        const double sq = std::sqrt(disc > 0 ? disc : 0);
        const double q = b > 0 ? -(b + sq) : -(b - sq);
        const double r0 = q / (a < 1e-300 ? 1.0 : a);
        const double r1 = q != 0 ? c / q : r0;
        // Parallel to the axis: all of the line inside, or none of it.
        const double parallel0 = c > 0 ? kInf : -kInf, parallel1 = c > 0 ? -kInf : kInf;
        t0[k] = a < 1e-300 ? parallel0 : disc < 0 ? kInf : (r0 < r1 ? r0 : r1);
        t1[k] = a < 1e-300 ? parallel1 : disc < 0 ? -kInf : (r0 < r1 ? r1 : r0);
      }
      break;
    default:  // HalfSpace
      for (int k = 0; k < kLanes; ++k) {
        const double dz = l.dz[k], oz = l.oz[k];
        const double t = -oz / (dz == 0 ? 1.0 : dz);
        // Parallel to the plane: all of the line inside, or none of it.
        const double flat0 = oz > 0 ? kInf : -kInf, flat1 = oz > 0 ? -kInf : kInf;
        t0[k] = dz == 0 ? flat0 : dz > 0 ? -kInf : t;
        t1[k] = dz == 0 ? flat1 : dz < 0 ? kInf : t;
      }
      break;
  }
  for (int k = 0; k < kLanes; ++k) {
    enter[k] = t0[k] > enter[k] ? t0[k] : enter[k];
    exit[k] = t1[k] < exit[k] ? t1[k] : exit[k];
  }
}

}  // namespace

void transformRays(const Rigid3& x, const RayLanes& in, RayLanes& out) {
  transformLanes(x, in, out);
}

void Solid::nearestCrossings(int n, const Ray* rays, double tMin, double* t, Vec3* normal) const {
  if (n < 0 || n > kBatch) fail(Errc::InvalidArgument, "Solid::nearestCrossings: {} rays (at most {})", n, kBatch);
  // Lanes beyond n carry a harmless ray; their results are not read.
  RayLanes lanes;
  for (int k = 0; k < kLanes; ++k) lanes.set(k, rays[k < n ? k : 0]);
  nearestCrossings(lanes, (1u << n) - 1, tMin, t, normal);
}

[[gnu::always_inline]] inline void Solid::laneSpans(const RayLanes& rays, LaneSpans& out) const {
  if (!identity_) transformLanes(localFromParent_, rays, out.transformed);
  out.local = identity_ ? &rays : &out.transformed;
  const RayLanes& local = *out.local;
  for (int k = 0; k < kLanes; ++k) out.enter[k] = -kInf, out.exit[k] = kInf;
  out.primitive = isPrimitive(kind_);
  if (out.primitive) {  // primitiveSpan's interval (present when it is not empty, even of zero length)
    foldSpan(kind_, radius_, local, out.t0[0], out.t1[0], out.enter, out.exit);
    return;
  }
  RayLanes part;
  for (size_t p = 0; p < convex_.size(); ++p) {
    const ConvexPart& c = convex_[p];
    if (!c.identity) transformLanes(c.partFromLocal, local, part);
    foldSpan(c.kind, c.radius, c.identity ? local : part, out.t0[p], out.t1[p], out.enter, out.exit);
  }
}

[[gnu::always_inline]] inline Vec3 Solid::spanNormal(const LaneSpans& spans, int k, double t, bool entering) const {
  const Ray local = spans.local->ray(k);
  Vec3 n;
  if (spans.primitive) {
    n = primitiveNormal(kind_, radius_, local, t, entering);
  } else {
    // The part that set the crossing: the first whose span end equals it (as convexIntervals).
    const double(&ends)[kMaxConvexParts][kLanes] = entering ? spans.t0 : spans.t1;
    const size_t last = convex_.size() - 1;
    size_t which = 0;
    while (which < last && ends[which][k] != t) ++which;
    n = convex_[which].normal(local, t, entering);
  }
  return identity_ ? n : parentFromLocal_.vector(n);
}

void Solid::nearestCrossings(const RayLanes& rays, std::uint32_t lanes, double tMin, double* t, Vec3* normal) const {
  // The lane-parallel kernel costs about as much as three one-ray queries
  // whatever the number of rays (measured: 141 ns for 1 ray, 280 ns for 16,
  // 48 ns per ray one at a time): a few rays go one at a time.
  constexpr int kFewRays = 3;
  static_assert(kLanes < 32);
  lanes &= (1u << kLanes) - 1;
  if ((convex_.empty() && !convexDifference_) || std::popcount(lanes) <= kFewRays) {
    IntervalList list;
    for (; lanes; lanes &= lanes - 1) {
      const int k = std::countr_zero(lanes);
      intervals(rays.ray(k), list);
      t[k] = kInf;
      for (int i = 0; i < list.size() && t[k] == kInf; ++i)
        for (const SurfacePoint* s : {&list[i].enter, &list[i].exit})
          if (s->t > tMin && std::isfinite(s->t)) {
            t[k] = s->t;
            normal[k] = s->normal;
            break;
          }
    }
    return;
  }
  if (convexDifference_) {
    differenceCrossings(rays, lanes, tMin, t, normal);
    return;
  }
  // Every lane is computed; only the lanes asked for are read.
  LaneSpans spans;
  laneSpans(rays, spans);
  const RayLanes& local = *spans.local;
  const int parts = static_cast<int>(convex_.size());
  for (; lanes; lanes &= lanes - 1) {
    const int k = std::countr_zero(lanes);
    t[k] = kInf;
    if (!(spans.exit[k] > spans.enter[k])) continue;
    const bool front = spans.enter[k] > tMin;
    const double hit = front ? spans.enter[k] : spans.exit[k];
    if (!(hit > tMin) || !std::isfinite(hit)) continue;
    // The part that set the crossing: the first whose span end equals it (as convexIntervals).
    int which = 0;
    while (which + 1 < parts && (front ? spans.t0[which][k] : spans.t1[which][k]) != hit) ++which;
    const Vec3 n1 = convex_[static_cast<size_t>(which)].normal(local.ray(k), hit, front);
    t[k] = hit;
    normal[k] = identity_ ? n1 : parentFromLocal_.vector(n1);
  }
}

void Solid::differenceCrossings(const RayLanes& rays, std::uint32_t lanes, double tMin, double* t, Vec3* normal) const {
  RayLanes transformed;
  if (!identity_) transformLanes(localFromParent_, rays, transformed);
  const RayLanes& local = identity_ ? rays : transformed;
  LaneSpans a, b;
  a_->laneSpans(local, a);
  b_->laneSpans(local, b);
  for (; lanes; lanes &= lanes - 1) {
    const int k = std::countr_zero(lanes);
    t[k] = kInf;
    if (!a.present(k)) continue;  // empty - B = empty
    // localIntervals' merge of A's and B's boundary events (A first on ties),
    // emitting where "in A and not in B" changes; the first boundary of the
    // result past tMin, as the one-ray query takes it.
    struct Event {
      double t;
      bool fromA, entering;
    };
    Event ea[2] = {{a.enter[k], true, true}, {a.exit[k], true, false}};
    Event eb[2] = {{b.enter[k], false, true}, {b.exit[k], false, false}};
    const int nb = b.present(k) && b.exit[k] > b.enter[k] ? 2 : 0;  // (a tangent B, of no length, cuts nothing)
    Event events[4];
    int ia = 0, ib = 0, n = 0;
    while (ia < 2 || ib < nb) events[n++] = ib < nb && (ia == 2 || eb[ib].t < ea[ia].t) ? eb[ib++] : ea[ia++];
    bool inA = false, inB = false, inside = false;
    Event enter{};
    for (int i = 0; i < n; ++i) {
      const Event& e = events[i];
      (e.fromA ? inA : inB) = e.entering;
      const bool now = inA && !inB;
      if (now == inside) continue;
      inside = now;
      if (now) {
        enter = e;
        continue;
      }
      if (!(e.t > enter.t)) continue;  // an empty interval is not kept
      const Event* end = enter.t > tMin && std::isfinite(enter.t) ? &enter
                         : e.t > tMin && std::isfinite(e.t)       ? &e
                                                                  : nullptr;
      if (!end) continue;
      // B's surface faces the other way in the result.
      const Vec3 n1 =
          end->fromA ? a_->spanNormal(a, k, end->t, end->entering) : -b_->spanNormal(b, k, end->t, end->entering);
      t[k] = end->t;
      normal[k] = identity_ ? n1 : parentFromLocal_.vector(n1);
      break;
    }
  }
}

void Solid::localIntervals(const Ray& ray, IntervalList& out) const {
  if (isPrimitive(kind_)) {
    double t0, t1;
    if (primitiveSpan(kind_, radius_, ray, t0, t1))
      out.push({{t0, primitiveNormal(kind_, radius_, ray, t0, true)},
                {t1, primitiveNormal(kind_, radius_, ray, t1, false)}});
    return;
  }
  if (!convex_.empty()) {
    convexIntervals(ray, out);
    return;
  }
  switch (kind_) {
    case Kind::Sphere:
    case Kind::Cylinder:
    case Kind::HalfSpace:
      return;
    case Kind::Union:
    case Kind::Intersection:
    case Kind::Difference: {
      IntervalList la, lb;
      a_->intervals(ray, la);
      if (kind_ != Kind::Union && la.size() == 0) return;  // empty ∩ x = empty − x = empty
      b_->intervals(ray, lb);
      // Merge the boundary events of both lists in t order and emit the
      // boundaries where the boolean's membership changes.
      // Each list is sorted and disjoint, so its events are already in order:
      // a linear merge is enough (A first on ties).
      // (An interval of no length, a ray tangent to a ball, changes nothing:
      // kept, a tangent cut-out would split A's interval with a gap of none.)
      std::array<Event, 2 * IntervalList::kCapacity> ea, eb;
      std::array<Event, 4 * IntervalList::kCapacity> events;
      int na = 0, nb = 0;
      for (int i = 0; i < la.size(); ++i)
        if (la[i].exit.t > la[i].enter.t) {
          ea[na++] = {la[i].enter.t, la[i].enter.normal, true, true};
          ea[na++] = {la[i].exit.t, la[i].exit.normal, true, false};
        }
      for (int i = 0; i < lb.size(); ++i)
        if (lb[i].exit.t > lb[i].enter.t) {
          eb[nb++] = {lb[i].enter.t, lb[i].enter.normal, false, true};
          eb[nb++] = {lb[i].exit.t, lb[i].exit.normal, false, false};
        }
      const int n = na + nb;
      std::merge(ea.begin(), ea.begin() + na, eb.begin(), eb.begin() + nb, events.begin(),
                 [](const Event& x, const Event& y) { return x.t < y.t; });
      bool inA = false, inB = false, inside = false;
      Interval current{};
      for (int i = 0; i < n; ++i) {
        const Event& e = events[i];
        (e.fromA ? inA : inB) = e.entering;
        const bool now = kind_ == Kind::Union          ? (inA || inB)
                         : kind_ == Kind::Intersection ? (inA && inB)
                                                       : (inA && !inB);
        if (now == inside) continue;
        // The subtracted solid's surface faces the other way in the result.
        const Vec3 normal = (kind_ == Kind::Difference && !e.fromA) ? -e.normal : e.normal;
        if (now) {
          current.enter = {e.t, normal};
        } else {
          current.exit = {e.t, normal};
          if (current.exit.t > current.enter.t) out.push(current);
        }
        inside = now;
      }
      return;
    }
  }
}

}  // namespace lfi::sim
