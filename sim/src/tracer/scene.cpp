// SPDX-License-Identifier: Apache-2.0
#include "lfi/sim/scene.h"

#include "lfi/core/error.h"
#include "lfi/core/log.h"

#include "simd.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>

namespace lfi::sim {

namespace {

// A rectangle in the world frame: centre, unit axes along its sides and normal
// (the object's x, y, z), half sizes.
struct WorldRectangle {
  Vec3 centre{0}, axisX{0}, axisY{0}, normal{0};
  double halfX = 0, halfY = 0;
};

// Our data for one analytic object (a solid or a rectangle), handed to Embree's callbacks.
struct AnalyticGeometry {
  const Solid* solid;  // null for a rectangle
  WorldRectangle rectangle;
  Rigid3 worldFromObject;
  Rigid3 objectFromWorld;
  int object;
  bool placed;  // false: the object frame is the world frame
  Bounds box;   // world frame, padded as Embree sees it
};

// World bounds of an object's local bounds, padded so that Embree's float
// traversal never culls a real hit.
// A rectangle's box in its own frame: centred, in the xy plane.
Bounds rectangleBounds(const Rectangle& r) {
  return {{-r.sizeX / 2, -r.sizeY / 2, 0}, {r.sizeX / 2, r.sizeY / 2, 0}};
}

Bounds paddedWorldBounds(const Bounds& local, const Rigid3& worldFromObject) {
  Bounds b = local.transformed(worldFromObject);
  const double pad = 1e-3 + 1e-6 * std::max({std::abs(b.lo.x), std::abs(b.lo.y), std::abs(b.lo.z), std::abs(b.hi.x),
                                             std::abs(b.hi.y), std::abs(b.hi.z)});
  b.lo = b.lo - Vec3(pad), b.hi = b.hi + Vec3(pad);
  return b;
}

bool contains(const Bounds& b, const Vec3& p) {
  return p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y && p.z >= b.lo.z && p.z <= b.hi.z;
}

bool overlap(const Bounds& a, const Bounds& b) {
  return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y && a.lo.z <= b.hi.z &&
         b.lo.z <= a.hi.z;
}

// The crossings beyond tMin of the lanes in `lanes` with a (closed)
// rectangle, kept where they are the nearest so far; every lane is computed
// at once (vectorised; a lane's crossing does not depend on the others').
LFI_SIMD_CLONES void rectangleLanes(const WorldRectangle& r, const RayLanes& __restrict rays, std::uint32_t lanes,
                                    double tMin, int object, Scene::HitPacket& __restrict best) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Vec3 n = r.normal, ax = r.axisX, ay = r.axisY, c = r.centre;
  const double halfX = r.halfX, halfY = r.halfY;
  double crossing[RayLanes::kSize];
  for (int k = 0; k < RayLanes::kSize; ++k) {
    const double cx = c.x - rays.ox[k], cy = c.y - rays.oy[k], cz = c.z - rays.oz[k];
    const double dx = rays.dx[k], dy = rays.dy[k], dz = rays.dz[k];
    const double t = (cx * n.x + cy * n.y + cz * n.z) / (dx * n.x + dy * n.y + dz * n.z);  // NaN or inf: parallel
    const double px = dx * t - cx, py = dy * t - cy, pz = dz * t - cz;  // from the centre, in the plane
    const double u = px * ax.x + py * ax.y + pz * ax.z, v = px * ay.x + py * ay.y + pz * ay.z;
    const bool hit = (t > tMin) & (t < kInf) & (std::abs(u) <= halfX) & (std::abs(v) <= halfY);  // no branches
    crossing[k] = hit ? t : kInf;
  }
  for (int k = 0; k < RayLanes::kSize; ++k) {
    const bool nearer =
        (lanes >> k & 1) != 0 && (crossing[k] < best.t[k] || (crossing[k] == best.t[k] && object < best.object[k]));
    best.t[k] = nearer ? crossing[k] : best.t[k];
    best.nx[k] = nearer ? n.x : best.nx[k];
    best.ny[k] = nearer ? n.y : best.ny[k];
    best.nz[k] = nearer ? n.z : best.nz[k];
    best.object[k] = nearer ? object : best.object[k];
  }
}

// Embree finds which analytic objects each ray may hit (their bounds). The
// callback only notes the lanes; their crossings are computed after the
// traversal for all of them at once: Embree's packet traversal hands the
// callback only one or a few rays at a time, while a rectangle's crossing and
// the solids' convex kernel are lane-parallel. Lanes are the rays' ids (their
// index in the packet). Crossings are in double precision.
struct HitContext {
  RTCIntersectContext embree;
  const RayLanes* rays;  // world frame
  double tMin;
  Scene::HitPacket* best;               // the nearest analytic crossing so far, per lane
  const AnalyticGeometry* const* skip;  // per lane: a solid the ray cannot cross, or null
  // The objects met so far, each with the lanes that may cross it.
  static constexpr int kObjects = 8;
  int objects;
  std::array<const AnalyticGeometry*, kObjects> object;  // not initialised: `objects` says what is valid
  std::array<std::uint32_t, kObjects> lanes;
};
static_assert(RayLanes::kSize == static_cast<int>(Scene::kPacket) && Scene::kPacket <= 32);

// Keeps a crossing of lane k if it is the nearest so far. Of two at the same
// distance (coincident surfaces) the lower object index wins, whatever order
// the objects were resolved in (which depends on the packet's other lanes).
inline void keepNearest(Scene::HitPacket& best, int k, double t, const Vec3& normal, int object) {
  if (!(t < best.t[k] || (t == best.t[k] && object < best.object[k]))) return;
  best.t[k] = t;
  best.nx[k] = normal.x, best.ny[k] = normal.y, best.nz[k] = normal.z;
  best.object[k] = object;
}

// Intersects the noted objects' lanes exactly and keeps each lane's nearest.
void resolveLanes(HitContext& ctx) {
  RayLanes local;
  double t[RayLanes::kSize];
  Vec3 normal[RayLanes::kSize];
  for (int s = 0; s < ctx.objects; ++s) {
    const AnalyticGeometry& g = *ctx.object[static_cast<size_t>(s)];
    const std::uint32_t lanes = ctx.lanes[static_cast<size_t>(s)];
    if (lanes == 0) continue;  // every lane skipped it
    if (!g.solid) {
      rectangleLanes(g.rectangle, *ctx.rays, lanes, ctx.tMin, g.object, *ctx.best);
      continue;
    }
    if (g.placed) transformRays(g.objectFromWorld, *ctx.rays, local);
    g.solid->nearestCrossings(g.placed ? local : *ctx.rays, lanes, ctx.tMin, t, normal);
    for (std::uint32_t bits = lanes; bits; bits &= bits - 1) {
      const int k = std::countr_zero(bits);
      keepNearest(*ctx.best, k, t[k], g.placed ? g.worldFromObject.vector(normal[k]) : normal[k], g.object);
    }
  }
  ctx.objects = 0;
}

// Notes that the lanes in `bits` may cross object g (resolved by resolveLanes).
void noteLanes(HitContext& ctx, const AnalyticGeometry* g, std::uint32_t bits) {
  int s = 0;
  while (s < ctx.objects && ctx.object[static_cast<size_t>(s)] != g) ++s;
  if (s == ctx.objects) {
    if (ctx.objects == HitContext::kObjects) resolveLanes(ctx), s = 0;
    ctx.object[static_cast<size_t>(s)] = g;
    ctx.lanes[static_cast<size_t>(s)] = 0;
    ++ctx.objects;
  }
  ctx.lanes[static_cast<size_t>(s)] |= bits;
}

void analyticBounds(const RTCBoundsFunctionArguments* args) {
  const Bounds& b = static_cast<const AnalyticGeometry*>(args->geometryUserPtr)->box;
  RTCBounds* o = args->bounds_o;
  o->lower_x = static_cast<float>(b.lo.x);
  o->lower_y = static_cast<float>(b.lo.y);
  o->lower_z = static_cast<float>(b.lo.z);
  o->upper_x = static_cast<float>(b.hi.x);
  o->upper_y = static_cast<float>(b.hi.y);
  o->upper_z = static_cast<float>(b.hi.z);
}

void analyticIntersect(const RTCIntersectFunctionNArguments* args) {
  auto& ctx = *reinterpret_cast<HitContext*>(args->context);
  const auto* g = static_cast<const AnalyticGeometry*>(args->geometryUserPtr);
  RTCRayN* rays = RTCRayHitN_RayN(args->rayhit, args->N);
  std::uint32_t bits = 0;
  for (unsigned k = 0; k < args->N; ++k) {
    const unsigned lane = RTCRayN_id(rays, args->N, k);
    bits |= (args->valid[k] != 0 && ctx.skip[lane] != g ? 1u : 0u) << lane;
  }
  noteLanes(ctx, g, bits);
}

// How far along a ray Embree's copy of it starts: a ray from farther than
// twice the scene's radius starts where it comes within that radius of the
// scene's centre, before which it cannot have met anything. Embree takes
// origins, and gives a mesh's t, in float: from a far sensor (1 km) its t
// would be off by 0.06 mm, and its rounded origins would pass beside the
// parts' padded boxes. The exact crossings take the whole ray in double;
// Embree's t of a mesh gets the shift back in double.
inline double embreeStart(const Vec3& centre, double radius, double ox, double oy, double oz, double dx, double dy,
                          double dz) {
  const double cx = centre.x - ox, cy = centre.y - oy, cz = centre.z - oz;
  const double along = cx * dx + cy * dy + cz * dz;
  const bool far = cx * cx + cy * cy + cz * cz > 4 * radius * radius && along > radius;
  return far ? along - radius : 0.0;
}

// Embree's packet for the lanes in `traced` (the others invalid), every lane
// at once (vectorised). An invalid lane also gets tfar < tnear: on a CPU
// without AVX-512, Embree 3.13 answers rtcIntersect16 through its ray-stream
// path, which ignores the valid mask and skips only such rays (it traced all
// sixteen, and the callbacks noted lanes nobody asked for).
LFI_SIMD_CLONES void embreePacket(const RayLanes& __restrict r, std::uint32_t traced, double tMin, Vec3 centre,
                                  double radius, int* __restrict valid, double* __restrict start,
                                  RTCRayHit16& __restrict rh) {
  for (int k = 0; k < RayLanes::kSize; ++k) {
    valid[k] = (traced >> k & 1) != 0 ? -1 : 0;
    const double t0 = embreeStart(centre, radius, r.ox[k], r.oy[k], r.oz[k], r.dx[k], r.dy[k], r.dz[k]);
    start[k] = t0;
    rh.ray.org_x[k] = static_cast<float>(r.ox[k] + t0 * r.dx[k]);
    rh.ray.org_y[k] = static_cast<float>(r.oy[k] + t0 * r.dy[k]);
    rh.ray.org_z[k] = static_cast<float>(r.oz[k] + t0 * r.dz[k]);
    rh.ray.dir_x[k] = static_cast<float>(r.dx[k]);
    rh.ray.dir_y[k] = static_cast<float>(r.dy[k]);
    rh.ray.dir_z[k] = static_cast<float>(r.dz[k]);
    rh.ray.tnear[k] = static_cast<float>(std::max(tMin - t0, 0.0));
    rh.ray.tfar[k] =
        (traced >> k & 1) != 0 ? std::numeric_limits<float>::infinity() : -std::numeric_limits<float>::infinity();
    rh.ray.time[k] = 0;
    rh.ray.mask[k] = 0xffffffffu;
    rh.ray.id[k] = static_cast<unsigned>(k);
    rh.ray.flags[k] = 0;
    rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
  }
}

// Per object: its solid when no other object's bounds meet the solid's padded
// bounds, else null.
std::vector<const AnalyticGeometry*> isolatedSolids(const std::vector<Object>& objects,
                                                    const std::vector<std::unique_ptr<AnalyticGeometry>>& analytic) {
  std::vector<Bounds> boxes(objects.size());  // world bounds of every object's surface
  std::vector<const AnalyticGeometry*> solidOf(objects.size(), nullptr);
  for (const auto& g : analytic) {
    boxes[static_cast<size_t>(g->object)] = g->box;
    if (g->solid) solidOf[static_cast<size_t>(g->object)] = g.get();
  }
  for (size_t i = 0; i < objects.size(); ++i)
    if (std::holds_alternative<TriangleMesh>(objects[i].shape)) boxes[i] = worldBounds(objects[i]);
  std::vector<const AnalyticGeometry*> isolated(objects.size(), nullptr);
  for (size_t i = 0; i < objects.size(); ++i) {
    if (!solidOf[i]) continue;
    bool alone = true;
    for (size_t j = 0; j < objects.size() && alone; ++j) alone = j == i || !overlap(boxes[i], boxes[j]);
    if (alone) isolated[i] = solidOf[i];
  }
  return isolated;
}

Surface surfaceOf(const Object& obj) {
  Surface s;
  s.exact = !std::holds_alternative<TriangleMesh>(obj.shape);
  if (obj.emission) {
    s.kind = Surface::Kind::Emitter;
    if (const auto* parallel = std::get_if<ParallelEmission>(&*obj.emission)) {
      s.uniformEmission = true;
      s.radiance = parallel->radiance;
      s.cosHalfAngle = std::cos(parallel->halfAngle_rad);
    } else if (const auto* lambertian = std::get_if<LambertianEmission>(&*obj.emission)) {
      s.uniformEmission = true;
      s.radiance = lambertian->radiance;
      s.cosHalfAngle = std::numeric_limits<double>::denorm_min();  // cos θ >= it: cos θ > 0
    }
  } else if (const auto* glass = std::get_if<Dielectric>(&obj.material)) {
    s.kind = Surface::Kind::Dielectric;
    s.ior = glass->ior;
    s.absorption_per_mm = glass->absorption_per_mm;
  } else if (const auto* diffuse = std::get_if<Diffuse>(&obj.material)) {
    s.kind = Surface::Kind::Diffuse;
    s.albedo = diffuse->albedo;
  }
  return s;
}

void embreeError(void*, RTCError code, const char* message) {
  spdlog::error("embree: error {}: {}", static_cast<int>(code), message ? message : "");
}

}  // namespace

Bounds worldBounds(const Object& object) {
  if (const auto* mesh = std::get_if<TriangleMesh>(&object.shape)) {
    Bounds box;
    for (const Vec3& v : mesh->vertices) {
      const Vec3 p = object.worldFromObject.point(v);
      box = box.unite({p, p});
    }
    return box;
  }
  if (const auto* rect = std::get_if<Rectangle>(&object.shape))
    return rectangleBounds(*rect).transformed(object.worldFromObject);
  const auto& solid = std::get<std::shared_ptr<const Solid>>(object.shape);
  return solid ? solid->bounds().transformed(object.worldFromObject) : Bounds{};
}

struct Scene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<std::unique_ptr<AnalyticGeometry>> analytic;  // solids and rectangles
  std::vector<Rigid3> objectFromWorld;
  // Per object: its solid when no other object's bounds meet the solid's padded
  // bounds, else null. A ray starting in such a box that crosses the solid
  // crosses it before anything else (see intersect), so the solid alone answers.
  std::vector<const AnalyticGeometry*> isolated;
  std::vector<const AnalyticGeometry*> convex;  // per object: its solid if convex, else null
  bool meshes = false;                          // whether any object is a triangle mesh
  Vec3 centre;                                  // of a ball holding every object (embreeStart)
  double radius = 0;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

Scene::Scene(std::vector<Object> objects, double ambientIor)
    : impl_(std::make_unique<Impl>()), objects_(std::move(objects)), ambientIor_(ambientIor) {
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device)
    fail(Errc::Device, "embree: cannot create a device (error {})", static_cast<int>(rtcGetDeviceError(nullptr)));
  rtcSetDeviceErrorFunction(impl_->device, embreeError, nullptr);
  impl_->scene = rtcNewScene(impl_->device);
  // Robust (watertight, conservative) traversal matters for meshes only: rays
  // must not slip between their triangles. The analytic objects' boxes are
  // padded far beyond the fast traversal's rounding.
  const bool meshes =
      std::ranges::any_of(objects_, [](const Object& o) { return std::holds_alternative<TriangleMesh>(o.shape); });
  rtcSetSceneFlags(impl_->scene, meshes ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
  impl_->meshes = meshes;
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

  for (size_t i = 0; i < objects_.size(); ++i) {
    const Object& obj = objects_[i];
    impl_->objectFromWorld.push_back(obj.worldFromObject.inverse());
    surfaces_.push_back(surfaceOf(obj));
    RTCGeometry geom = nullptr;
    const auto* solid = std::get_if<std::shared_ptr<const Solid>>(&obj.shape);
    const auto* rect = std::get_if<Rectangle>(&obj.shape);
    if (solid || rect) {  // Embree user geometry, intersected exactly by us
      Bounds local;
      if (solid) {
        if (!*solid) fail(Errc::InvalidArgument, "scene object '{}' has no solid", obj.name);
        local = (*solid)->bounds();
        if (!local.transformed(obj.worldFromObject).finite())
          fail(Errc::InvalidArgument, "scene object '{}' is unbounded (intersect it with a finite solid)", obj.name);
      } else {
        if (!(rect->sizeX > 0) || !(rect->sizeY > 0) || !std::isfinite(rect->sizeX) || !std::isfinite(rect->sizeY))
          fail(Errc::InvalidArgument, "scene object '{}': rectangle size must be finite and > 0", obj.name);
        local = rectangleBounds(*rect);
      }
      WorldRectangle world;
      if (rect)
        world = {obj.worldFromObject.t,
                 obj.worldFromObject.vector({1, 0, 0}),
                 obj.worldFromObject.vector({0, 1, 0}),
                 obj.worldFromObject.vector({0, 0, 1}),
                 rect->sizeX / 2,
                 rect->sizeY / 2};
      auto data = std::make_unique<AnalyticGeometry>(AnalyticGeometry{
          solid ? solid->get() : nullptr, world, obj.worldFromObject, obj.worldFromObject.inverse(),
          static_cast<int>(i), !obj.worldFromObject.isIdentity(), paddedWorldBounds(local, obj.worldFromObject)});
      geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_USER);
      rtcSetGeometryUserPrimitiveCount(geom, 1);
      rtcSetGeometryUserData(geom, data.get());
      rtcSetGeometryBoundsFunction(geom, analyticBounds, nullptr);
      rtcSetGeometryIntersectFunction(geom, analyticIntersect);
      impl_->analytic.push_back(std::move(data));
    } else {
      const auto& mesh = std::get<TriangleMesh>(obj.shape);
      if (mesh.triangles.empty()) fail(Errc::InvalidArgument, "scene object '{}': mesh has no triangles", obj.name);
      if (!mesh.normals.empty() && mesh.normals.size() != mesh.vertices.size())
        fail(Errc::InvalidArgument, "scene object '{}': {} normals for {} vertices", obj.name, mesh.normals.size(),
             mesh.vertices.size());
      geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                            3 * sizeof(float), mesh.vertices.size()));
      for (size_t k = 0; k < mesh.vertices.size(); ++k) {
        const Vec3 p = obj.worldFromObject.point(mesh.vertices[k]);
        v[3 * k] = static_cast<float>(p.x);
        v[3 * k + 1] = static_cast<float>(p.y);
        v[3 * k + 2] = static_cast<float>(p.z);
      }
      auto* t = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                               3 * sizeof(unsigned), mesh.triangles.size()));
      for (size_t k = 0; k < mesh.triangles.size(); ++k)
        for (int c = 0; c < 3; ++c) {
          if (mesh.triangles[k][c] >= mesh.vertices.size())
            fail(Errc::InvalidArgument, "scene object '{}': triangle {} uses vertex {} of {}", obj.name, k,
                 mesh.triangles[k][c], mesh.vertices.size());
          t[3 * k + c] = mesh.triangles[k][c];
        }
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(impl_->scene, geom, static_cast<unsigned>(i));
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
  Bounds all;
  for (const auto& g : impl_->analytic) all = all.unite(g->box);
  for (const Object& obj : objects_)
    if (std::holds_alternative<TriangleMesh>(obj.shape)) all = all.unite(paddedWorldBounds(worldBounds(obj), {}));
  if (all.finite()) impl_->centre = (all.lo + all.hi) * 0.5, impl_->radius = 0.5 * (all.hi - all.lo).length();
  impl_->isolated = isolatedSolids(objects_, impl_->analytic);
  impl_->convex.assign(objects_.size(), nullptr);
  for (const auto& g : impl_->analytic)
    if (g->solid && g->solid->convex()) impl_->convex[static_cast<size_t>(g->object)] = g.get();
}

Scene::~Scene() = default;

Hit Scene::intersect(const Ray& ray, double tMin, double tMax) const {
  RayLanes lane0;  // every lane the ray, for the lane-parallel kernels
  HitPacket best;
  for (int k = 0; k < RayLanes::kSize; ++k) {
    lane0.set(k, ray);
    best.t[k] = tMax;
    best.object[k] = -1;
  }
  HitContext ctx;
  rtcInitIntersectContext(&ctx.embree);
  ctx.rays = &lane0, ctx.tMin = tMin, ctx.best = &best;
  const AnalyticGeometry* skip[1] = {};
  ctx.skip = skip;
  ctx.objects = 0;
  RTCRayHit rh;
  const Vec3 &o = ray.origin, &d = ray.direction;
  const double t0 = embreeStart(impl_->centre, impl_->radius, o.x, o.y, o.z, d.x, d.y, d.z);
  rh.ray.org_x = static_cast<float>(o.x + t0 * d.x);
  rh.ray.org_y = static_cast<float>(o.y + t0 * d.y);
  rh.ray.org_z = static_cast<float>(o.z + t0 * d.z);
  rh.ray.dir_x = static_cast<float>(d.x);
  rh.ray.dir_y = static_cast<float>(d.y);
  rh.ray.dir_z = static_cast<float>(d.z);
  rh.ray.tnear = static_cast<float>(std::max(tMin - t0, 0.0));
  rh.ray.tfar = std::isfinite(tMax) ? static_cast<float>(tMax - t0) : std::numeric_limits<float>::infinity();
  rh.ray.time = 0;
  rh.ray.mask = 0xffffffffu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &ctx.embree, &rh);
  resolveLanes(ctx);
  if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID)
    meshHit(0, ray.direction, rh.hit.geomID, rh.hit.primID, t0 + rh.ray.tfar, {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z},
            rh.hit.u, rh.hit.v, best);
  Hit hit;
  if (best.object[0] < 0) return hit;
  hit.object = best.object[0];
  hit.t = best.t[0];
  hit.normal = best.normal(0);
  hit.point = ray.at(hit.t);
  return hit;
}

void Scene::intersect(std::span<const Ray> rays, std::span<Hit> hits, double tMin,
                      std::span<const RayStart> starts) const {
  if (rays.size() > kPacket || hits.size() < rays.size() || (!starts.empty() && starts.size() < rays.size()))
    fail(Errc::InvalidArgument, "Scene::intersect: {} rays for {} hits and {} starts (at most {} at once)", rays.size(),
         hits.size(), starts.size(), kPacket);
  const int n = static_cast<int>(rays.size());
  if (n == 0) return;
  RayPacket packet;
  for (int k = 0; k < static_cast<int>(kPacket); ++k) {  // lanes past n: a harmless copy
    packet.rays.set(k, rays[static_cast<size_t>(k < n ? k : 0)]);
    const RayStart start = starts.empty() || k >= n ? RayStart{} : starts[static_cast<size_t>(k)];
    packet.inside[k] = start.inside, packet.on[k] = start.on;
  }
  HitPacket out;
  intersect(packet, (1u << n) - 1, out, tMin);
  for (int k = 0; k < n; ++k) {
    Hit& hit = hits[static_cast<size_t>(k)];
    hit.object = out.object[k];
    if (hit.object < 0) continue;
    hit.t = out.t[k];
    hit.normal = out.normal(k);
    hit.point = rays[static_cast<size_t>(k)].at(hit.t);
  }
}

void Scene::intersect(const RayPacket& packet, std::uint32_t lanes, HitPacket& hits, double tMin) const {
  constexpr int kLanes = static_cast<int>(kPacket);
  lanes &= (1u << kLanes) - 1;
  std::fill_n(hits.t, kLanes, std::numeric_limits<double>::infinity());
  std::fill_n(hits.object, kLanes, -1);
  HitContext ctx;
  rtcInitIntersectContext(&ctx.embree);
  ctx.rays = &packet.rays, ctx.tMin = tMin, ctx.best = &hits;
  ctx.objects = 0;
  // Rays starting inside an isolated solid's box: the solid's nearest crossing,
  // if any, comes before every other object's surface (those lie outside the
  // box, and the ray stays in the box up to the crossing, which is in it), so
  // the solid answers without a traversal. Rays that do not cross it go on to
  // Embree. The hint only picks which rays to try: the answer is the same.
  std::uint32_t tried = 0;
  const size_t objects = objects_.size();
  for (std::uint32_t bits = lanes; bits; bits &= bits - 1) {
    const int k = std::countr_zero(bits);
    const int object = packet.inside[k];
    if (static_cast<size_t>(object + 1) > objects || static_cast<size_t>(packet.on[k] + 1) > objects)
      fail(Errc::InvalidArgument, "Scene::intersect: lane {} starts inside object {} on object {}, of {} objects", k,
           object, packet.on[k], objects);
    const AnalyticGeometry* g = object >= 0 ? impl_->isolated[static_cast<size_t>(object)] : nullptr;
    if (g && contains(g->box, packet.rays.ray(k).origin)) {
      noteLanes(ctx, g, 1u << k);
      tried |= 1u << k;
    }
  }
  resolveLanes(ctx);
  std::uint32_t traced = lanes;
  for (std::uint32_t bits = tried; bits; bits &= bits - 1)
    if (const int k = std::countr_zero(bits); hits.object[k] >= 0) traced &= ~(1u << k);
  if (traced == 0) return;
  // A ray leaving a convex solid (from its surface, outside it) cannot cross it
  // again beyond tMin: its lane skips that solid.
  const AnalyticGeometry* skip[kPacket];
  for (int k = 0; k < kLanes; ++k) {
    const int on = packet.on[k];
    skip[k] = (traced >> k & 1) && on >= 0 && on != packet.inside[k] ? impl_->convex[static_cast<size_t>(on)] : nullptr;
  }
  ctx.skip = skip;
  // Incoherent: with few objects, Embree's per-ray traversal of the packet beats
  // its packet traversal (measured: 17 % of a render of the reference scene).
  ctx.embree.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  alignas(64) int valid[kPacket];
  alignas(64) double start[kPacket];
  alignas(64) RTCRayHit16 rh;
  embreePacket(packet.rays, traced, tMin, impl_->centre, impl_->radius, valid, start, rh);
  rtcIntersect16(valid, impl_->scene, &ctx.embree, &rh);
  resolveLanes(ctx);
  if (!impl_->meshes) return;
  for (std::uint32_t bits = traced; bits; bits &= bits - 1)
    if (const int k = std::countr_zero(bits); rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID)
      meshHit(k, {packet.rays.dx[k], packet.rays.dy[k], packet.rays.dz[k]}, rh.hit.geomID[k], rh.hit.primID[k],
              start[k] + rh.ray.tfar[k], {rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]}, rh.hit.u[k], rh.hit.v[k],
              hits);
}

void Scene::meshHit(int k, const Vec3& direction, unsigned geomID, unsigned primID, double tfar, const Vec3& ng,
                    float u, float v, HitPacket& hits) const {
  if (!(tfar <= hits.t[k])) return;  // an analytic object is nearer (or tMax is); a tie goes to keepNearest
  Vec3 normal = ng.normalized();
  const Object& obj = objects_[geomID];
  const auto& mesh = std::get<TriangleMesh>(obj.shape);
  if (!mesh.normals.empty()) {
    const auto& tri = mesh.triangles[primID];
    const Vec3 n = mesh.normals[tri[0]] * (1.0 - u - v) + mesh.normals[tri[1]] * u + mesh.normals[tri[2]] * v;
    const Vec3 shading = obj.worldFromObject.vector(n).normalized();
    // The interpolated normal where it is on the geometric normal's side and
    // the ray meets both from the same side: whether a path enters or leaves
    // the mesh is the surface's geometry (d·n), which a smoothed normal near a
    // silhouette could turn round.
    if (shading.dot(normal) > 0 && (shading.dot(direction) < 0) == (normal.dot(direction) < 0)) normal = shading;
  }
  keepNearest(hits, k, tfar, normal, static_cast<int>(geomID));
}

bool Scene::isolated(int index) const {
  return impl_->isolated[static_cast<size_t>(index)] != nullptr;
}

const Rigid3& Scene::objectFromWorld(int index) const {
  return impl_->objectFromWorld[static_cast<size_t>(index)];
}

}  // namespace lfi::sim

namespace lfi::sim {

void Scene::setEmission(int index, std::optional<Emission> emission) {
  if (index < 0 || static_cast<size_t>(index) >= objects_.size())
    fail(Errc::InvalidArgument, "Scene::setEmission: object {} of {}", index, objects_.size());
  objects_[static_cast<size_t>(index)].emission = std::move(emission);
  surfaces_[static_cast<size_t>(index)] = surfaceOf(objects_[static_cast<size_t>(index)]);
}

}  // namespace lfi::sim
