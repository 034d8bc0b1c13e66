// SPDX-License-Identifier: Apache-2.0
// One path at a time: the public optics helpers (the concentric disc, Fresnel
// reflectance, refraction, reflection) and the one-ray walk behind
// traceRadiance() and refractionPath().

#include "lfi/sim/render.h"

#include "camera_samples.h"
#include "fresnel_step.h"
#include "path_physics.h"

#include <algorithm>
#include <vector>

namespace lfi::sim {

Vec2 concentricDisc(double u1, double u2) {
  Vec2 p;
  detail::concentricDisc(u1, u2, p.x, p.y);
  return p;
}

double fresnelReflectance(double cosI, double n1, double n2) {
  cosI = std::clamp(cosI, 0.0, 1.0);
  const double cosT = detail::transmittedCosine(cosI, n1 / n2);
  return cosT < 0 ? 1.0 : detail::fresnelFromCosines(cosI, cosT, n1, n2);
}

bool refract(const Vec3& d, const Vec3& n, double eta, Vec3& out) {
  const double cosI = std::clamp(-d.dot(n), 0.0, 1.0);
  const double cosT = detail::transmittedCosine(cosI, eta);
  if (cosT < 0) return false;
  out = detail::renormalised(d * eta + n * (eta * cosI - cosT));
  return true;
}

Vec3 reflect(const Vec3& d, const Vec3& n) {
  return detail::renormalised(d - n * (2 * d.dot(n)));
}

namespace {

using detail::interact;
using detail::PathState;
using detail::SampledPolicy;
using detail::Step;

// One path and its split branches, one ray at a time. Returns the radiance carried back.
template <typename Policy>
double walk(const Scene& scene, PathState p, Policy& policy) {
  double sum = 0;
  PathState branch = p;  // written by a split
  while (p.depth < policy.maxDepth) {
    const Hit hit = scene.intersect(p.ray);
    policy.visit(hit, p.ray);
    double radiance;
    const Step step = interact(scene, hit, p, branch, radiance, policy);
    if (step == Step::Done) return sum + radiance;
    if (step == Step::Split) sum += walk(scene, branch, policy);
  }
  return sum;
}

struct RefractionPathPolicy {
  std::vector<Vec3>& vertices;
  int maxDepth;
  double escape;
  int splitDepth = 0;
  bool diffuse = false;
  void visit(const Hit& hit, const Ray& ray) { vertices.push_back(hit.valid() ? hit.point : ray.at(escape)); }
  bool chooseReflection(double) { return false; }
  Vec3 bounce(const Vec3& n) { return n; }
};

}  // namespace

double traceRadiance(const Scene& scene, const Ray& ray, Sampler& sampler, int maxDepth, int splitDepth) {
  SampledPolicy policy{sampler, maxDepth, splitDepth};
  return walk(scene, PathState{.ray = ray}, policy);
}

std::vector<Vec3> refractionPath(const Scene& scene, const Ray& ray, int maxDepth, double escape) {
  std::vector<Vec3> vertices{ray.origin};
  RefractionPathPolicy policy{vertices, maxDepth, escape};
  walk(scene, PathState{.ray = ray}, policy);
  return vertices;
}

}  // namespace lfi::sim
