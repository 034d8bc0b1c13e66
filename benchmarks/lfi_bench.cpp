// SPDX-License-Identifier: Apache-2.0
// lfi-bench: the ray tracer's throughput on the reference scene, next to the
// raw Embree bound measured in the same run.
//
//   tracer   samples/s of lfi::sim::render on data/scenes/reference.toml
//            (analytic lens, Fresnel sampling), 1 thread and all threads;
//            also the reference scene's lens under the study's three
//            illuminations (the study's own bench is another lens).
//   bound    bare Embree rays/s, 1 thread, for the same rays (the refraction
//            paths of the same camera samples, sixteen at a time in the order
//            the tracer makes them; a packet may hold two segments of a path,
//            which the tracer's never do; every segment, also those the tracer
//            answers without Embree inside the lens) and the same back light:
//            rtcIntersect1 and rtcIntersect16
//            with the lens as a fine triangle mesh, and rtcIntersect16 with
//            the lens and the back light as user primitives whose callbacks do
//            nothing, coherent and incoherent (the traversal alone: the floor
//            of any Embree tracer of this scene).
//   ratio    the tracer's time per ray over the fastest bound's: what the
//            exact intersection, the shading and the sampling cost on top.
//            Also per sample against the incoherent no-op bound on only the
//            rays the tracer sends to Embree (1.55 of a sample's 2.09: it
//            answers the others inside the lens itself), the stricter reading.
//   queries  the tracer's own ray queries (Scene::intersect: Embree, the exact
//            crossings, the lens answering the rays inside it) on the same rays
//            in the same sixteens, each with where it starts; checked against
//            the one-ray query first. Its ratio to the tracer is what the
//            sampling, the shading and the bookkeeping cost on top.
//   ceiling  samples/s on all threads if the fastest bound were all the work
//            (scaled as the machine's independent renders scale).
//   scaling  1 thread to all threads, next to the machine's own bound: as many
//            independent 1-thread renders at once as there are threads (no
//            parallel render can do better than copies sharing nothing).
//
// The triangle bounds' scene is built in this file (the lens tessellated, the
// back light a quad); before any timing it must answer the recorded rays as the
// scene of reference.toml does, or the bench fails: a changed scene file is
// not silently bounded by the old scene. The no-op bounds' boxes are the
// scene's own (worldBounds).
//
// Everything runs in turns (one run of each per turn). Speeds are the best
// run's; ratios (scaling, bound, queries) are the median of the turns' ratios,
// with their range: a turn's two ends ran one after the other on the same
// machine load (bench_util.h).
//
// Usage: lfi-bench [--quick]   (quick: smaller images, for a smoke run)
//        lfi-bench --rmse A.exr B.exr
//            relative RMS difference of two EXR images of any origin (luminance,
//            (R+G+B)/3), for the time-to-equal-error comparison in
//            scripts/compare-cycles.sh.

#include "lfi/core/error.h"
#include "lfi/core/light_field.h"
#include "lfi/sim/render.h"
#include "lfi/sim/scene_file.h"

#include "bench_util.h"

#include <OpenEXR/ImfRgbaFile.h>
#include <embree3/rtcore.h>
#include <fmt/format.h>
#include <tbb/info.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>
#include <stdexcept>
#include <thread>

using namespace lfi;
using namespace lfi::sim;

using lfi::bench::bestOf;
using lfi::bench::bestSeconds;
using lfi::bench::bestSecondsInTurns;
using lfi::bench::ratiosByTurn;
using lfi::bench::secondsInTurns;
using lfi::bench::spreadOf;

namespace {

// The lens surface as triangles: both spherical caps on a polar grid and the
// edge cylinder, wound outwards.
TriangleMesh tessellateLens(double r1, double r2, double tc, double diameter, int rings, int sectors) {
  TriangleMesh m;
  const double a = diameter / 2;
  auto sag = [](double radius, double r) {
    return radius == 0 ? 0.0 : radius - (radius > 0 ? 1 : -1) * std::sqrt(radius * radius - r * r);
  };
  auto cap = [&](double radius, double z0, bool front) {
    const auto base = static_cast<unsigned>(m.vertices.size());
    m.vertices.push_back({0, 0, z0});
    for (int i = 1; i <= rings; ++i)
      for (int k = 0; k < sectors; ++k) {
        const double r = a * i / rings, phi = 2 * std::numbers::pi * k / sectors;
        m.vertices.push_back({r * std::cos(phi), r * std::sin(phi), z0 + sag(radius, r)});
      }
    auto idx = [&](int ring, int k) { return ring == 0 ? base : base + 1 + (ring - 1) * sectors + (k % sectors); };
    for (int i = 0; i < rings; ++i)
      for (int k = 0; k < sectors; ++k) {
        std::array<unsigned, 3> t1{idx(i, k), idx(i + 1, k), idx(i + 1, k + 1)};
        std::array<unsigned, 3> t2{idx(i, k), idx(i + 1, k + 1), idx(i, k + 1)};
        if (front) std::swap(t1[1], t1[2]), std::swap(t2[1], t2[2]);
        m.triangles.push_back(t1);
        if (i > 0) m.triangles.push_back(t2);
      }
    return base + 1 + (rings - 1) * sectors;  // first vertex of the rim
  };
  const unsigned frontRim = cap(r1, -tc / 2, true), backRim = cap(r2, tc / 2, false);
  for (int k = 0; k < sectors; ++k) {
    const unsigned f0 = frontRim + k, f1 = frontRim + (k + 1) % sectors, b0 = backRim + k,
                   b1 = backRim + (k + 1) % sectors;
    m.triangles.push_back({f0, f1, b1});
    m.triangles.push_back({f0, b1, b0});
  }
  return m;
}

struct RayBatch {
  std::vector<RTCRayHit> rays;
  std::vector<Ray> exact;                       // the same rays in double precision
  std::vector<int> startInside, startOn;        // and where they start (Scene::RayPacket)
  std::vector<std::pair<size_t, int>> packets;  // first ray and count: one segment of a group of samples
  double samples = 0;
};

// The rays the tracer follows for these camera samples (refraction branch),
// ordered as its packets see them: per group of 16 consecutive samples, the
// first segments of all 16, then the second segments, and so on.
RayBatch recordRays(const Scene& scene, const TelecentricCamera& cam, int spp) {
  RayBatch batch;
  Sampler sampler(7, 0);
  std::vector<std::vector<Vec3>> group;
  std::vector<int> on;       // per path of the group: the object its current segment leaves from
  std::vector<Vec3> normal;  // and that object's outward normal there
  auto flush = [&] {
    on.assign(group.size(), -1);
    normal.assign(group.size(), Vec3(0));
    for (size_t segment = 0;; ++segment) {
      bool any = false;
      batch.packets.push_back({batch.exact.size(), 0});
      for (size_t p = 0; p < group.size(); ++p) {
        const auto& path = group[p];
        if (segment + 1 >= path.size()) continue;
        any = true;
        const Vec3 d = (path[segment + 1] - path[segment]).normalized();
        batch.exact.push_back({path[segment], d});
        ++batch.packets.back().second;
        // Inside the dielectric it leaves from if it goes into it (refracted in,
        // or totally reflected inside); the scene nests none.
        batch.startInside.push_back(on[p] >= 0 && d.dot(normal[p]) < 0 ? on[p] : -1);
        batch.startOn.push_back(on[p]);
        const Hit hit = scene.intersect(Ray{path[segment], d});
        on[p] = hit.object;
        normal[p] = hit.normal;
        RTCRayHit rh{};
        rh.ray.org_x = static_cast<float>(path[segment].x), rh.ray.org_y = static_cast<float>(path[segment].y);
        rh.ray.org_z = static_cast<float>(path[segment].z);
        rh.ray.dir_x = static_cast<float>(d.x), rh.ray.dir_y = static_cast<float>(d.y);
        rh.ray.dir_z = static_cast<float>(d.z);
        rh.ray.tnear = 1e-4f;
        rh.ray.mask = 0xffffffffu;
        batch.rays.push_back(rh);
      }
      if (!any) break;
    }
    group.clear();
  };
  for (int j = 0; j < cam.height; ++j)
    for (int i = 0; i < cam.width; ++i)
      for (int s = 0; s < spp; ++s) {
        const double u = std::sqrt(sampler.next()), phi = 2 * std::numbers::pi * sampler.next();
        const Ray ray = cam.ray(i, j, {sampler.next(), sampler.next()}, {u * std::cos(phi), u * std::sin(phi)});
        group.push_back(refractionPath(scene, ray, 64, 1e4));
        batch.samples += 1;
        if (group.size() == 16) flush();
      }
  flush();
  return batch;
}

}  // namespace

// Mean of (R+G+B)/3 per pixel of any EXR that OpenEXR's RGBA interface reads
// (luminance-only files come back as R = G = B = Y) whose data window starts
// at (0, 0), as lfi's and Blender's do.
std::vector<double> readLuminance(const char* path, int& width, int& height) {
  Imf::RgbaInputFile file(path);
  const Imath::Box2i dw = file.dataWindow();
  if (dw.min.x != 0 || dw.min.y != 0)
    throw std::runtime_error(
        fmt::format("{}: its data window starts at ({}, {}), not (0, 0)", path, dw.min.x, dw.min.y));
  width = dw.max.x + 1;
  height = dw.max.y + 1;
  std::vector<Imf::Rgba> pixels(static_cast<size_t>(width) * static_cast<size_t>(height));
  file.setFrameBuffer(pixels.data(), 1, static_cast<size_t>(width));
  file.readPixels(dw.min.y, dw.max.y);
  std::vector<double> y;
  y.reserve(pixels.size());
  for (const auto& p : pixels)
    y.push_back((static_cast<float>(p.r) + static_cast<float>(p.g) + static_cast<float>(p.b)) / 3.0);
  return y;
}

int rmse(const char* a, const char* b) {
  int wa = 0, ha = 0, wb = 0, hb = 0;
  const auto ya = readLuminance(a, wa, ha), yb = readLuminance(b, wb, hb);
  if (wa != wb || ha != hb) {
    fmt::print(stderr, "lfi-bench: {} is {}x{} but {} is {}x{}\n", a, wa, ha, b, wb, hb);
    return 1;
  }
  double sq = 0, mean = 0;
  for (size_t k = 0; k < ya.size(); ++k) {
    sq += (ya[k] - yb[k]) * (ya[k] - yb[k]);
    mean += yb[k];
  }
  mean /= static_cast<double>(yb.size());
  if (!(mean > 0) || !std::isfinite(mean)) {  // (the RMSE is relative to B's mean)
    fmt::print(stderr, "lfi-bench: {} has mean {}: no relative RMSE against it\n", b, mean);
    return 1;
  }
  fmt::print("rmse_rel={:.6f}\n", std::sqrt(sq / static_cast<double>(ya.size())) / mean);
  return 0;
}

static int run(int argc, char** argv) {
  bool quick = false;
  std::vector<std::string> compared;
  CLI::App app("lfi-bench: the ray tracer's throughput next to the raw Embree bound measured in the same run");
  app.add_flag("--quick", quick, "Smaller images, for a smoke run");
  app.add_option("--rmse", compared, "Only the relative RMS difference of two EXR images A and B")
      ->expected(2)
      ->check(CLI::ExistingFile)
      ->excludes(app.get_option("--quick"));
  CLI11_PARSE(app, argc, argv);
  if (!compared.empty()) return rmse(compared[0].c_str(), compared[1].c_str());
  const int threads = tbb::info::default_concurrency();
  SceneDescription d = loadSceneFile(std::filesystem::path(LFI_SOURCE_DIR) / "data" / "scenes" / "reference.toml");
  auto cam = std::get<TelecentricCamera>(d.sensor);
  if (quick) {
    cam.width = cam.height = 128;
    cam.pixelPitch_mm *= 4;
  }
  const Scene scene(d.objects, d.ambientIor);
  RenderOptions ro = d.render;
  const int repeats = quick ? 1 : 3;

  fmt::print("lfi-bench: reference scene {}x{}, {} spp, Fresnel split depth {}, {} hardware threads\n", cam.width,
             cam.height, ro.samplesPerPixel, ro.splitDepth, threads);
  const double samples = static_cast<double>(cam.width) * cam.height * ro.samplesPerPixel;
  // 1 thread and all threads in turns, so that the machine's load weighs on the scaling's both ends alike.
  auto renderWith = [&](const Scene& s, int t) {
    return [&s, &cam, ro, t]() mutable {
      ro.threads = t;
      render(s, cam, ro);
    };
  };
  // Speeds are the best run's; ratios the median of the turns' ratios (a
  // ratio's two ends ran one after the other: lfi::bench::ratiosByTurn).
  // The machine's own bound on the scaling: as many 1-thread renders as there
  // are hardware threads, each on its own thread, sharing nothing but the
  // (read-only) scene. No parallel render of one image can scale better than
  // independent copies of it; on a VM whose cores share a physical core's
  // pipeline or clock budget, they scale by less than the thread count.
  auto independentCopies = [&] {
    std::vector<std::thread> copies;
    for (int c = 0; c < threads; ++c) copies.emplace_back(renderWith(scene, 1));
    for (auto& copy : copies) copy.join();
  };
  const int turns = quick ? 3 : 7;
  const auto scalingRuns = secondsInTurns(turns, {renderWith(scene, 1), renderWith(scene, threads), independentCopies});
  for (size_t i = 0; i < 2; ++i)
    fmt::print("  tracer   {} thread(s): {:8.3f} M samples/s\n", i ? threads : 1,
               samples / bestOf(scalingRuns, i) / 1e6);
  std::vector<double> machineScaling, scalingShare;
  for (const auto& turn : scalingRuns) {
    machineScaling.push_back(threads * turn[0] / turn[2]);
    scalingShare.push_back(turn[0] / turn[1] / machineScaling.back());
  }
  const auto scaling = spreadOf(ratiosByTurn(scalingRuns, 0, 1)), machine = spreadOf(machineScaling),
             share = spreadOf(scalingShare);
  fmt::print("  scaling  1 -> {} threads: {:.2f}x (median of {} turns; {:.2f}-{:.2f}; target >= 1.8)\n", threads,
             scaling.median, turns, scaling.low, scaling.high);
  fmt::print(
      "  bound    {} independent 1-thread renders at once: {:.2f}x one's throughput (median; {:.2f}-{:.2f}: "
      "the machine's own scaling)\n",
      threads, machine.median, machine.low, machine.high);
  fmt::print("  ratio    tracer's scaling / the machine's: {:.2f} (median of {} turns; {:.2f}-{:.2f})\n", share.median,
             turns, share.low, share.high);

  // The study's three illuminations behind the same lens and camera: a
  // collimated back light (0.0087 rad), the Lambertian one above, and a light
  // field display 60 mm below the lens showing the light field captured there.
  {
    const Object lensObject = d.objects[0];
    LightFieldGeometry g;
    g.spatialX = g.spatialY = 40;
    g.angular = 16;
    g.pixelPitch_mm = 0.1;  // 1.6 mm elements over 64 mm
    g.distance_mm = 60;
    std::vector<Object> captureObjects{lensObject};
    Rigid3 down = Rigid3::rotation({1, 0, 0}, std::numbers::pi);
    down.t = {0, 0, 100};
    captureObjects.push_back({"beam", Rectangle{200, 200}, down, Absorber{}, ParallelEmission{1, 0.0087}});
    RenderOptions capture;
    capture.samplesPerPixel = quick ? 4 : 16;
    auto lightField = std::make_shared<LightField>(
        g, render(Scene(std::move(captureObjects)), LightFieldSensor{g, Rigid3::translation({0, 0, -60})}, capture));
    const std::vector<std::pair<std::string, Object>> lights = {
        {"parallel",
         {"light", Rectangle{400, 400}, Rigid3::translation({0, 0, -100}), Absorber{}, ParallelEmission{1, 0.0087}}},
        {"area", d.objects[1]},
        {"inverse_schlieren",
         {"display", Rectangle{g.extentX_mm(), g.extentY_mm()}, Rigid3::translation({0, 0, -60}), Absorber{},
          LightFieldEmission{lightField, LightFieldLookup::Nearest}}}};
    for (const auto& [name, light] : lights) {
      const Scene lit(std::vector<Object>{lensObject, light});
      const std::vector<double> sec = bestSecondsInTurns(repeats, {renderWith(lit, 1), renderWith(lit, threads)});
      for (int i = 0; i < 2; ++i)
        fmt::print("  study    {:<18} {} thread(s): {:8.3f} M samples/s\n", name, i ? threads : 1,
                   samples / sec[static_cast<size_t>(i)] / 1e6);
    }
  }

  // The bound: bare Embree on the same rays.
  TelecentricCamera small = cam;
  small.width = small.height = 128;
  small.pixelPitch_mm = cam.pixelPitch_mm * cam.width / 128.0;
  RayBatch batch = recordRays(scene, small, quick ? 2 : 8);
  const double raysPerSample = static_cast<double>(batch.rays.size()) / batch.samples;
  RTCDevice device = rtcNewDevice(nullptr);
  if (device == nullptr)
    throw std::runtime_error(
        fmt::format("embree: cannot create a device (error {})", static_cast<int>(rtcGetDeviceError(nullptr))));
  RTCScene raw = rtcNewScene(device);
  const TriangleMesh lens = tessellateLens(100, -100, 7, 50, 256, 512);
  {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), lens.vertices.size()));
    for (size_t k = 0; k < lens.vertices.size(); ++k)
      for (int c = 0; c < 3; ++c) v[3 * k + c] = static_cast<float>(lens.vertices[k][c]);
    auto* t = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned), lens.triangles.size()));
    for (size_t k = 0; k < lens.triangles.size(); ++k)
      for (int c = 0; c < 3; ++c) t[3 * k + c] = lens.triangles[k][c];
    rtcCommitGeometry(g);
    rtcAttachGeometry(raw, g);
    rtcReleaseGeometry(g);
    RTCGeometry q = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_QUAD);
    auto* qv = static_cast<float*>(
        rtcSetNewGeometryBuffer(q, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4));
    const float corners[12] = {-200, -200, -100, 200, -200, -100, 200, 200, -100, -200, 200, -100};
    std::memcpy(qv, corners, sizeof(corners));
    auto* qi = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(q, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4, 4 * sizeof(unsigned), 1));
    qi[0] = 0, qi[1] = 1, qi[2] = 2, qi[3] = 3;
    rtcCommitGeometry(q);
    rtcAttachGeometry(raw, q);
    rtcReleaseGeometry(q);
  }
  rtcCommitScene(raw);
  std::vector<RTCRayHit> work = batch.rays;
  auto intersectAll = [&](RTCScene target) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t k = 0; k < batch.rays.size(); ++k) {
      work[k] = batch.rays[k];
      work[k].ray.tfar = std::numeric_limits<float>::infinity();
      work[k].hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(target, &ctx, &work[k]);
    }
  };
  // The same rays as packets of 16, in recording order (neighbouring samples' segments).
  std::vector<RTCRay> allRays, embreeRays;  // every segment; those the tracer sends to Embree
  for (size_t k = 0; k < batch.rays.size(); ++k) {
    allRays.push_back(batch.rays[k].ray);
    if (batch.startInside[k] < 0) embreeRays.push_back(batch.rays[k].ray);
  }
  auto intersectPackets = [&](RTCScene target, RTCIntersectContextFlags flags, const std::vector<RTCRay>& rays) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = flags;
    alignas(64) RTCRayHit16 p;
    alignas(64) int valid[16];
    for (size_t k0 = 0; k0 < rays.size(); k0 += 16) {
      for (int k = 0; k < 16; ++k) {
        const size_t i = std::min(k0 + static_cast<size_t>(k), rays.size() - 1);
        const RTCRay& r = rays[i];
        valid[k] = k0 + static_cast<size_t>(k) < rays.size() ? -1 : 0;  // (and tfar < tnear: scene.cpp)
        p.ray.org_x[k] = r.org_x, p.ray.org_y[k] = r.org_y, p.ray.org_z[k] = r.org_z;
        p.ray.dir_x[k] = r.dir_x, p.ray.dir_y[k] = r.dir_y, p.ray.dir_z[k] = r.dir_z;
        p.ray.tnear[k] = r.tnear, p.ray.tfar[k] = valid[k] ? std::numeric_limits<float>::infinity() : -1.0f;
        p.ray.time[k] = 0, p.ray.mask[k] = 0xffffffffu, p.ray.id[k] = static_cast<unsigned>(k), p.ray.flags[k] = 0;
        p.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      }
      rtcIntersect16(valid, target, &ctx, &p);
    }
  };
  const double n = static_cast<double>(batch.rays.size());
  // The bounds' scenes are built here, not from reference.toml: their answers
  // must be the tracer's, or a changed scene file would be bounded by another
  // scene. The triangle lens (geometry 0) and the quad (1) against the scene's
  // objects 0 (the lens) and 1 (the back light), ray by ray: the same object,
  // and the same distance within the tessellation's error. (A ray that starts
  // on the lens starts 0.01 mm on here: the exact surface lies up to 5e-4 mm
  // off the triangles' chords, which such a ray would otherwise meet again.)
  {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    size_t differ = 0;
    for (size_t k = 0; k < batch.rays.size(); ++k) {
      RTCRayHit rh = batch.rays[k];
      if (batch.startOn[k] >= 0) rh.ray.tnear = 0.01f;
      rh.ray.tfar = std::numeric_limits<float>::infinity();
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(raw, &ctx, &rh);
      const Hit exact = scene.intersect(batch.exact[k]);
      const int object = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? -1 : static_cast<int>(rh.hit.geomID);
      if (object != exact.object || (exact.valid() && std::abs(rh.ray.tfar - exact.t) > 0.01)) ++differ;
    }
    if (differ > batch.rays.size() / 1000)
      throw std::runtime_error(
          fmt::format("self-check: the bounds' lens and back light answer {} of {} rays unlike "
                      "the scene of reference.toml (are its lens and back light still R = 100, "
                      "Ø50, 7 mm at the origin and 400 x 400 at z = -100?)",
                      differ, batch.rays.size()));
    fmt::print("  check    the bounds' triangle lens and quad answer as the scene: {} of {} rays differ (grazing)\n",
               differ, batch.rays.size());
  }
  // Embree's own share of the tracer's query: the lens and the back light as
  // user primitives (as the tracer has them) whose callbacks do nothing, so
  // that only the traversal and the callback dispatch are timed; packets
  // traced coherently and incoherently (the tracer's mode).
  RTCScene hull = rtcNewScene(device);
  // Their boxes: the scene's own lens and back light (worldBounds, as the tracer gives them to
  // Embree), a micrometre wider.
  std::array<RTCBounds, 2> hullBounds;
  for (size_t i = 0; i < 2; ++i) {
    const Bounds b = worldBounds(d.objects[i]);
    hullBounds[i] = {
        static_cast<float>(b.lo.x - 1e-3), static_cast<float>(b.lo.y - 1e-3), static_cast<float>(b.lo.z - 1e-3), 0,
        static_cast<float>(b.hi.x + 1e-3), static_cast<float>(b.hi.y + 1e-3), static_cast<float>(b.hi.z + 1e-3), 0};
  }
  for (RTCBounds& bounds : hullBounds) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, 1);
    rtcSetGeometryUserData(g, &bounds);
    rtcSetGeometryBoundsFunction(
        g,
        [](const RTCBoundsFunctionArguments* args) {
          *args->bounds_o = *static_cast<const RTCBounds*>(args->geometryUserPtr);
        },
        nullptr);
    rtcSetGeometryIntersectFunction(g, [](const RTCIntersectFunctionNArguments*) {});
    rtcCommitGeometry(g);
    rtcAttachGeometry(hull, g);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(hull);
  // The tracer's own ray queries on the same rays, with where each starts:
  // Embree's traversal, the exact crossings of the lens and the back light,
  // and the lens answering the rays inside it (Scene::intersect).
  auto queryAll = [&](const std::function<void(size_t, const Scene::HitPacket&, int)>& check) {
    Scene::RayPacket packet;
    Scene::HitPacket hits;
    for (const auto& [k0, lanes] : batch.packets) {
      for (int k = 0; k < lanes; ++k) {
        packet.rays.set(k, batch.exact[k0 + static_cast<size_t>(k)]);
        packet.inside[k] = batch.startInside[k0 + static_cast<size_t>(k)];
        packet.on[k] = batch.startOn[k0 + static_cast<size_t>(k)];
      }
      if (lanes > 0) scene.intersect(packet, (1u << lanes) - 1, hits);
      if (check) check(k0, hits, lanes);
    }
  };
  size_t hitCount = 0;  // the queries must answer as the one-ray query, or the bound means nothing
  queryAll([&](size_t k0, const Scene::HitPacket& hits, int lanes) {
    for (int k = 0; k < lanes; ++k) {
      const Hit one = scene.intersect(batch.exact[k0 + static_cast<size_t>(k)]);
      if (hits.object[k] != one.object || (one.valid() && std::abs(hits.t[k] - one.t) > 1e-9))
        fail(Errc::InvalidArgument, "lfi-bench: the packet query of ray {} differs from the one-ray query",
             k0 + static_cast<size_t>(k));
      hitCount += one.valid();
    }
  });
  // The bounds and the tracer on 1 thread in turns, so that their ratios see
  // the same machine. A bound's pass over the rays is short: it is repeated to
  // last about a quarter of a render, so that both ends of a ratio span a
  // similar stretch of the host's load.
  const double renderSeconds = bestSeconds(1, renderWith(scene, 1));
  std::vector<double> passes;  // each bound's passes per timed run
  auto repeated = [&](std::function<void()> pass) {
    const double once = bestSeconds(1, pass);
    const double count = std::clamp(std::round(0.25 * renderSeconds / once), 1.0, 1000.0);
    passes.push_back(count);
    return [pass, count] {
      for (double i = 0; i < count; ++i) pass();
    };
  };
  const auto runs = secondsInTurns(
      turns, {renderWith(scene, 1), repeated([&] { intersectAll(raw); }),
              repeated([&] { intersectPackets(raw, RTC_INTERSECT_CONTEXT_FLAG_COHERENT, allRays); }),
              repeated([&] { intersectPackets(hull, RTC_INTERSECT_CONTEXT_FLAG_COHERENT, allRays); }),
              repeated([&] { intersectPackets(hull, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, allRays); }),
              repeated([&] { queryAll(nullptr); }),
              repeated([&] { intersectPackets(hull, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, embreeRays); })});
  rtcReleaseScene(hull);
  const double tracerRays = samples * raysPerSample;  // rays per render
  // Rays per second of run i in one turn, and at its best (run 6 traces only the Embree rays).
  auto raysOf = [&](size_t i) {
    return i == 0 ? tracerRays : (i == 6 ? static_cast<double>(embreeRays.size()) : n) * passes[i - 1];
  };
  auto speed = [&](const std::vector<double>& turn, size_t i) { return raysOf(i) / turn[i]; };
  auto best = [&](size_t i) { return raysOf(i) / bestOf(runs, i); };
  fmt::print("  bound    1 thread:  {:8.3f} M rays/s  (bare Embree rtcIntersect1, lens as {} triangles)\n",
             best(1) / 1e6, lens.triangles.size());
  fmt::print("  bound    1 thread:  {:8.3f} M rays/s  (bare Embree rtcIntersect16, same rays and triangles)\n",
             best(2) / 1e6);
  fmt::print(
      "  bound    1 thread:  {:8.3f} M rays/s  (bare Embree rtcIntersect16, lens and back light as no-op user "
      "primitives, coherent)\n",
      best(3) / 1e6);
  fmt::print("  bound    1 thread:  {:8.3f} M rays/s  (the same, incoherent: the tracer's mode)\n", best(4) / 1e6);
  fmt::print("  tracer   1 thread:  {:8.3f} M rays/s  ({:.2f} rays per sample; timed in turns with the bounds)\n",
             best(0) / 1e6, raysPerSample);
  // Per turn: the fastest bound, and the tracer's own queries, over the tracer.
  // The Embree-only bound per sample: the rays the tracer sends to Embree for one sample (it answers the
  // others inside the lens itself), at that bound's speed.
  const double embreeRaysPerSample = static_cast<double>(embreeRays.size()) / batch.samples;
  std::vector<double> boundRatio, queryRatio, embreeRatio;
  for (const auto& turn : runs) {
    boundRatio.push_back(std::max({speed(turn, 1), speed(turn, 2), speed(turn, 3), speed(turn, 4)}) / speed(turn, 0));
    queryRatio.push_back(speed(turn, 5) / speed(turn, 0));
    embreeRatio.push_back((speed(turn, 6) / embreeRaysPerSample) / (speed(turn, 0) / raysPerSample));
  }
  const auto bound = spreadOf(boundRatio), queries = spreadOf(queryRatio), embree = spreadOf(embreeRatio);
  fmt::print(
      "  ratio    bound / tracer per ray, 1 thread: {:.2f} (median of {} turns; {:.2f}-{:.2f}; bound: the "
      "fastest of the above in each turn, Embree with no exact crossings)\n",
      bound.median, turns, bound.low, bound.high);
  fmt::print(
      "  bound    1 thread:  {:8.3f} M rays/s  (no-op user primitives, incoherent, only the {:.2f} rays per "
      "sample the tracer sends to Embree)\n",
      best(6) / 1e6, embreeRaysPerSample);
  fmt::print("  ratio    that bound / tracer per sample, 1 thread: {:.2f} (median of {} turns; {:.2f}-{:.2f})\n",
             embree.median, turns, embree.low, embree.high);
  fmt::print(
      "  queries  1 thread:  {:8.3f} M rays/s  (the tracer's own ray queries, Scene::intersect, same rays and "
      "packets; {:.0f} % hit)\n",
      best(5) / 1e6, 100.0 * static_cast<double>(hitCount) / n);
  fmt::print(
      "  ratio    queries / tracer per ray, 1 thread: {:.2f} (median of {} turns; {:.2f}-{:.2f}; what "
      "sampling, shading and bookkeeping add; accepted at about 2)\n",
      queries.median, turns, queries.low, queries.high);
  fmt::print(
      "  ceiling  {} threads at the fastest bound: {:.1f} M samples/s (Embree alone, zero shading, scaled as the "
      "machine's independent renders)\n",
      threads, std::max({best(1), best(2), best(3), best(4)}) * machine.median / raysPerSample / 1e6);
  rtcReleaseScene(raw);
  rtcReleaseDevice(device);
  return 0;
}

int main(int argc, char** argv) {
  return lfi::bench::runGuarded("lfi-bench", [&] { return run(argc, argv); });
}
