#include "lfi/sim/render.h"

#include "lfi/core/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <functional>
#include <numbers>

namespace lfi::sim {

namespace {

std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// sin x and cos x for |x| <= pi/4 by their Taylor series to x^15 and x^16
// (remainders below 5e-17, so exact to rounding), evaluated by Estrin's scheme
// for a short dependency chain: a fraction of a general sincos's cost, and the
// camera draws one per sample.
void sinCosQuarter(double x, double& sinX, double& cosX) {
  const double y = -x * x, y2 = y * y, y4 = y2 * y2;
  auto series = [&](const double (&c)[9]) {  // sum of c[k] y^k
    const double p01 = c[0] + c[1] * y, p23 = c[2] + c[3] * y, p45 = c[4] + c[5] * y, p67 = c[6] + c[7] * y;
    return (p01 + p23 * y2) + (p45 + p67 * y2) * y4 + c[8] * (y4 * y4);
  };
  static constexpr double kSin[9] = {1, 1.0 / 6, 1.0 / 120, 1.0 / 5040, 1.0 / 362880, 1.0 / 39916800,
                                     1.0 / 6227020800, 1.0 / 1307674368000, 0};  // 1/(2k+1)!
  static constexpr double kCos[9] = {1, 1.0 / 2, 1.0 / 24, 1.0 / 720, 1.0 / 40320, 1.0 / 3628800,
                                     1.0 / 479001600, 1.0 / 87178291200, 1.0 / 20922789888000};  // 1/(2k)!
  sinX = x * series(kSin);
  cosX = series(kCos);
}

}  // namespace

Vec2 concentricDisc(double u1, double u2) {
  const double a = 2 * u1 - 1, b = 2 * u2 - 1;
  // |a| > |b|: r = a, phi = pi/4 b/a, point r (cos phi, sin phi); otherwise
  // r = b, phi = pi/2 - pi/4 a/b, point r (sin psi, cos psi) with psi = pi/4 a/b.
  // Selects rather than branches: which case holds is a coin toss per sample.
  const bool wide = std::abs(a) > std::abs(b);
  const double r = wide ? a : b, other = wide ? b : a;
  if (r == 0) return {0, 0};
  double s, c;
  sinCosQuarter((std::numbers::pi / 4) * (other / r), s, c);
  return {r * (wide ? c : s), r * (wide ? s : c)};
}

namespace {

Vec3 cosineHemisphere(const Vec3& n, double u1, double u2) {
  const Vec2 d = concentricDisc(u1, u2);
  const double z = std::sqrt(std::max(0.0, 1 - d.x * d.x - d.y * d.y));
  const Vec3 t = std::abs(n.x) > 0.5 ? Vec3(0, 1, 0).cross(n).normalized() : Vec3(1, 0, 0).cross(n).normalized();
  const Vec3 bt = n.cross(t);
  return (t * d.x + bt * d.y + n * z).normalized();
}

double emittedRadiance(const Scene& scene, const Hit& hit, const Emission& emission, const Vec3& towardsSensor) {
  const double cosTheta = towardsSensor.dot(hit.normal);
  return std::visit(
      [&](const auto& e) -> double {
        using T = std::decay_t<decltype(e)>;
        if constexpr (std::is_same_v<T, ParallelEmission>) {
          return cosTheta >= std::cos(e.halfAngle_rad) ? e.radiance : 0.0;
        } else if constexpr (std::is_same_v<T, LambertianEmission>) {
          return cosTheta > 0 ? e.radiance : 0.0;
        } else if constexpr (std::is_same_v<T, LightFieldEmission>) {
          if (!e.lightField) return 0.0;
          const Rigid3& local = scene.objectFromWorld(hit.object);
          const Vec3 q = local.point(hit.point);
          return e.lightField->radiance({q.x, q.y}, local.vector(towardsSensor), e.lookup);
        } else {
          static_assert(std::is_same_v<T, PanelEmission>);
          const Rigid3& local = scene.objectFromWorld(hit.object);
          const Vec3 q = local.point(hit.point);
          return e.radiance({q.x, q.y}, local.vector(towardsSensor));
        }
      },
      emission);
}

// The dielectric objects a path is inside, innermost last.
class MediumStack {
public:
  static constexpr int kDepth = 8;
  int size() const { return size_; }
  int top() const { return items_[size_ - 1]; }
  void push(int object) {
    if (size_ < kDepth) items_[size_++] = object;
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
      if (items_[i] != skip) return std::get<Dielectric>(scene.object(items_[i]).material).ior;
    return scene.ambientIor();
  }
  double absorption(const Scene& scene) const {
    return size_ ? std::get<Dielectric>(scene.object(top()).material).absorption_per_mm : 0.0;
  }

private:
  std::array<int, kDepth> items_{};
  int size_ = 0;
};

}  // namespace

Sampler::Sampler(std::uint64_t seed, std::uint64_t stream) : state(splitMix64(stream ^ splitMix64(seed))) {}

std::uint64_t Sampler::nextU64() {
  const std::uint64_t x = state;
  state += 0x9e3779b97f4a7c15ull;  // the golden-ratio increment; splitMix64 mixes x + increment
  return splitMix64(x);
}

std::uint32_t Sampler::below(std::uint32_t bound) {
  // Multiply and keep the high half; reject the few low halves that would bias it.
  std::uint64_t m = static_cast<std::uint64_t>(nextU32()) * bound;
  if (static_cast<std::uint32_t>(m) < bound) {
    const std::uint32_t threshold = -bound % bound;
    while (static_cast<std::uint32_t>(m) < threshold) m = static_cast<std::uint64_t>(nextU32()) * bound;
  }
  return static_cast<std::uint32_t>(m >> 32);
}

namespace {

// Unit vector along v (v != 0).
Vec3 unit(const Vec3& v) { return v * (1 / std::sqrt(v.dot(v))); }

// Cosine of the transmitted angle (Snell) for incidence cosine cosI in [0, 1]
// and eta = n1 / n2; -1 under total internal reflection.
double transmittedCosine(double cosI, double eta) {
  const double sin2T = eta * eta * (1 - cosI * cosI);
  return sin2T >= 1 ? -1 : std::sqrt(1 - sin2T);
}

// Unpolarised Fresnel reflectance from both angles' cosines.
double fresnelFromCosines(double cosI, double cosT, double n1, double n2) {
  const double rs = (n1 * cosI - n2 * cosT) / (n1 * cosI + n2 * cosT);
  const double rp = (n2 * cosI - n1 * cosT) / (n2 * cosI + n1 * cosT);
  return 0.5 * (rs * rs + rp * rp);
}

Vec3 refractedDirection(const Vec3& d, const Vec3& n, double eta, double cosI, double cosT) {
  return unit(d * eta + n * (eta * cosI - cosT));
}

}  // namespace

double fresnelReflectance(double cosI, double n1, double n2) {
  cosI = std::clamp(cosI, 0.0, 1.0);
  const double cosT = transmittedCosine(cosI, n1 / n2);
  return cosT < 0 ? 1.0 : fresnelFromCosines(cosI, cosT, n1, n2);
}

bool refract(const Vec3& d, const Vec3& n, double eta, Vec3& out) {
  const double cosI = std::clamp(-d.dot(n), 0.0, 1.0);
  const double cosT = transmittedCosine(cosI, eta);
  if (cosT < 0) return false;
  out = refractedDirection(d, n, eta, cosI, cosT);
  return true;
}

Vec3 reflect(const Vec3& d, const Vec3& n) { return unit(d - n * (2 * d.dot(n))); }

namespace {

struct PathState {
  Ray ray;
  MediumStack media;
  double throughput = 1;
  int depth = 0;
};

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
  const Object& obj = scene.object(hit.object);
  if (obj.emission) {
    radiance = p.throughput * emittedRadiance(scene, hit, *obj.emission, -p.ray.direction);
    return Step::Done;
  }
  const Vec3 d = p.ray.direction;
  const bool entering = d.dot(hit.normal) < 0;
  const Vec3 facing = entering ? hit.normal : -hit.normal;  // towards the incoming side
  // Meshes are intersected in float: step off the surface to avoid re-hits.
  const bool exact = std::holds_alternative<std::shared_ptr<const Solid>>(obj.shape);
  auto leave = [&](const Vec3& dir) {
    const double offset = exact ? 0.0 : 1e-4 * (dir.dot(facing) > 0 ? 1 : -1);
    return Ray{hit.point + facing * offset, dir};
  };
  const int depth = p.depth++;

  if (std::holds_alternative<Absorber>(obj.material)) return Step::Done;
  if (const auto* diffuse = std::get_if<Diffuse>(&obj.material)) {
    if (!policy.diffuse) return Step::Done;
    p.throughput *= diffuse->albedo;
    p.ray = leave(policy.bounce(facing));
    return Step::Continue;
  }
  const auto& glass = std::get<Dielectric>(obj.material);
  // Entering: from the current medium into the glass. Leaving: from the
  // glass into whatever medium contains it (a bubble in glass exits to glass).
  const double n1 = entering ? p.media.ior(scene) : glass.ior;
  const double n2 = entering ? glass.ior : p.media.ior(scene, hit.object);
  const double cosI = std::clamp(-d.dot(facing), 0.0, 1.0);
  const double cosT = transmittedCosine(cosI, n1 / n2);
  if (cosT < 0) {  // total internal reflection
    p.ray = leave(reflect(d, facing));
    return Step::Continue;
  }
  const double reflectance = fresnelFromCosines(cosI, cosT, n1, n2);
  const bool split = depth < policy.splitDepth;
  if (split) {
    // Splitting: both branches, weighted, instead of a random choice.
    branch = p;
    branch.ray = leave(reflect(d, facing));
    branch.throughput *= reflectance;
    p.throughput *= 1 - reflectance;
  } else if (policy.chooseReflection(reflectance)) {
    p.ray = leave(reflect(d, facing));
    return Step::Continue;
  }
  p.ray = leave(refractedDirection(d, facing, n1 / n2, cosI, cosT));
  if (entering)
    p.media.push(hit.object);
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

struct SampledPolicy {
  Sampler& sampler;
  int maxDepth;
  int splitDepth;
  // Stratified values for the first Fresnel choices of this sample (Latin
  // hypercube across the pixel's samples); later choices draw at random.
  const double* decisions = nullptr;
  int decisionCount = 0;
  bool diffuse = true;
  void visit(const Hit&, const Ray&) {}
  bool chooseReflection(double reflectance) {
    const double u = decisionCount > 0 ? (--decisionCount, *decisions++) : sampler.next();
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

double traceRadiance(const Scene& scene, const Ray& ray, Sampler& sampler, int maxDepth, int splitDepth,
                     const double* decisions, int decisionCount) {
  SampledPolicy policy{sampler, maxDepth, splitDepth, decisions, decisionCount};
  return walk(scene, PathState{.ray = ray}, policy);
}

std::vector<Vec3> refractionPath(const Scene& scene, const Ray& ray, int maxDepth, double escape) {
  std::vector<Vec3> vertices{ray.origin};
  RefractionPathPolicy policy{vertices, maxDepth, escape};
  walk(scene, PathState{.ray = ray}, policy);
  return vertices;
}

// Fresnel choices per sample drawn from a Latin hypercube rather than at random.
constexpr int kStratifiedChoices = 4;

namespace {

// A pixel whose samples are being traced: its sample plan and their results.
struct PixelWork {
  int i = 0, j = 0;
  int issued = 0;    // samples started
  int inFlight = 0;  // samples started and not yet ended
  std::vector<double> values;     // each sample's radiance, summed in sample order at the end
  std::vector<int> permutation;   // stop strata, independently permuted
  std::vector<double> decisions;  // Latin hypercube, kStratifiedChoices per sample
};

// Where a path goes on: its state, random stream and stratified choices.
struct Walker {
  PathState path;
  Sampler sampler{0, 0};
  const double* decisions = nullptr;
  int decisionCount = 0;
};

// One sample in the packet. Its split branches wait on its own stack and are
// traced depth first in the same lane, so each sample's radiance is summed in
// the same order however samples share packets: the image is bit-identical
// for any tile size and thread count.
struct Lane {
  Walker walker;
  // At most one waiting branch per split depth.
  std::array<Walker, RenderOptions::kMaxSplitDepth> branches;
  int waiting = 0;
  double radiance = 0;
  int pixel = 0;  // index into the tile's PixelWork slots
  int sample = 0;
};

// Renders one tile: the pixels' samples are traced as packets of up to
// Scene::kPacket paths through Embree, refilled as samples end, so that a
// packet stays full and coherent (neighbouring samples of one or two pixels).
class TileRenderer {
public:
  TileRenderer(const Scene& scene, const Sensor& sensor, const RenderOptions& options)
      : scene_(scene), sensor_(sensor), options_(options), width_(sensorWidth(sensor)),
        cameraRays_(std::holds_alternative<TelecentricCamera>(sensor)
                        ? std::optional(TelecentricCamera::RayMap(std::get<TelecentricCamera>(sensor)))
                        : std::nullopt),
        side_(static_cast<int>(std::sqrt(static_cast<double>(options.samplesPerPixel)))), strata_(side_ * side_),
        invSide_(1.0 / side_), invSpp_(1.0 / options.samplesPerPixel) {}

  void render(int x0, int y0, int x1, int y1, cv::Mat& image) {
    nextI_ = x0, nextJ_ = y0, x0_ = x0, x1_ = x1, y1_ = y1;
    image_ = &image;
    int issuing = -1;
    std::array<Lane*, Scene::kPacket> active{};
    std::array<Ray, Scene::kPacket> rays;
    std::array<Hit, Scene::kPacket> hits;
    std::vector<Lane> lanes(Scene::kPacket);
    std::vector<int> freeLanes;
    for (int k = static_cast<int>(Scene::kPacket) - 1; k >= 0; --k) freeLanes.push_back(k);
    size_t n = 0;
    for (;;) {
      // Fill the packet with new samples.
      while (n < Scene::kPacket) {
        if (issuing < 0 || pixels_[static_cast<size_t>(issuing)].issued == options_.samplesPerPixel) {
          if (issuing >= 0) finishIfDone(issuing);
          issuing = startPixel();
          if (issuing < 0) break;
        }
        Lane* lane = &lanes[static_cast<size_t>(freeLanes.back())];
        if (!startSample(issuing, *lane)) continue;
        freeLanes.pop_back();
        active[n++] = lane;
      }
      if (n == 0) break;
      for (size_t k = 0; k < n; ++k) rays[k] = active[k]->walker.path.ray;
      scene_.intersect(std::span(rays.data(), n), std::span(hits.data(), n));
      size_t kept = 0;
      for (size_t k = 0; k < n; ++k) {
        Lane& lane = *active[k];
        Walker& w = lane.walker;
        SampledPolicy policy{w.sampler, options_.maxDepth, options_.splitDepth, w.decisions, w.decisionCount};
        double radiance;
        const Step step = interact(scene_, hits[k], w.path, branch_, radiance, policy);
        w.decisions = policy.decisions;
        w.decisionCount = policy.decisionCount;
        if (step == Step::Split)  // the branch gets its own stream, keyed by the parent's state and depth
          lane.branches[static_cast<size_t>(lane.waiting++)] = {
              branch_, Sampler(w.sampler.state, static_cast<std::uint64_t>(branch_.depth)), w.decisions,
              w.decisionCount};
        if (step != Step::Done && w.path.depth < options_.maxDepth) {
          active[kept++] = &lane;
          continue;
        }
        lane.radiance += radiance;
        // The path ended: go on with the sample's latest waiting branch, if any.
        bool resumed = false;
        while (!resumed && lane.waiting > 0) {
          w = lane.branches[static_cast<size_t>(--lane.waiting)];
          resumed = w.path.depth < options_.maxDepth;
        }
        if (resumed) {
          active[kept++] = &lane;
          continue;
        }
        PixelWork& px = pixels_[static_cast<size_t>(lane.pixel)];
        px.values[static_cast<size_t>(lane.sample)] = lane.radiance;
        --px.inFlight;
        freeLanes.push_back(static_cast<int>(&lane - lanes.data()));
        if (lane.pixel != issuing) finishIfDone(lane.pixel);
      }
      n = kept;
    }
  }

private:
  // Claims a slot for the tile's next pixel and plans its samples; -1 when the tile is done.
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
    const int spp = options_.samplesPerPixel;
    Sampler pixelSampler(options_.seed, pixelIndex(px));
    // Jittered strata for the pixel area and, independently permuted, for
    // the stop: the first m^2 samples cover both evenly; the rest are random.
    px.permutation.resize(static_cast<size_t>(strata_));
    for (int k = 0; k < strata_; ++k) px.permutation[static_cast<size_t>(k)] = k;
    for (int k = strata_ - 1; k > 0; --k)
      std::swap(px.permutation[static_cast<size_t>(k)],
                px.permutation[static_cast<size_t>(pixelSampler.below(static_cast<std::uint32_t>(k + 1)))]);
    // Latin hypercube for the first Fresnel choices: across the pixel's
    // samples each choice's random value covers [0,1) evenly, so the few
    // reflect/refract branches of a lens are taken in proportion.
    px.decisions.resize(static_cast<size_t>(spp) * kStratifiedChoices);
    order_.resize(static_cast<size_t>(spp));
    for (int d = 0; d < kStratifiedChoices; ++d) {
      for (int k = 0; k < spp; ++k) order_[static_cast<size_t>(k)] = k;
      for (int k = spp - 1; k > 0; --k)
        std::swap(order_[static_cast<size_t>(k)],
                  order_[static_cast<size_t>(pixelSampler.below(static_cast<std::uint32_t>(k + 1)))]);
      for (int k = 0; k < spp; ++k)
        px.decisions[static_cast<size_t>(k) * kStratifiedChoices + d] =
            (order_[static_cast<size_t>(k)] + pixelSampler.next()) * invSpp_;
    }
    return slot;
  }

  // Starts the pixel's next sample in `lane`; false when its ray does not exist
  // (outside a light field sensor's disc: the sample contributes 0).
  bool startSample(int slot, Lane& lane) {
    PixelWork& px = pixels_[static_cast<size_t>(slot)];
    const int s = px.issued++;
    // One random stream per sample: two scenes that differ only where a path
    // can reach (a defect) give identical samples everywhere else.
    Sampler& sampler = lane.walker.sampler;
    sampler = Sampler(options_.seed, (pixelIndex(px) << 24) ^ static_cast<std::uint64_t>(s) ^ 0x5bd1e995ull);
    auto stratified = [&](int stratum) {
      const double u = sampler.next(), v = sampler.next();
      if (stratum >= strata_) return Vec2(u, v);
      const int row = stratum / side_;
      return Vec2((stratum - row * side_ + u) * invSide_, (row + v) * invSide_);
    };
    const Vec2 offset = stratified(s);
    std::optional<Ray> ray;
    if (cameraRays_) {
      const Vec2 u = stratified(s < strata_ ? px.permutation[static_cast<size_t>(s)] : s);
      ray = (*cameraRays_)(px.i, px.j, offset, concentricDisc(u.x, u.y));
    } else {
      ray = std::get<LightFieldSensor>(sensor_).ray(px.i, px.j, offset);
    }
    if (!ray) {
      px.values[static_cast<size_t>(s)] = 0;
      return false;
    }
    lane.walker.path = PathState{.ray = *ray};
    lane.walker.decisions = &px.decisions[static_cast<size_t>(s) * kStratifiedChoices];
    lane.walker.decisionCount = kStratifiedChoices;
    lane.waiting = 0;
    lane.radiance = 0;
    lane.pixel = slot;
    lane.sample = s;
    ++px.inFlight;
    return true;
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
  int side_, strata_;
  double invSide_, invSpp_;
  int nextI_ = 0, nextJ_ = 0, x0_ = 0, x1_ = 0, y1_ = 0;
  cv::Mat* image_ = nullptr;
  std::vector<PixelWork> pixels_;
  std::vector<int> freeSlots_;
  std::vector<int> order_;
  PathState branch_;  // written by a split
};

}  // namespace

cv::Mat render(const Scene& scene, const Sensor& sensor, const RenderOptions& options) {
  if (options.samplesPerPixel < 1) fail(Errc::InvalidArgument, "render: samplesPerPixel must be >= 1");
  if (options.splitDepth < 0 || options.splitDepth > RenderOptions::kMaxSplitDepth)
    fail(Errc::InvalidArgument, "render: splitDepth = {} is outside [0, {}]", options.splitDepth,
         RenderOptions::kMaxSplitDepth);
  if (options.tileSize < 1) fail(Errc::InvalidArgument, "render: tileSize must be >= 1");
  if (const auto* cam = std::get_if<TelecentricCamera>(&sensor)) cam->validate();
  if (const auto* lfs = std::get_if<LightFieldSensor>(&sensor)) lfs->geometry.validate();
  const int width = sensorWidth(sensor), height = sensorHeight(sensor);
  cv::Mat image(height, width, CV_32FC1, cv::Scalar(0));
  const int ts = options.tileSize;
  const int tilesX = (width + ts - 1) / ts, tilesY = (height + ts - 1) / ts, tiles = tilesX * tilesY;
  std::atomic<int> done{0};
  std::atomic<bool> stopped{false};

  auto renderTile = [&](int tile) {
    if (options.cancel && options.cancel->load(std::memory_order_relaxed)) {
      stopped = true;
      return;
    }
    const int x0 = (tile % tilesX) * ts, y0 = (tile / tilesX) * ts;
    TileRenderer(scene, sensor, options).render(x0, y0, std::min(x0 + ts, width), std::min(y0 + ts, height), image);
    const int finished = ++done;
    if (options.progress) options.progress(static_cast<double>(finished) / tiles);
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
