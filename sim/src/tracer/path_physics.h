// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim: one path's interactions (emitters' radiance, the media it
// is inside, Beer-Lambert absorption, the Fresnel choice, diffuse bounces), inline
// for the one-ray walk (path_walk.cpp) and the packet renderer (tile_renderer.cpp).

#include "lfi/sim/render.h"

#include "lfi/core/error.h"

#include "camera_samples.h"
#include "fresnel_step.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <variant>

namespace lfi::sim::detail {

// A cosine-weighted direction about unit n, for a diffuse bounce. Always
// inlined (into interact(), through SampledPolicy::bounce): GCC inlines a
// function for having a single caller only when it is local to its file.
[[gnu::always_inline]] inline Vec3 cosineHemisphere(const Vec3& n, double u1, double u2) {
  const Vec2 d = sim::concentricDisc(u1, u2);  // the public map (detail's takes four arguments)
  const double z = std::sqrt(std::max(0.0, 1 - d.x * d.x - d.y * d.y));
  const Vec3 t = std::abs(n.x) > 0.5 ? Vec3(0, 1, 0).cross(n).normalized() : Vec3(1, 0, 0).cross(n).normalized();
  const Vec3 bt = n.cross(t);
  return (t * d.x + bt * d.y + n * z).normalized();
}

// A parallel or Lambertian emitter's radiance at cos θ from its normal.
inline double uniformRadiance(const Surface& surface, double cosTheta) {
  return cosTheta >= surface.cosHalfAngle ? surface.radiance : 0.0;
}

// Any emitter's radiance towards the sensor from the hit. Not inlined: the
// packet loop (TileRenderer::step) calls it only for panels and a light field's
// odd lanes, and its code stays compact for the glass and uniform emitters.
[[gnu::noinline]] inline double emittedRadiance(const Scene& scene, const Hit& hit, const Emission& emission,
                                                const Vec3& towardsSensor) {
  const Surface& surface = scene.surface(hit.object);
  if (surface.uniformEmission) return uniformRadiance(surface, towardsSensor.dot(hit.normal));
  const Rigid3& local = scene.objectFromWorld(hit.object);
  const Vec3 q = local.point(hit.point);
  if (const auto* e = std::get_if<LightFieldEmission>(&emission))
    return e->lightField ? e->lightField->radiance({q.x, q.y}, local.vector(towardsSensor), e->lookup) : 0.0;
  return std::get<PanelEmission>(emission).radiance({q.x, q.y}, local.vector(towardsSensor));
}

// The dielectric objects a path is inside, innermost last.
class MediumStack {
 public:
  static constexpr int kDepth = 8;
  int size() const { return size_; }
  int top() const { return items_[size_ - 1]; }
  void clear() { size_ = 0; }
  // Throws Errc::Config, naming the objects, when the path would be inside
  // more than kDepth dielectrics at once (rather than lose one of them).
  void push(const Scene& scene, int object) {
    if (size_ == kDepth) tooDeep(scene, object);
    items_[size_++] = object;
  }
  void remove(int object) {
    for (int i = size_ - 1; i >= 0; --i)
      if (items_[i] == object) {
        for (int k = i; k + 1 < size_; ++k) items_[k] = items_[k + 1];
        --size_;
        return;
      }
  }
  // Index of refraction of the innermost medium, ignoring `skip`.
  double ior(const Scene& scene, int skip = -1) const {
    for (int i = size_ - 1; i >= 0; --i)
      if (items_[i] != skip) return scene.surface(items_[i]).ior;
    return scene.ambientIor();
  }
  double absorption(const Scene& scene) const { return size_ ? scene.surface(top()).absorption_per_mm : 0.0; }
  // The index on the inner side of `object`'s surface, for a path leaving it:
  // the innermost medium when the path is inside `object` (its own, or that of
  // a dielectric entered after it that overlaps it there), else the object's.
  double iorInside(const Scene& scene, int object) const {
    for (int i = 0; i < size_; ++i)
      if (items_[i] == object) return scene.surface(top()).ior;
    return scene.surface(object).ior;
  }

 private:
  [[noreturn, gnu::cold, gnu::noinline]] void tooDeep(const Scene& scene, int object) const {
    std::string inside;
    for (int i = 0; i < size_; ++i) inside += fmt::format("{}'{}'", i ? ", " : "", scene.object(items_[i]).name);
    fail(Errc::Config,
         "a path entering dielectric '{}' is already inside {} nested dielectrics ({}); the tracer "
         "follows at most {}: nest fewer, or make the overlapping objects one solid",
         scene.object(object).name, size_, inside, kDepth);
  }
  std::array<int, kDepth> items_{};
  int size_ = 0;
};

struct PathState {
  Ray ray;
  MediumStack media;
  double throughput = 1;
  int depth = 0;
  int on = -1;  // the dielectric whose surface the ray leaves from (-1: none)
};

// How far a path leaving a triangle mesh's surface at p starts off it, so
// that its next query cannot meet the same face again: 1e-4 mm, or, far from
// the origin, 4 float epsilons of p's largest coordinate (4 to 8 units in the
// last place of that coordinate in float).
// Embree takes the new ray's origin in float (rounded by up to half a unit
// there) and meets the face with an error of a few units: a fixed 1e-4 mm would
// be under one unit past 1024 mm, and paths would turn back into a part they had left.
inline double meshOffset(const Vec3& p) {
  const double largest = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  return std::max(1e-4, 4 * std::numeric_limits<float>::epsilon() * largest);
}

// What one interaction did to a path.
enum class Step {
  Done,      // ended (an emitter, an absorber, left the scene): `radiance` is its contribution
  Continue,  // goes on along p.ray
  Split,     // goes on along p.ray (refracted) and along `branch` (reflected), both weighted
};

// One interaction of path p with what it hit. The policy decides each Fresnel
// event (split into both branches, or choose one) and bounces off diffuse
// surfaces. Shared by the one-ray walk and the packet renderer.
template <typename Policy>
Step interact(const Scene& scene, const Hit& hit, PathState& p, PathState& branch, double& radiance, Policy& policy) {
  radiance = 0;
  if (!hit.valid()) return Step::Done;
  if (p.media.size())
    if (const double a = p.media.absorption(scene); a > 0) p.throughput *= std::exp(-a * hit.t);
  const Surface& surface = scene.surface(hit.object);
  if (surface.kind == Surface::Kind::Emitter) {
    radiance = p.throughput * emittedRadiance(scene, hit, *scene.object(hit.object).emission, -p.ray.direction);
    return Step::Done;
  }
  const Vec3 d = p.ray.direction;
  const bool entering = d.dot(hit.normal) < 0;
  const Vec3 facing = entering ? hit.normal : -hit.normal;  // towards the incoming side
  // Meshes are intersected in float: step off the surface to avoid re-hits.
  auto leave = [&](const Vec3& dir) {
    const double offset = surface.exact ? 0.0 : meshOffset(hit.point) * (dir.dot(facing) > 0 ? 1 : -1);
    return Ray{hit.point + facing * offset, dir};
  };
  const int depth = p.depth++;

  if (surface.kind == Surface::Kind::Absorber) return Step::Done;
  if (surface.kind == Surface::Kind::Diffuse) {
    if (!policy.diffuse) return Step::Done;
    p.throughput *= surface.albedo;
    p.ray = leave(policy.bounce(facing));
    p.on = -1;
    return Step::Continue;
  }
  p.on = hit.object;
  // Entering: from the current medium into the glass. Leaving: from the
  // glass into whatever medium contains it (a bubble in glass exits to glass).
  // The packet renderer takes the same steps for its exact dielectrics.
  const double n1 = entering ? p.media.ior(scene) : p.media.iorInside(scene, hit.object);
  const double n2 = entering ? surface.ior : p.media.ior(scene, hit.object);
  const detail::FresnelEvent e = detail::fresnelEvent(d, hit.normal, n1, n2);
  const Vec3 reflected(e.rx, e.ry, e.rz);
  if (e.cosT < 0) {  // total internal reflection
    p.ray = leave(reflected);
    return Step::Continue;
  }
  const bool split = depth < policy.splitDepth;
  if (split) {
    // Splitting: both branches, weighted, instead of a random choice.
    branch = p;
    branch.ray = leave(reflected);
    branch.throughput *= e.reflectance;
    p.throughput *= 1 - e.reflectance;
  } else if (policy.chooseReflection(e.reflectance)) {
    p.ray = leave(reflected);
    return Step::Continue;
  }
  p.ray = leave({e.tx, e.ty, e.tz});
  if (entering)
    p.media.push(scene, hit.object);
  else
    p.media.remove(hit.object);
  return split ? Step::Split : Step::Continue;
}

// A sample's first detail::kStratifiedChoices Fresnel choices, from a Latin
// hypercube over its pixel's samples (camera_samples.h). The packet renderer
// makes the first kBatchedChoices for many lanes at once when their paths
// first need one (`batched`); otherwise each is made when it is needed. Both
// give the same values. The pixel's keys (one per choice) and its number of
// samples are the pixel's, passed in.
using ChoiceKeys = std::array<std::uint32_t, detail::kStratifiedChoices>;
struct StratifiedChoices {
  std::array<double, detail::kBatchedChoices> u;  // when batched
  std::uint32_t sample = 0;
  int used = detail::kStratifiedChoices;  // none left
  bool batched = false;
  bool next(double& value, const ChoiceKeys& key, std::uint32_t spp) {
    if (used == detail::kStratifiedChoices) return false;
    const auto d = static_cast<size_t>(used++);
    value = batched && d < detail::kBatchedChoices ? u[d] : detail::stratifiedChoice(spp, sample, key[d]);
    return true;
  }
};

struct SampledPolicy {
  Sampler& sampler;
  int maxDepth;
  int splitDepth;
  StratifiedChoices* choices = nullptr;  // then random choices
  const ChoiceKeys* keys = nullptr;      // with choices: the pixel's
  std::uint32_t spp = 0;                 // with choices: the pixel's samples
  bool diffuse = true;
  void visit(const Hit&, const Ray&) {}
  bool chooseReflection(double reflectance) {
    double u;
    if (!choices || !choices->next(u, *keys, spp)) u = sampler.next();
    return u < reflectance;
  }
  Vec3 bounce(const Vec3& n) {
    const double u1 = sampler.next(), u2 = sampler.next();
    return cosineHemisphere(n, u1, u2);
  }
};

}  // namespace lfi::sim::detail
