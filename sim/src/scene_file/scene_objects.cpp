// SPDX-License-Identifier: Apache-2.0
// [[object]] tables: the shape (a solid with its spherical cut-outs, a
// rectangle or a mesh file), the material and the emitter.

#include "lfi/sim/scene_file.h"

#include "lfi/core/config.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"

#include "scene_file_internal.h"

#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

namespace lfi::sim {

namespace fs = std::filesystem;

const char* lensKey(LensFault::Part part) {
  switch (part) {
    case LensFault::Part::Thickness:
      return "centre_thickness_mm";
    case LensFault::Part::Diameter:
      return "diameter_mm";
    case LensFault::Part::FrontRadius:
      return "front_radius_mm";
    case LensFault::Part::BackRadius:
      return "back_radius_mm";
    case LensFault::Part::Edge:
      return "centre_thickness_mm";
  }
  return "diameter_mm";
}

namespace {

// Whether any of the kGridLines x kGridLines lines along x, along y and along
// z across `box` meets `solid`: after its cut-outs, a part none of them meets
// is gone (or a chip under 1/kGridLines of its box).
constexpr int kGridLines = 33;
bool meetsLines(const Solid& solid, const Bounds& box) {
  IntervalList found;
  for (int axis = 0; axis < 3; ++axis)
    for (int i = 0; i < kGridLines; ++i)
      for (int j = 0; j < kGridLines; ++j) {
        const double u = (i + 0.5) / kGridLines, v = (j + 0.5) / kGridLines;
        const double lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};
        double o[3], d[3] = {0, 0, 0};
        const int a = (axis + 1) % 3, b = (axis + 2) % 3;
        o[axis] = lo[axis];
        o[a] = lo[a] + u * (hi[a] - lo[a]);
        o[b] = lo[b] + v * (hi[b] - lo[b]);
        d[axis] = 1;
        solid.intervals(Ray{{o[0], o[1], o[2]}, {d[0], d[1], d[2]}}, found);
        if (found.size() > 0) return true;
      }
  return false;
}

// The least size of a solid or a cut-out, 1 µm: a thousand times the tracer's
// least hit distance (Scene::kTMin), so that a ray crossing the thinnest part
// still meets both of its surfaces.
constexpr double kSmallest_mm = 1e-3;

std::shared_ptr<const Solid> readSolid(ConfigTable& t, const std::string& kind) {
  if (kind == "sphere") return Solid::sphere(t.number("radius_mm", std::nullopt, kSmallest_mm, 1e6));
  if (kind == "lens") {
    const double r1 = t.number("front_radius_mm", std::nullopt, -1e6, 1e6);
    const double r2 = t.number("back_radius_mm", std::nullopt, -1e6, 1e6);
    const double tc = t.number("centre_thickness_mm", std::nullopt, kSmallest_mm, 1e6);
    const double diameter = t.number("diameter_mm", std::nullopt, kSmallest_mm, 1e6);
    if (const auto fault = sphericalLensFault(r1, r2, tc, diameter))
      fail(Errc::Config, "{}: {}", t.where(lensKey(fault->part)), fault->why);
    return Solid::sphericalLens(r1, r2, tc, diameter);
  }
  if (kind == "cylinder") {
    // A finite cylinder along z, centred: the infinite one cut by two planes.
    const double r = t.number("radius_mm", std::nullopt, kSmallest_mm, 1e6);
    const double h = t.number("length_mm", std::nullopt, kSmallest_mm, 1e6);
    Rigid3 top = Rigid3::translation({0, 0, h / 2});
    Rigid3 bottom = Rigid3::rotation({1, 0, 0}, std::numbers::pi);
    bottom.t = {0, 0, -h / 2};
    return Solid::combine(Solid::Kind::Intersection, Solid::cylinder(r),
                          Solid::combine(Solid::Kind::Intersection, Solid::halfSpace(top), Solid::halfSpace(bottom)));
  }
  fail(Errc::Config, "{}: unknown shape '{}'", t.where("shape"), kind);
}

// Reads the file that key `key` of `t` names (relative to the scene file),
// with `read`; its errors say which scene file and key named it.
template <typename Read>
auto readNamedFile(ConfigTable& t, const char* key, Read read) {
  fs::path file = t.string(key);
  if (file.is_relative()) file = t.directory() / file;
  try {
    return read(file);
  } catch (const Error& e) {
    throw Error(e.code(), fmt::format("{}: {}", t.where(key), e.what()));
  }
}

}  // namespace

namespace detail {

Object readObject(ConfigTable& t) {
  Object obj;
  obj.name = t.string("name");
  const std::string kind = t.string("shape", std::nullopt, {"sphere", "lens", "cylinder", "rectangle", "mesh"});
  obj.worldFromObject = readPlacement(t);
  if ((kind == "rectangle" || kind == "mesh") && t.has("cut"))  // (else it would be an unknown key)
    fail(Errc::Config, "{}: cut-outs apply to solids (sphere, lens, cylinder), not to a {}", t.where("cut"), kind);
  if (kind == "rectangle") {
    const auto size = t.numbers("size_mm", 2, std::nullopt, kSmallest_mm, 2 * kFarthest_mm);
    obj.shape = Rectangle{size[0], size[1]};
  } else if (kind == "mesh") {
    const double crease = t.number("crease_angle_deg", kDefaultCreaseAngle_deg, 0, 180) * std::numbers::pi / 180;
    const double scale = t.number("scale", 1.0, 1e-6, 1e6);  // the file's unit: 1000 for metres (glTF)
    obj.shape = readNamedFile(t, "file", [=](const fs::path& file) { return loadMesh(file, crease, scale); });
  } else {
    std::shared_ptr<const Solid> solid = readSolid(t, kind);
    // Cut-outs: spheres subtracted from the solid (object frame). Each can split
    // the part once along a ray; the tracer holds IntervalList::kCapacity pieces,
    // less a spare and less the pieces of the part itself along a ray: one, and
    // one more per concave face of a lens (each is a sphere taken away).
    auto cuts = t.tables("cut");
    int pieces = 1;
    if (kind == "lens") pieces += (t.number("front_radius_mm") < 0 ? 1 : 0) + (t.number("back_radius_mm") > 0 ? 1 : 0);
    if (const auto maxCuts = static_cast<size_t>(IntervalList::kCapacity - 1 - pieces); cuts.size() > maxCuts)
      fail(Errc::Config,
           "{}: {} cut-outs; at most {} for this {} (a ray through all of them would cross more "
           "pieces than the tracer follows): make the part a mesh",
           t.where("cut"), cuts.size(), maxCuts, kind);
    // A cut that misses the part's box changes nothing, and one holding the
    // whole box leaves nothing: both are a wrong position, radius or unit.
    const Bounds box = solid->bounds();  // (conservative: a box around the part)
    for (ConfigTable& cut : cuts) {
      const auto c = cut.numbers("position_mm", 3, std::nullopt, -kFarthest_mm, kFarthest_mm);
      const double r = cut.number("radius_mm", std::nullopt, kSmallest_mm, 1e6);
      const Bounds::Ball fit = box.ball({c[0], c[1], c[2]}, r);
      if (fit == Bounds::Ball::Clear)
        fail(Errc::Config,
             "{}: the cut-out (radius {:g} mm) does not meet the part, which lies within {} in the "
             "object's frame: position_mm is in the object's frame, in millimetres",
             cut.where("position_mm"), r, box.text());
      if (fit == Bounds::Ball::HoldsAll)
        fail(Errc::Config,
             "{}: the cut-out (radius {:g} mm) holds the whole part ({} in the object's frame): "
             "nothing would be left",
             cut.where("radius_mm"), r, box.text());
      solid = Solid::combine(Solid::Kind::Difference, solid, Solid::sphere(r, Rigid3::translation({c[0], c[1], c[2]})));
      cut.finish();
    }
    if (!cuts.empty() && !meetsLines(*solid, box))
      fail(Errc::Config,
           "{}: the cut-outs together leave nothing of the part ({} in the object's frame; no line of "
           "a {} x {} grid across it along x, y or z meets what is left)",
           cuts.back().where("radius_mm"), box.text(), kGridLines, kGridLines);
    obj.shape = solid;
  }
  const std::string material = t.string("material", "absorber", {"dielectric", "absorber", "diffuse"});
  if (material != "absorber" && t.has("emitter"))  // (its ior, absorption or albedo would be read and not used)
    fail(Errc::Config,
         "{}: an emitting object is opaque, its material unused: leave out material = '{}' (or the "
         "emitter)",
         t.where("material"), material);
  if (material == "dielectric") {
    if (std::holds_alternative<Rectangle>(obj.shape))  // a path would enter it and never leave
      fail(Errc::Config,
           "{}: a rectangle has no inside: it cannot be a dielectric (make it a thin box, a solid or "
           "a closed mesh)",
           t.where("material"));
    obj.material = Dielectric{t.number("ior", std::nullopt, 1.0, 5.0), t.number("absorption_per_mm", 0.0, 0, 1e3)};
    if (const auto* mesh = std::get_if<TriangleMesh>(&obj.shape))  // rays enter and leave it: it must be closed
      if (const auto fault = meshClosureFault(*mesh))
        fail(Errc::Config, "{}: a dielectric mesh must bound a solid; '{}' is {}", t.where("file"), t.string("file"),
             *fault);
  } else if (material == "diffuse")
    obj.material = Diffuse{t.number("albedo", 0.8, 0, 1)};
  else
    obj.material = Absorber{};
  if (t.has("emitter")) {
    const std::string e = t.string("emitter", std::nullopt, {"parallel", "lambertian", "light_field"});
    if (e == "parallel") {
      obj.emission =
          ParallelEmission{t.number("radiance", 1.0, 0, 1e12),
                           t.number("half_angle_rad", std::nullopt, kNarrowestCone_rad, std::numbers::pi / 2)};
    } else if (e == "lambertian") {
      obj.emission = LambertianEmission{t.number("radiance", 1.0, 0, 1e12)};
    } else {
      auto lightField = std::make_shared<LightField>(readNamedFile(t, "light_field", readLightFieldExr));
      // The display's plane is the light field's: a rectangle of its extent (the emitter takes the sensor's
      // parameters). Another size would cut off elements or add a dark border without a word.
      const auto* rect = std::get_if<Rectangle>(&obj.shape);
      if (!rect)
        fail(Errc::Config, "{}: a light field emitter must be a rectangle (the display's plane)", t.where("emitter"));
      const LightFieldGeometry& g = lightField->geometry();
      if (std::abs(rect->sizeX - g.extentX_mm()) > 1e-9 * g.extentX_mm() ||
          std::abs(rect->sizeY - g.extentY_mm()) > 1e-9 * g.extentY_mm())
        fail(Errc::Config, "{} = [{}, {}] is not the light field's extent, [{}, {}] mm ({} x {} elements of {} mm)",
             t.where("size_mm"), rect->sizeX, rect->sizeY, g.extentX_mm(), g.extentY_mm(), g.spatialX, g.spatialY,
             g.elementPitch_mm());
      const bool nearest = t.string("lookup", "nearest", {"nearest", "interpolated"}) == "nearest";
      obj.emission = LightFieldEmission{std::move(lightField),
                                        nearest ? LightFieldLookup::Nearest : LightFieldLookup::Interpolated};
    }
  }
  t.finish();
  return obj;
}

}  // namespace detail

}  // namespace lfi::sim
