// SPDX-License-Identifier: Apache-2.0
// The packet renderer of one tile: its pixels' samples traced as a structure of
// arrays of Scene::kPacket paths, refilled as samples end (render.cpp runs the tiles).

#include "tile_renderer.h"

#include "camera_samples.h"
#include "fresnel_step.h"
#include "light_field_lanes.h"
#include "path_physics.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <optional>
#include <variant>
#include <vector>

namespace lfi::sim::detail {

namespace {

// A pixel whose samples are being traced: its sample plan and their results.
struct PixelWork {
  int i = 0, j = 0;
  int issued = 0;              // samples started
  int inFlight = 0;            // samples started and not yet ended
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
  int pixel[kLanes];    // index into the tile's PixelWork slots
  int sample[kLanes];   // index in the pixel
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
      : scene_(scene),
        sensor_(sensor),
        options_(options),
        width_(sensorWidth(sensor)),
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
    // Every sample has a ray but a light field sensor's outside its disc and
    // a camera's that a knife edge blocks.
    if (cameraRays_)
      hasRay_ = detail::makeCameraSamples(*cameraRays_, options_.seed, side_, static_cast<int>(m), batch_);
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
      if (!(hasRay_ >> k & 1)) {  // no ray (outside a light field sensor's disc, blocked by a knife edge): 0
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
  Scene::HitPacket hits_{};      // (lanes without a hit are read by the lane-parallel passes, their results dropped)
  detail::FresnelLanes fresnel_;
  detail::LightFieldMapping lightFieldMapping_;
  // Per lane, its waiting split branches, at most one per split depth.
  std::vector<std::array<Walker, RenderOptions::kMaxSplitDepth>> branches_;
};

}  // namespace

void renderTile(const Scene& scene, const Sensor& sensor, const RenderOptions& options, int x0, int y0, int x1, int y1,
                cv::Mat& image) {
  TileRenderer(scene, sensor, options).render(x0, y0, x1, y1, image);
}

}  // namespace lfi::sim::detail
