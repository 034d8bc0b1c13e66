// SPDX-License-Identifier: Apache-2.0
// Building solids: the primitives, their boolean combinations (flattened into
// convex parts where they allow it), their bounds and point membership.

#include "lfi/sim/solid.h"

#include "lfi/core/error.h"

#include "solid_internal.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

namespace lfi::sim {

namespace {

using detail::isPrimitive;
using detail::kInf;

}  // namespace

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

Bounds::Ball Bounds::ball(const Vec3& centre, double radius) const {
  double near2 = 0, far2 = 0;  // squared distances from the centre to the box's nearest and farthest points
  for (int axis = 0; axis < 3; ++axis) {
    const double low = lo[axis] - centre[axis], high = hi[axis] - centre[axis];
    const double gap = low > 0 ? low : high < 0 ? -high : 0;
    near2 += gap * gap;
    far2 += std::max(low * low, high * high);
  }
  if (near2 >= radius * radius) return Ball::Clear;
  return far2 <= radius * radius ? Ball::HoldsAll : Ball::Overlaps;
}

std::string Bounds::text() const {
  return fmt::format("[{:g}, {:g}, {:g}] to [{:g}, {:g}, {:g}] mm", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
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
    : kind_(kind),
      radius_(radius),
      parentFromLocal_(parentFromLocal),
      localFromParent_(parentFromLocal.inverse()),
      identity_(parentFromLocal.isIdentity()) {}

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
  // Both operands convex: flatten their primitives into this node's frame.
  auto convexParts = [](const Solid& x, std::vector<ConvexPart>& parts) {
    if (isPrimitive(x.kind_)) {
      parts.push_back(ConvexPart::make(x.kind_, x.radius_, x.parentFromLocal_));
      return true;
    }
    if (x.convex_.empty()) return false;
    for (const ConvexPart& p : x.convex_)
      parts.push_back(ConvexPart::make(p.kind, p.radius, x.parentFromLocal_ * p.localFromPart));
    return true;
  };
  std::vector<ConvexPart> parts;
  if (op == Kind::Intersection && convexParts(*a, parts) && convexParts(*b, parts) && parts.size() <= kMaxConvexParts)
    s->convex_ = std::move(parts);
  s->convexDifference_ = op == Kind::Difference && a->convex() && b->convex();
  s->a_ = std::move(a);
  s->b_ = std::move(b);
  return s;
}

Solid::ConvexPart Solid::ConvexPart::make(Kind kind, double radius, const Rigid3& localFromPart) {
  const double invRadius = kind == Kind::HalfSpace ? 0.0 : 1 / radius;
  return {kind,
          radius,
          localFromPart,
          localFromPart.inverse(),
          localFromPart.isIdentity(),
          localFromPart.t,
          localFromPart.vector({0, 0, 1}),
          invRadius};
}

bool Solid::convex() const {
  return isPrimitive(kind_) || !convex_.empty();
}

Bounds Solid::bounds() const {
  Bounds local;
  switch (kind_) {
    case Kind::Sphere:
      local = {Vec3(-radius_), Vec3(radius_)};
      break;
    case Kind::Cylinder:
      local = {{-radius_, -radius_, -kInf}, {radius_, radius_, kInf}};
      break;
    case Kind::HalfSpace:
      local = {Vec3(-kInf), {kInf, kInf, 0}};
      break;
    case Kind::Union:
      local = a_->bounds().unite(b_->bounds());
      break;
    case Kind::Intersection:
      local = a_->bounds().intersect(b_->bounds());
      break;
    case Kind::Difference:
      local = a_->bounds();
      break;
  }
  return local.transformed(parentFromLocal_);
}

bool Solid::contains(const Vec3& parentPoint) const {
  const Vec3 p = identity_ ? parentPoint : localFromParent_.point(parentPoint);
  switch (kind_) {
    case Kind::Sphere:
      return p.dot(p) <= radius_ * radius_;
    case Kind::Cylinder:
      return p.x * p.x + p.y * p.y <= radius_ * radius_;
    case Kind::HalfSpace:
      return p.z <= 0;
    case Kind::Union:
      return a_->contains(p) || b_->contains(p);
    case Kind::Intersection:
      return a_->contains(p) && b_->contains(p);
    case Kind::Difference:
      return a_->contains(p) && !b_->contains(p);
  }
  return false;
}

}  // namespace lfi::sim
