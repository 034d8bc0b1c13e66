#include "lfi/sim/solid.h"

#include "lfi/core/error.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lfi::sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

bool isIdentity(const Rigid3& x) {
  const Rigid3 id;
  return x.r == id.r && x.t == id.t;
}

struct Event {
  double t;
  Vec3 normal;
  bool fromA;
  bool entering;
};

}  // namespace

void IntervalList::push(const Interval& interval) {
  if (size_ == kCapacity) fail(Errc::InvalidArgument, "solid: more than {} intervals along one ray", kCapacity);
  items_[size_++] = interval;
}

bool Bounds::finite() const {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(lo[i]) || !std::isfinite(hi[i])) return false;
  return true;
}

Bounds Bounds::transformed(const Rigid3& x) const {
  if (lo.x > hi.x || lo.y > hi.y || lo.z > hi.z) return *this;  // empty
  // Interval arithmetic per output axis (for a finite box, the same box as its
  // eight transformed corners). Along an unbounded input axis, rotation entries
  // below 1e-12 are the rounding residues of quarter and half turns
  // (sin(pi) = 1.2e-16) and count as exact zeros: a half space turned over
  // keeps its finite side, so cylinder ∩ two half spaces is bounded.
  Bounds out;
  for (int i = 0; i < 3; ++i) {
    double a = x.t[i], b = x.t[i];
    for (int j = 0; j < 3; ++j) {
      const double r = x.r[3 * i + j];
      if (r == 0 || (std::abs(r) < 1e-12 && !(std::isfinite(lo[j]) && std::isfinite(hi[j])))) continue;
      a += std::min(r * lo[j], r * hi[j]);
      b += std::max(r * lo[j], r * hi[j]);
    }
    out.lo[i] = a;
    out.hi[i] = b;
  }
  return out;
}

Bounds Bounds::intersect(const Bounds& o) const {
  Bounds out;
  for (int i = 0; i < 3; ++i) {
    out.lo[i] = std::max(lo[i], o.lo[i]);
    out.hi[i] = std::min(hi[i], o.hi[i]);
  }
  return out;
}

Bounds Bounds::unite(const Bounds& o) const {
  Bounds out;
  for (int i = 0; i < 3; ++i) {
    out.lo[i] = std::min(lo[i], o.lo[i]);
    out.hi[i] = std::max(hi[i], o.hi[i]);
  }
  return out;
}

Solid::Solid(Kind kind, double radius, const Rigid3& parentFromLocal)
    : kind_(kind), radius_(radius), parentFromLocal_(parentFromLocal),
      localFromParent_(parentFromLocal.inverse()), identity_(isIdentity(parentFromLocal)) {}

std::shared_ptr<Solid> Solid::sphere(double radius, const Rigid3& parentFromLocal) {
  if (!(radius > 0) || !std::isfinite(radius)) fail(Errc::InvalidArgument, "sphere radius {} must be > 0", radius);
  return std::shared_ptr<Solid>(new Solid(Kind::Sphere, radius, parentFromLocal));
}

std::shared_ptr<Solid> Solid::cylinder(double radius, const Rigid3& parentFromLocal) {
  if (!(radius > 0) || !std::isfinite(radius)) fail(Errc::InvalidArgument, "cylinder radius {} must be > 0", radius);
  return std::shared_ptr<Solid>(new Solid(Kind::Cylinder, radius, parentFromLocal));
}

std::shared_ptr<Solid> Solid::halfSpace(const Rigid3& parentFromLocal) {
  return std::shared_ptr<Solid>(new Solid(Kind::HalfSpace, 0, parentFromLocal));
}

std::shared_ptr<Solid> Solid::combine(Kind op, std::shared_ptr<const Solid> a, std::shared_ptr<const Solid> b,
                                      const Rigid3& parentFromLocal) {
  if (op != Kind::Union && op != Kind::Intersection && op != Kind::Difference)
    fail(Errc::InvalidArgument, "Solid::combine needs a boolean operation");
  if (!a || !b) fail(Errc::InvalidArgument, "Solid::combine needs two operands");
  auto s = std::shared_ptr<Solid>(new Solid(op, 0, parentFromLocal));
  s->a_ = std::move(a);
  s->b_ = std::move(b);
  return s;
}

std::shared_ptr<Solid> Solid::sphericalLens(double r1, double r2, double tc, double diameter) {
  if (!(tc > 0) || !(diameter > 0) || !std::isfinite(tc) || !std::isfinite(diameter))
    fail(Errc::InvalidArgument, "lens: thickness {} and diameter {} must be finite and > 0", tc, diameter);
  for (double r : {r1, r2})
    if (r != 0 && std::abs(r) < diameter / 2)
      fail(Errc::InvalidArgument, "lens: |radius| {} is smaller than the semi-diameter {}", std::abs(r), diameter / 2);
  // The half space on the glass side of the plane z = z0.
  auto glassSide = [](double z0, bool glassTowardsPlusZ) {
    Rigid3 x = glassTowardsPlusZ ? Rigid3::rotation({1, 0, 0}, std::numbers::pi) : Rigid3();
    x.t = {0, 0, z0};
    return halfSpace(x);
  };
  std::shared_ptr<const Solid> body = cylinder(diameter / 2);
  // A face with its vertex at z0; the glass lies towards +z for the front face.
  auto applyFace = [&](double radius, double z0, bool glassTowardsPlusZ) {
    if (radius == 0) {
      body = combine(Kind::Intersection, body, glassSide(z0, glassTowardsPlusZ));
      return;
    }
    auto ball = sphere(std::abs(radius), Rigid3::translation({0, 0, z0 + radius}));
    const bool convex = glassTowardsPlusZ ? radius > 0 : radius < 0;
    if (convex) {
      body = combine(Kind::Intersection, body, ball);
      return;
    }
    // Concave: the glass is outside the ball, bounded by the plane of the rim.
    const double sag = std::abs(radius) - std::sqrt(radius * radius - diameter * diameter / 4);
    body = combine(Kind::Difference, body, ball);
    body = combine(Kind::Intersection, body, glassSide(glassTowardsPlusZ ? z0 - sag : z0 + sag, glassTowardsPlusZ));
  };
  applyFace(r1, -tc / 2, true);
  applyFace(r2, tc / 2, false);
  return std::const_pointer_cast<Solid>(body);
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

void Solid::localIntervals(const Ray& ray, IntervalList& out) const {
  const Vec3& o = ray.origin;
  const Vec3& d = ray.direction;
  switch (kind_) {
    case Kind::Sphere: {
      const double b = o.dot(d);
      const double c = o.dot(o) - radius_ * radius_;
      const double disc = b * b - c;
      if (disc < 0) return;
      const double sq = std::sqrt(disc);
      // Stable roots: avoid cancellation in -b +- sq.
      double t0, t1;
      if (b > 0) {
        t0 = -b - sq;
        t1 = c / t0;
      } else {
        t1 = -b + sq;
        t0 = t1 != 0 ? c / t1 : -b - sq;
      }
      if (t0 > t1) std::swap(t0, t1);
      out.push({{t0, (o + d * t0) / radius_}, {t1, (o + d * t1) / radius_}});
      return;
    }
    case Kind::Cylinder: {
      const double a = d.x * d.x + d.y * d.y;
      const double c = o.x * o.x + o.y * o.y - radius_ * radius_;
      if (a < 1e-300) {
        if (c <= 0) out.push({{-kInf, {0, 0, -1}}, {kInf, {0, 0, 1}}});
        return;
      }
      const double b = o.x * d.x + o.y * d.y;
      const double disc = b * b - a * c;
      if (disc < 0) return;
      const double sq = std::sqrt(disc);
      const double q = b > 0 ? -(b + sq) : -(b - sq);
      double t0 = q / a, t1 = q != 0 ? c / q : t0;
      if (t0 > t1) std::swap(t0, t1);
      const Vec3 p0 = o + d * t0, p1 = o + d * t1;
      out.push({{t0, Vec3(p0.x, p0.y, 0) / radius_}, {t1, Vec3(p1.x, p1.y, 0) / radius_}});
      return;
    }
    case Kind::HalfSpace: {
      if (d.z == 0) {
        if (o.z <= 0) out.push({{-kInf, {0, 0, -1}}, {kInf, {0, 0, 1}}});
        return;
      }
      const double t = -o.z / d.z;
      if (d.z > 0)
        out.push({{-kInf, {0, 0, -1}}, {t, {0, 0, 1}}});
      else
        out.push({{t, {0, 0, 1}}, {kInf, {0, 0, -1}}});
      return;
    }
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
      std::array<Event, 2 * IntervalList::kCapacity> ea, eb;
      std::array<Event, 4 * IntervalList::kCapacity> events;
      for (int i = 0; i < la.size(); ++i) {
        ea[2 * i] = {la[i].enter.t, la[i].enter.normal, true, true};
        ea[2 * i + 1] = {la[i].exit.t, la[i].exit.normal, true, false};
      }
      for (int i = 0; i < lb.size(); ++i) {
        eb[2 * i] = {lb[i].enter.t, lb[i].enter.normal, false, true};
        eb[2 * i + 1] = {lb[i].exit.t, lb[i].exit.normal, false, false};
      }
      const int n = 2 * (la.size() + lb.size());
      std::merge(ea.begin(), ea.begin() + 2 * la.size(), eb.begin(), eb.begin() + 2 * lb.size(), events.begin(),
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

Bounds Solid::bounds() const {
  Bounds local;
  switch (kind_) {
    case Kind::Sphere: local = {Vec3(-radius_), Vec3(radius_)}; break;
    case Kind::Cylinder: local = {{-radius_, -radius_, -kInf}, {radius_, radius_, kInf}}; break;
    case Kind::HalfSpace: local = {Vec3(-kInf), {kInf, kInf, 0}}; break;
    case Kind::Union: local = a_->bounds().unite(b_->bounds()); break;
    case Kind::Intersection: local = a_->bounds().intersect(b_->bounds()); break;
    case Kind::Difference: local = a_->bounds(); break;
  }
  return local.transformed(parentFromLocal_);
}

bool Solid::contains(const Vec3& parentPoint) const {
  const Vec3 p = identity_ ? parentPoint : localFromParent_.point(parentPoint);
  switch (kind_) {
    case Kind::Sphere: return p.dot(p) <= radius_ * radius_;
    case Kind::Cylinder: return p.x * p.x + p.y * p.y <= radius_ * radius_;
    case Kind::HalfSpace: return p.z <= 0;
    case Kind::Union: return a_->contains(p) || b_->contains(p);
    case Kind::Intersection: return a_->contains(p) && b_->contains(p);
    case Kind::Difference: return a_->contains(p) && !b_->contains(p);
  }
  return false;
}

}  // namespace lfi::sim
