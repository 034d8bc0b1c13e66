#include "lfi/sim/render.h"

#include "lfi/core/error.h"

#include "camera_samples.h"
#include "fresnel_step.h"
#include "light_field_lanes.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <mutex>
#include <string>

namespace lfi::sim {

Vec2 concentricDisc(double u1, double u2) {
  Vec2 p;
  detail::concentricDisc(u1, u2, p.x, p.y);
  return p;
}

namespace {

Vec3 cosineHemisphere(const Vec3& n, double u1, double u2) {
  const Vec2 d = concentricDisc(u1, u2);
  const double z = std::sqrt(std::max(0.0, 1 - d.x * d.x - d.y * d.y));
  const Vec3 t = std::abs(n.x) > 0.5 ? Vec3(0, 1, 0).cross(n).normalized() : Vec3(1, 0, 0).cross(n).normalized();
  const Vec3 bt = n.cross(t);
  return (t * d.x + bt * d.y + n * z).normalized();
}

// A parallel or Lambertian emitter's radiance at cos θ from its normal.
double uniformRadiance(const Surface& surface, double cosTheta) {
  return cosTheta >= surface.cosHalfAngle ? surface.radiance : 0.0;
}

double emittedRadiance(const Scene& scene, const Hit& hit, const Emission& emission, const Vec3& towardsSensor) {
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
    fail(Errc::Config, "a path entering dielectric '{}' is already inside {} nested dielectrics ({}); the tracer "
         "follows at most {}: nest fewer, or make the overlapping objects one solid",
         scene.object(object).name, size_, inside, kDepth);
  }
  std::array<int, kDepth> items_{};
  int size_ = 0;
};

}  // namespace

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

Vec3 reflect(const Vec3& d, const Vec3& n) { return detail::renormalised(d - n * (2 * d.dot(n))); }

namespace {

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
// there) and meets the face with an error of a few units: a fixed 1e-4 mm is
// under one unit past 1024 mm, and paths turned back into a part they had left.
double meshOffset(const Vec3& p) {
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

namespace {

// A pixel whose samples are being traced: its sample plan and their results.
struct PixelWork {
  int i = 0, j = 0;
  int issued = 0;    // samples started
  int inFlight = 0;  // samples started and not yet ended
  std::vector<double> values;  // each sample's radiance, summed in sample order at the end
  std::uint64_t streams = 0;   // sample s's random stream is streams ^ s
  std::uint32_t stopKey = 0;   // permutes the stop strata against the pixel-area strata
  ChoiceKeys choiceKeys{};
};

// Where a path goes on: its state, random stream and stratified choices (a
// split branch waiting for its lane).
struct Walker {
  PathState path;
  Sampler sampler{0, 0};
  StratifiedChoices choices;
};

constexpr int kLanes = static_cast<int>(Scene::kPacket);
using LaneMask = std::uint32_t;  // bit k: lane k
constexpr int kFewChoices = 2;   // as many lanes' first choices are made one by one rather than in a batch

// The packet's paths as structures of arrays, lane k in slot k of each. A
// lane traces one sample; its split branches wait on its own stack and are
// traced depth first in the same lane, so each sample's radiance is summed in
// the same order however samples share packets: the image is bit-identical
// for any tile size and thread count.
struct Lanes {
  Scene::RayPacket ray;  // each path's ray; inside = its media stack's top, on = PathState::on
  alignas(64) double throughput[kLanes];
  double radiance[kLanes];        // the sample's sum so far
  std::uint64_t sampler[kLanes];  // Sampler::state
  int depth[kLanes];
  int pixel[kLanes];   // index into the tile's PixelWork slots
  int sample[kLanes];  // index in the pixel
  int waiting[kLanes];  // branches waiting on the lane's stack (TileRenderer::branches_)
  std::array<StratifiedChoices, kLanes> choices;
  std::array<MediumStack, kLanes> media;
};

// Renders one tile: the pixels' samples are traced in a packet of kLanes
// paths through Embree, refilled as samples end, so that the packet stays
// full and coherent (neighbouring samples of one or two pixels).
class TileRenderer {
public:
  TileRenderer(const Scene& scene, const Sensor& sensor, const RenderOptions& options)
      : scene_(scene), sensor_(sensor), options_(options), width_(sensorWidth(sensor)),
        cameraRays_(std::holds_alternative<TelecentricCamera>(sensor)
                        ? std::optional(TelecentricCamera::RayMap(std::get<TelecentricCamera>(sensor)))
                        : std::nullopt),
        side_(static_cast<int>(std::sqrt(static_cast<double>(options.samplesPerPixel)))),
        invSpp_(1.0 / options.samplesPerPixel) {
    // Lanes without a path still take part in the lane-parallel arithmetic:
    // give them a harmless ray and interface.
    for (int k = 0; k < kLanes; ++k) {
      lanes_.ray.rays.set(k, Ray{{0, 0, 0}, {0, 0, 1}});
      lanes_.ray.inside[k] = lanes_.ray.on[k] = -1;
      fresnel_.n1[k] = fresnel_.n2[k] = 1;
    }
    branches_.resize(Scene::kPacket);
    isolated_.assign(scene.objects().size() + 1, 0);
    for (size_t i = 0; i < scene.objects().size(); ++i) {
      isolated_[i + 1] = scene.isolated(static_cast<int>(i));
      absorbing_ = absorbing_ || scene.surface(static_cast<int>(i)).absorption_per_mm > 0;
    }
  }

  void render(int x0, int y0, int x1, int y1, cv::Mat& image) {
    nextI_ = x0, nextJ_ = y0, x0_ = x0, x1_ = x1, y1_ = y1;
    image_ = &image;
    issuing_ = -1;
    prepared_ = nextPrepared_ = 0;
    LaneMask active = 0, free = (1u << kLanes) - 1;
    for (;;) {
      if (free) active |= startSamples(free);  // new samples in the free lanes
      if (active == 0) break;
      active = step(active, free);
      // Paths that went into an isolated solid (a lens) meet only its surface
      // next: the solid answers them without a traversal, so step them at once
      // and keep the Embree packets for the rays that need one.
      for (LaneMask inner; (inner = active & insideIsolated_) != 0;) active = (active & ~inner) | step(inner, free);
    }
  }

private:
  // Sets lane k's innermost medium from its media stack: the packet query's
  // hint, and whether the lane is inside an isolated solid.
  void setInside(int k) {
    const MediumStack& media = lanes_.media[k];
    const int inside = media.size() ? media.top() : -1;
    lanes_.ray.inside[k] = inside;
    const LaneMask bit = 1u << k;
    insideIsolated_ = isolated_[static_cast<size_t>(inside + 1)] ? insideIsolated_ | bit : insideIsolated_ & ~bit;
  }

  // Beer-Lambert transmittance of lane k's medium up to its hit (1 when it
  // does not absorb), as interact() applies it.
  double transmittance(int k) const {
    if (!absorbing_) return 1.0;
    const MediumStack& media = lanes_.media[k];
    const double a = media.size() ? media.absorption(scene_) : 0.0;
    return a > 0 ? std::exp(-a * hits_.t[k]) : 1.0;
  }

  // Traces one step of the paths in `lanes`: their next hits, in one packet
  // query, and what they do there. Returns the lanes that go on; the lanes
  // whose samples end are written and set in `free`.
  LaneMask step(LaneMask lanes, LaneMask& free) {
    scene_.intersect(lanes_.ray, lanes, hits_);
    LaneMask kept = 0, fresnel = 0, enteringLanes = 0, lightFields = 0;
    for (LaneMask bits = lanes; bits; bits &= bits - 1) {
      const int k = std::countr_zero(bits);
      const LaneMask bit = 1u << k;
      const int object = hits_.object[k];
      if (object < 0) {  // left the scene
        if (endPath(k, 0, free)) kept |= bit;
        continue;
      }
      const Surface& surface = scene_.surface(object);
      if (surface.kind == Surface::Kind::Dielectric && surface.exact) {
        // Taken below, all lanes at once: as interact() does.
        lanes_.throughput[k] *= transmittance(k);
        const MediumStack& media = lanes_.media[k];
        const bool entering = direction(k).dot(hits_.normal(k)) < 0;
        fresnel_.n1[k] = entering ? media.ior(scene_) : media.iorInside(scene_, object);
        fresnel_.n2[k] = entering ? surface.ior : media.ior(scene_, object);
        if (entering) enteringLanes |= bit;
        fresnel |= bit;
        continue;
      }
      if (surface.kind == Surface::Kind::Emitter) {  // the end of most paths: as interact()
        const double throughput = lanes_.throughput[k] * transmittance(k);
        double radiance;
        if (surface.uniformEmission) {  // no need of the hit point
          radiance = uniformRadiance(surface, (-direction(k)).dot(hits_.normal(k)));
        } else if (std::holds_alternative<LightFieldEmission>(*scene_.object(object).emission)) {
          lanes_.throughput[k] = throughput;  // taken below, all lanes at once
          lightFields |= bit;
          continue;
        } else {
          const Ray ray = lanes_.ray.rays.ray(k);
          const Hit hit{object, hits_.t[k], ray.at(hits_.t[k]), hits_.normal(k)};
          radiance = emittedRadiance(scene_, hit, *scene_.object(object).emission, -ray.direction);
        }
        if (endPath(k, throughput * radiance, free)) kept |= bit;
        continue;
      }
      // Anything else (absorbers, diffuse surfaces, meshes), one lane at a time.
      Walker w = walker(k);
      SampledPolicy policy{w.sampler, options_.maxDepth, options_.splitDepth, &w.choices, &keys(k), spp()};
      const Ray ray = lanes_.ray.rays.ray(k);
      const Hit hit{object, hits_.t[k], ray.at(hits_.t[k]), hits_.normal(k)};
      double radiance;
      PathState branch;
      const Step s = interact(scene_, hit, w.path, branch, radiance, policy);
      if (s == Step::Split) wait(k, branch, w.sampler, w.choices);
      if (s != Step::Done && w.path.depth < options_.maxDepth) {
        load(k, w);
        kept |= bit;
      } else if (endPath(k, radiance, free)) {
        kept |= bit;
      }
    }
    if (fresnel) kept |= takeFresnelEvents(fresnel, enteringLanes, free);
    if (lightFields) kept |= endOnLightFields(lightFields, free);
    return kept;
  }

  // Ends the paths of `lanes`, which met light field emitters (their
  // throughputs set), as emittedRadiance() does. Returns the lanes that go on.
  LaneMask endOnLightFields(LaneMask lanes, LaneMask& free) {
    LaneMask kept = 0;
    while (lanes) {  // one emitter object at a time
      const int object = hits_.object[std::countr_zero(lanes)];
      LaneMask these = 0;
      for (LaneMask bits = lanes; bits; bits &= bits - 1) {
        const int k = std::countr_zero(bits);
        if (hits_.object[k] == object) these |= 1u << k;
      }
      lanes &= ~these;
      const Emission& emission = *scene_.object(object).emission;
      const LightField* lightField = std::get<LightFieldEmission>(emission).lightField.get();
      const LightFieldLookup lookup = std::get<LightFieldEmission>(emission).lookup;
      if (lightField)
        detail::mapToLightField(lanes_.ray.rays, hits_.t, scene_.objectFromWorld(object), lightField->geometry(),
                                lightFieldMapping_);
      const detail::LightFieldMapping& m = lightFieldMapping_;
      for (; these; these &= these - 1) {
        const int k = std::countr_zero(these);
        double radiance = 0;
        if (lightField && m.oneByOne[k]) {
          const Ray ray = lanes_.ray.rays.ray(k);
          radiance = emittedRadiance(scene_, {object, hits_.t[k], ray.at(hits_.t[k]), hits_.normal(k)}, emission,
                                     -ray.direction);
        } else if (lightField && m.seen[k]) {
          radiance = lightField->radianceAt(m.sx[k], m.sy[k], {m.discX[k], m.discY[k]}, lookup);
        }
        if (endPath(k, lanes_.throughput[k] * radiance, free)) kept |= 1u << k;
      }
    }
    return kept;
  }

  // The Fresnel events of the lanes in `lanes` (fresnel_.n1, n2 set; those in
  // `enteringLanes` enter their dielectric), as interact() takes them: total
  // internal reflection, a split into both branches, or a choice of one.
  // Returns the lanes that go on.
  LaneMask takeFresnelEvents(LaneMask lanes, LaneMask enteringLanes, LaneMask& free) {
    if (const LaneMask rest = lanes & (lanes - 1); (rest & (rest - 1)) != 0)  // more than two lanes
      detail::fresnelLanes(lanes_.ray.rays, hits_, fresnel_);
    else  // a path reflected inside a lens, or two: cheaper one by one
      for (LaneMask bits = lanes; bits; bits &= bits - 1)
        detail::fresnelLane(lanes_.ray.rays, hits_, fresnel_, std::countr_zero(bits));
    const detail::FresnelLanes& f = fresnel_;
    batchChoices(lanes);
    LaneMask kept = 0;
    for (; lanes; lanes &= lanes - 1) {
      const int k = std::countr_zero(lanes);
      const int object = hits_.object[k], depth = lanes_.depth[k]++;
      const bool entering = (enteringLanes >> k & 1) != 0;
      lanes_.ray.on[k] = object;
      const Vec3 point(f.px[k], f.py[k], f.pz[k]), reflected(f.rx[k], f.ry[k], f.rz[k]);
      bool refract = f.cosT[k] >= 0;  // else total internal reflection
      if (refract && depth < options_.splitDepth) {
        // Splitting: both branches, weighted, instead of a random choice.
        Walker branch = walker(k);
        branch.path.ray = {point, reflected};
        branch.path.throughput *= f.reflectance[k];
        wait(k, branch.path, branch.sampler, branch.choices);
        lanes_.throughput[k] *= 1 - f.reflectance[k];
      } else if (refract) {
        double u;
        if (!lanes_.choices[k].next(u, keys(k), spp())) {
          Sampler sampler(0, 0);
          sampler.state = lanes_.sampler[k];
          u = sampler.next();
          lanes_.sampler[k] = sampler.state;
        }
        refract = !(u < f.reflectance[k]);
      }
      if (refract) {
        lanes_.ray.rays.set(k, {point, {f.tx[k], f.ty[k], f.tz[k]}});
        MediumStack& media = lanes_.media[k];
        if (entering)
          media.push(scene_, object);
        else
          media.remove(object);
        setInside(k);
      } else {
        lanes_.ray.rays.set(k, {point, reflected});
      }
      if (lanes_.depth[k] < options_.maxDepth || endPath(k, 0, free)) kept |= 1u << k;
    }
    return kept;
  }

  // Makes the batched stratified choices, in one vectorised pass, for the
  // lanes among `lanes` (at a Fresnel event, fresnel_ set) that are about to
  // make their first choice. Paths that never choose (they miss the lens, or
  // split instead) cost nothing; a few lanes choose one by one instead.
  void batchChoices(LaneMask lanes) {
    int n = 0;
    LaneMask batch = 0;
    for (; lanes; lanes &= lanes - 1) {
      const int k = std::countr_zero(lanes);
      const StratifiedChoices& c = lanes_.choices[static_cast<size_t>(k)];
      // (A batched lane has made its first choice in the same event: used > 0.)
      if (c.used != 0 || fresnel_.cosT[k] < 0 || lanes_.depth[k] < options_.splitDepth) continue;
      choices_.sample[n] = c.sample;
      for (size_t d = 0; d < detail::kBatchedChoices; ++d) choices_.key[d][n] = keys(k)[d];
      batch |= 1u << k;
      ++n;
    }
    if (n <= kFewChoices) return;
    detail::makeStratifiedChoices(spp(), n, choices_);
    for (int i = 0; batch; batch &= batch - 1, ++i) {
      StratifiedChoices& c = lanes_.choices[static_cast<size_t>(std::countr_zero(batch))];
      for (size_t d = 0; d < detail::kBatchedChoices; ++d) c.u[d] = choices_.u[d][i];
      c.batched = true;
    }
  }

  // Ends lane k's current path, which brought `radiance`, and goes on with the
  // sample's latest waiting branch, if any (true). Otherwise the sample is
  // written and the lane set free (false).
  bool endPath(int k, double radiance, LaneMask& free) {
    lanes_.radiance[k] += radiance;
    auto& stack = branches_[static_cast<size_t>(k)];
    while (lanes_.waiting[k] > 0) {
      const Walker& w = stack[static_cast<size_t>(--lanes_.waiting[k])];
      if (w.path.depth < options_.maxDepth) {
        load(k, w);
        return true;
      }
    }
    PixelWork& px = pixels_[static_cast<size_t>(lanes_.pixel[k])];
    px.values[static_cast<size_t>(lanes_.sample[k])] = lanes_.radiance[k];
    --px.inFlight;
    free |= 1u << k;
    if (lanes_.pixel[k] != issuing_) finishIfDone(lanes_.pixel[k]);
    return false;
  }

  // Puts a split branch on lane k's stack; it gets its own stream, keyed by
  // the parent's state and the branch's depth.
  void wait(int k, const PathState& branch, const Sampler& parent, const StratifiedChoices& choices) {
    branches_[static_cast<size_t>(k)][static_cast<size_t>(lanes_.waiting[k]++)] = {
        branch, Sampler(parent.state, static_cast<std::uint64_t>(branch.depth)), choices};
  }

  // The stratified choices' keys of lane k's pixel, and the samples per pixel.
  const ChoiceKeys& keys(int k) const { return pixels_[static_cast<size_t>(lanes_.pixel[k])].choiceKeys; }
  std::uint32_t spp() const { return static_cast<std::uint32_t>(options_.samplesPerPixel); }

  Vec3 direction(int k) const { return {lanes_.ray.rays.dx[k], lanes_.ray.rays.dy[k], lanes_.ray.rays.dz[k]}; }

  // Lane k's path as one walker, and back.
  Walker walker(int k) const {
    Walker w;
    w.path = {lanes_.ray.rays.ray(k), lanes_.media[k], lanes_.throughput[k], lanes_.depth[k], lanes_.ray.on[k]};
    w.sampler.state = lanes_.sampler[k];
    w.choices = lanes_.choices[k];
    return w;
  }
  void load(int k, const Walker& w) {
    lanes_.ray.rays.set(k, w.path.ray);
    lanes_.ray.on[k] = w.path.on;
    lanes_.media[k] = w.path.media;
    setInside(k);
    lanes_.throughput[k] = w.path.throughput;
    lanes_.depth[k] = w.path.depth;
    lanes_.sampler[k] = w.sampler.state;
    lanes_.choices[k] = w.choices;
  }

  // A sample about to start: its pixel's slot and its index in the pixel.
  struct Start {
    int slot = 0, sample = 0;
  };

  // Plans up to `room` new samples in starts_ (the tile's pixels in order,
  // each pixel's samples in order); returns how many.
  size_t planSamples(size_t room) {
    size_t m = 0;
    while (m < room) {
      if (issuing_ < 0 || pixels_[static_cast<size_t>(issuing_)].issued == options_.samplesPerPixel) {
        if (issuing_ >= 0) finishIfDone(issuing_);
        issuing_ = startPixel();
        if (issuing_ < 0) break;
      }
      PixelWork& px = pixels_[static_cast<size_t>(issuing_)];
      starts_[m].slot = issuing_;
      starts_[m++].sample = px.issued++;
      ++px.inFlight;
    }
    return m;
  }

  // Claims a slot for the tile's next pixel; -1 when the tile is done.
  int startPixel() {
    if (nextJ_ >= y1_) return -1;
    int slot;
    if (!freeSlots_.empty()) {
      slot = freeSlots_.back();
      freeSlots_.pop_back();
    } else {
      slot = static_cast<int>(pixels_.size());
      pixels_.emplace_back();
    }
    PixelWork& px = pixels_[static_cast<size_t>(slot)];
    px.i = nextI_, px.j = nextJ_, px.issued = 0, px.inFlight = 0;
    px.values.resize(static_cast<size_t>(options_.samplesPerPixel));
    if (++nextI_ == x1_) nextI_ = x0_, ++nextJ_;
    px.streams = (pixelIndex(px) << 24) ^ 0x5bd1e995ull;
    Sampler keys(options_.seed, pixelIndex(px));
    px.stopKey = keys.nextU32();
    for (auto& key : px.choiceKeys) key = keys.nextU32();
    return slot;
  }

  // Plans the next samples (a batch of CameraSampleBatch::kSize, more than a
  // packet holds, so that the pass runs on whole vectors) and makes their rays
  // in one vectorised pass, ready for startSamples(). Returns false when the tile
  // has no samples left to start. Each sample gets its random stream, its
  // stratified choices and its ray of sight. One random stream per sample:
  // two scenes that differ only where a path can reach (a defect) give
  // identical samples everywhere else. Jittered strata for the pixel area
  // and, independently permuted, for the stop: the first side^2 samples cover
  // both evenly; the rest are random.
  bool prepareSamples() {
    const size_t m = planSamples(static_cast<size_t>(detail::CameraSampleBatch::kSize));
    if (m == 0) return false;
    for (size_t k = 0; k < m; ++k) {
      const PixelWork& px = pixels_[static_cast<size_t>(starts_[k].slot)];
      const auto s = static_cast<std::uint32_t>(starts_[k].sample);
      batch_.stream[k] = px.streams ^ s;
      batch_.pixelX[k] = px.i, batch_.pixelY[k] = px.j;
      batch_.sample[k] = s;
      batch_.stopKey[k] = px.stopKey;
    }
    // Every sample has a ray but a light field sensor's outside its disc.
    hasRay_ = m == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << m) - 1;
    if (cameraRays_)
      detail::makeCameraSamples(*cameraRays_, options_.seed, side_, static_cast<int>(m), batch_);
    else
      hasRay_ = detail::makeLightFieldSamples(std::get<LightFieldSensor>(sensor_), options_.seed, side_,
                                              static_cast<int>(m), batch_);
    prepared_ = m, nextPrepared_ = 0;
    return true;
  }

  // Starts prepared samples in the free lanes (taken from `free`) while
  // there are samples; returns the lanes they took.
  LaneMask startSamples(LaneMask& free) {
    LaneMask started = 0;
    while (free && (nextPrepared_ < prepared_ || prepareSamples())) {
      const size_t k = nextPrepared_++;
      const Start& start = starts_[k];
      PixelWork& px = pixels_[static_cast<size_t>(start.slot)];
      if (!(hasRay_ >> k & 1)) {  // no ray (outside a light field sensor's disc): the sample is 0
        px.values[static_cast<size_t>(start.sample)] = 0;
        --px.inFlight;
        if (start.slot != issuing_) finishIfDone(start.slot);
        continue;
      }
      const int lane = std::countr_zero(free);
      free &= free - 1;
      started |= 1u << lane;
      RayLanes& rays = lanes_.ray.rays;
      rays.ox[lane] = batch_.ox[k], rays.oy[lane] = batch_.oy[k], rays.oz[lane] = batch_.oz[k];
      rays.dx[lane] = batch_.dx[k], rays.dy[lane] = batch_.dy[k], rays.dz[lane] = batch_.dz[k];
      lanes_.ray.on[lane] = -1;
      lanes_.throughput[lane] = 1;
      lanes_.radiance[lane] = 0;
      lanes_.sampler[lane] = batch_.state[k];
      lanes_.depth[lane] = 0;
      lanes_.pixel[lane] = start.slot;
      lanes_.sample[lane] = start.sample;
      lanes_.waiting[lane] = 0;
      StratifiedChoices& choices = lanes_.choices[static_cast<size_t>(lane)];
      choices.sample = static_cast<std::uint32_t>(start.sample);
      choices.used = 0;
      choices.batched = false;
      lanes_.media[static_cast<size_t>(lane)].clear();  // in air: no medium, not inside an isolated solid
      lanes_.ray.inside[lane] = -1;
    }
    insideIsolated_ &= ~started;
    return started;
  }

  // Writes a pixel whose samples have all been started and ended, and frees its slot.
  void finishIfDone(int slot) {
    PixelWork& px = pixels_[static_cast<size_t>(slot)];
    if (px.issued < options_.samplesPerPixel || px.inFlight > 0) return;
    double sum = 0;
    for (const double v : px.values) sum += v;
    image_->ptr<float>(px.j)[px.i] = static_cast<float>(sum * invSpp_);
    px.issued = -1;  // freed
    freeSlots_.push_back(slot);
  }

  std::uint64_t pixelIndex(const PixelWork& px) const {
    return static_cast<std::uint64_t>(px.j) * static_cast<std::uint64_t>(width_) + static_cast<std::uint64_t>(px.i);
  }

  const Scene& scene_;
  const Sensor& sensor_;
  const RenderOptions& options_;
  int width_;
  std::optional<TelecentricCamera::RayMap> cameraRays_;
  int side_;  // strata per axis of the pixel area (and of the stop)
  double invSpp_;
  int nextI_ = 0, nextJ_ = 0, x0_ = 0, x1_ = 0, y1_ = 0;
  int issuing_ = -1;  // the pixel whose samples are being planned
  cv::Mat* image_ = nullptr;
  std::vector<PixelWork> pixels_;
  std::vector<int> freeSlots_;
  std::array<Start, detail::CameraSampleBatch::kSize> starts_;  // the prepared samples, in batch_
  detail::CameraSampleBatch batch_;
  std::uint64_t hasRay_ = 0;  // bit k: prepared sample k has a ray
  size_t prepared_ = 0, nextPrepared_ = 0;
  detail::ChoiceBatch choices_;
  static_assert(detail::CameraSampleBatch::kSize == 64 && detail::ChoiceBatch::kSize >= kLanes);  // (hasRay_)
  Lanes lanes_;
  LaneMask insideIsolated_ = 0;  // lanes whose innermost medium is an isolated solid (Scene::isolated)
  std::vector<char> isolated_;   // Scene::isolated of object i at i + 1 (0: the ambient medium, false)
  bool absorbing_ = false;       // any medium absorbs (else every transmittance is 1)
  Scene::HitPacket hits_{};  // (lanes without a hit are read by the lane-parallel passes, their results dropped)
  detail::FresnelLanes fresnel_;
  detail::LightFieldMapping lightFieldMapping_;
  // Per lane, its waiting split branches, at most one per split depth.
  std::vector<std::array<Walker, RenderOptions::kMaxSplitDepth>> branches_;
};

}  // namespace

cv::Mat render(const Scene& scene, const Sensor& sensor, const RenderOptions& options) {
  if (options.samplesPerPixel < 1) fail(Errc::InvalidArgument, "render: samplesPerPixel must be >= 1");
  if (options.splitDepth < 0 || options.splitDepth > RenderOptions::kMaxSplitDepth)
    fail(Errc::InvalidArgument, "render: splitDepth = {} is outside [0, {}]", options.splitDepth,
         RenderOptions::kMaxSplitDepth);
  if (options.tileSize < 1) fail(Errc::InvalidArgument, "render: tileSize must be >= 1");
  if (options.maxDepth < 1) fail(Errc::InvalidArgument, "render: maxDepth = {} must be >= 1", options.maxDepth);
  // A pixel's sample s has the random stream (pixel << 24) ^ s: more samples would share the next pixel's streams.
  if (options.samplesPerPixel > (1 << 24))
    fail(Errc::InvalidArgument, "render: samplesPerPixel = {} is above 2^24", options.samplesPerPixel);
  if (const auto* cam = std::get_if<TelecentricCamera>(&sensor)) cam->validate();
  if (const auto* lfs = std::get_if<LightFieldSensor>(&sensor)) lfs->geometry.validate();
  const int width = sensorWidth(sensor), height = sensorHeight(sensor);
  cv::Mat image(height, width, CV_32FC1, cv::Scalar(0));
  const int ts = options.tileSize;
  const int tilesX = (width + ts - 1) / ts, tilesY = (height + ts - 1) / ts, tiles = tilesX * tilesY;
  int done = 0;
  std::mutex progressMutex;  // (fractions reported in order: a bar never steps back)
  std::atomic<bool> stopped{false};

  auto renderTile = [&](int tile) {
    if (options.cancel && options.cancel->load(std::memory_order_relaxed)) {
      stopped = true;
      return;
    }
    const int x0 = (tile % tilesX) * ts, y0 = (tile / tilesX) * ts;
    TileRenderer(scene, sensor, options).render(x0, y0, std::min(x0 + ts, width), std::min(y0 + ts, height), image);
    std::lock_guard lock(progressMutex);
    ++done;
    if (options.progress) options.progress(static_cast<double>(done) / tiles);
  };

  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, tiles, 1), [&](const tbb::blocked_range<int>& range) {
      for (int tile = range.begin(); tile != range.end(); ++tile) renderTile(tile);
    });
  });
  if (stopped) fail(Errc::Cancelled, "render cancelled");
  return image;
}

}  // namespace lfi::sim
