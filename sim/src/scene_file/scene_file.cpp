#include "lfi/sim/scene_file.h"

#include "lfi/core/config.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/input_file.h"
#include "lfi/drivers/display_optics.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "ply_mesh.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <unordered_map>
#include <numbers>
#include <numeric>

namespace lfi::sim {

namespace fs = std::filesystem;

Rigid3 placement(const std::vector<double>& p, const std::vector<double>& r) {
  const double deg = std::numbers::pi / 180;
  Rigid3 x = Rigid3::rotation({0, 0, 1}, r[2] * deg) * Rigid3::rotation({0, 1, 0}, r[1] * deg) *
             Rigid3::rotation({1, 0, 0}, r[0] * deg);
  x.t = {p[0], p[1], p[2]};
  return x;
}

namespace {

// Assimp opens the files a mesh file names (a glTF file's buffers, an OBJ
// file's materials) itself: only regular files, so that a FIFO or a device
// there fails instead of blocking the load.
// (DefaultIOSystem's Exists() opens the file too: a FIFO blocked there.)
class RegularFilesOnly final : public Assimp::DefaultIOSystem {
public:
  bool Exists(const char* file) const override {
    std::error_code ec;
    return fs::is_regular_file(file, ec);
  }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    return Exists(file) ? DefaultIOSystem::Open(file, mode) : nullptr;
  }
};

// A format Assimp reads but PLY (detail::readPly reads those), known by the
// file's extension: Assimp guesses the format of a file of another name from
// its content, and could hand it to its PLY importer after all.
TriangleMesh importMesh(const fs::path& path, const std::string& extension) {
  Assimp::Importer importer;
  if (extension.empty() || !importer.IsExtensionSupported(extension))
    fail(Errc::InvalidFile, "'{}': not a mesh format lfi reads ({}): name the file by its format: .ply (lfi's own "
         "reader), or .obj, .stl, .gltf, .glb or another extension Assimp reads", path.string(),
         extension.empty() ? std::string("no extension") : "'" + extension + "'");
  importer.SetIOHandler(new RegularFilesOnly);  // (the importer owns it)
  // Triangles with shared vertices; the data structure is checked (indices in
  // range, no empty meshes) before anything reads it.
  const aiScene* scene = importer.ReadFile(
      path.string(), aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_ValidateDataStructure |
                         aiProcess_FindDegenerates | aiProcess_SortByPType |
                         aiProcess_PreTransformVertices);  // the file's node transforms (glTF, COLLADA) applied
  if (!scene || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) || !scene->HasMeshes())
    fail(Errc::InvalidFile, "'{}': not a readable mesh: {}", path.string(), importer.GetErrorString());
  std::uint64_t triangles = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) triangles += scene->mMeshes[m]->mNumFaces;
  if (triangles > detail::kMostTriangles)
    fail(Errc::InvalidFile, "'{}': {} faces, more than the {} triangles a mesh may have", path.string(), triangles,
         detail::kMostTriangles);
  TriangleMesh mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* in = scene->mMeshes[m];
    if (!(in->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;  // points and lines have no surface
    const auto base = static_cast<unsigned>(mesh.vertices.size());
    for (unsigned v = 0; v < in->mNumVertices; ++v) {
      const aiVector3D& p = in->mVertices[v];
      mesh.vertices.push_back({p.x, p.y, p.z});
    }
    for (unsigned f = 0; f < in->mNumFaces; ++f) {
      const aiFace& face = in->mFaces[f];
      if (face.mNumIndices != 3) continue;
      mesh.triangles.push_back({base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
    }
  }
  return mesh;
}

// The file's first bytes (fewer if it is shorter).
std::string head(const fs::path& path, size_t n) {
  std::ifstream in(path, std::ios::binary);
  std::string bytes(n, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(n));
  bytes.resize(static_cast<size_t>(std::max<std::streamsize>(in.gcount(), 0)));
  return bytes;
}

// Vertex normals, smooth across edges whose faces meet at less than the crease
// angle and sharp across the others: around each vertex the faces fall into
// groups joined through such edges, and each group gets its own copy of the
// vertex (the first keeps the vertex's index, the others are appended), with
// the area-weighted mean of the group's face normals.
void smoothNormals(TriangleMesh& mesh, double creaseAngle) {
  const size_t nv = mesh.vertices.size(), nt = mesh.triangles.size();
  std::vector<Vec3> area(nt), unit(nt);  // each face's normal weighted by its area, and of unit length
  for (size_t t = 0; t < nt; ++t) {
    const auto& f = mesh.triangles[t];
    area[t] = (mesh.vertices[f[1]] - mesh.vertices[f[0]]).cross(mesh.vertices[f[2]] - mesh.vertices[f[0]]);
    unit[t] = area[t].length() > 0 ? area[t].normalized() : Vec3(0, 0, 0);
  }
  // The faces around each vertex (compressed rows).
  std::vector<unsigned> first(nv + 1, 0), around(3 * nt);
  for (const auto& f : mesh.triangles)
    for (const unsigned v : f) ++first[v + 1];
  std::partial_sum(first.begin(), first.end(), first.begin());
  std::vector<unsigned> fill(first.begin(), first.end() - 1);
  for (size_t t = 0; t < nt; ++t)
    for (const unsigned v : mesh.triangles[t]) around[fill[v]++] = static_cast<unsigned>(t);
  const double cosCrease = std::cos(creaseAngle);
  mesh.normals.assign(nv, Vec3(0, 0, 1));  // (for a vertex no face uses)
  std::vector<std::pair<unsigned, unsigned>> edges;  // (the edge's other end, the face's slot around v)
  std::vector<unsigned> group, copyOf;
  std::vector<Vec3> sum;
  for (unsigned v = 0; v < nv; ++v) {
    const unsigned begin = first[v], count = first[v + 1] - begin;
    if (count == 0) continue;
    // Faces sharing an edge from v (the same other end) join when they meet
    // at less than the crease angle: the two of an ordinary edge, any two of
    // a few (a sheet stored double-sided has four, its two layers facing
    // apart). An edge of more than kMostFacesOnAnEdge is sharp, and faces of
    // no area (corners welded into one) share none: the comparisons stay
    // linear in the faces, however many meet at one edge.
    edges.clear();
    for (unsigned s = 0; s < count; ++s)
      if (unit[around[begin + s]] != Vec3(0, 0, 0))
        for (const unsigned w : mesh.triangles[around[begin + s]])
          if (w != v) edges.emplace_back(w, s);
    std::sort(edges.begin(), edges.end());
    group.resize(count);
    std::iota(group.begin(), group.end(), 0u);
    auto root = [&](unsigned s) {
      while (group[s] != s) s = group[s] = group[group[s]];
      return s;
    };
    constexpr size_t kMostFacesOnAnEdge = 8;
    for (size_t i = 0, j; i < edges.size(); i = j) {
      for (j = i + 1; j < edges.size() && edges[j].first == edges[i].first;) ++j;
      if (j - i > kMostFacesOnAnEdge) continue;
      for (size_t a = i; a + 1 < j; ++a)
        for (size_t b = a + 1; b < j; ++b)
          if (unit[around[begin + edges[a].second]].dot(unit[around[begin + edges[b].second]]) >= cosCrease)
            group[root(edges[a].second)] = root(edges[b].second);
    }
    // One normal per group, the sum of its faces'; the first group (of faces with area) keeps v.
    sum.assign(count, Vec3(0, 0, 0));
    for (unsigned s = 0; s < count; ++s) sum[root(s)] += area[around[begin + s]];
    copyOf.assign(count, ~0u);
    bool kept = false;  // whether a group has taken v itself
    for (unsigned s = 0; s < count; ++s) {
      if (unit[around[begin + s]] == Vec3(0, 0, 0)) continue;  // (no area: never met, its corners left as they are)
      const unsigned r = root(s);
      if (copyOf[r] == ~0u) {
        const Vec3 n = sum[r].length() > 0 ? sum[r].normalized() : Vec3(0, 0, 1);
        if (!kept) {
          kept = true;
          copyOf[r] = v, mesh.normals[v] = n;
        } else {
          copyOf[r] = static_cast<unsigned>(mesh.vertices.size());
          const Vec3 position = mesh.vertices[v];
          mesh.vertices.push_back(position);
          mesh.normals.push_back(n);
        }
      }
      for (unsigned& corner : mesh.triangles[around[begin + s]])
        if (corner == v) corner = copyOf[r];
    }
  }
}

// Defined below, with the closure check that shares them.
double weldTolerance(const TriangleMesh& mesh);
std::vector<unsigned> weldVertices(const TriangleMesh& mesh, double tolerance, bool neighbours);

// Joins the vertices the closure check counts as one (weldTolerance): each
// face corner is pointed at the first of its vertex's group (the others stay,
// unused, so that the file's vertex numbers keep their meaning). Smooth
// normals need it: a format that repeats a vertex per face (STL, PLY from some
// exporters), a seam, or a UV sphere's ring of pole vertices (sin π is not 0,
// so the south pole's copies differ by 1e-16) would give each copy the normal
// of its own few faces; at a tessellated ball's south pole that tilted the
// normal by 0.03 rad and turned the rays through it by 0.013.
void weldMesh(TriangleMesh& mesh) {
  // (The quick weld: a pair it leaves apart across a cell wall keeps a normal
  // each, as every vertex did before; the closure check then searches the
  // neighbouring cells.)
  const std::vector<unsigned> welded = weldVertices(mesh, weldTolerance(mesh), false);
  for (auto& triangle : mesh.triangles)
    for (unsigned& corner : triangle) corner = welded[corner];
}

}  // namespace

TriangleMesh loadMesh(const fs::path& path, double creaseAngle_rad, double scale) {
  if (!(creaseAngle_rad >= 0 && creaseAngle_rad <= std::numbers::pi))
    fail(Errc::InvalidArgument, "'{}': crease angle {} rad is outside [0, pi]", path.string(), creaseAngle_rad);
  if (!(scale > 0) || !std::isfinite(scale))
    fail(Errc::InvalidArgument, "'{}': scale {} must be finite and > 0", path.string(), scale);
  requireInputFile(path, "mesh file");
  // PLY by its content, whatever the name; a .ply that is not PLY is not handed to Assimp either.
  std::string extension = path.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  TriangleMesh mesh =
      detail::looksLikePly(head(path, 8)) || extension == ".ply" ? detail::readPly(path) : importMesh(path, extension);
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    Vec3& p = mesh.vertices[v];
    p *= scale;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      fail(Errc::InvalidFile, "'{}': vertex {} (counting from 0) is not finite", path.string(), v);
    if (std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) > kFarthest_mm)
      fail(Errc::InvalidFile, "'{}': vertex {} (counting from 0) at ({:g}, {:g}, {:g}) mm is more than {:g} mm from "
           "the origin: not a part of a bench (wrong units? the scale is {:g})", path.string(), v, p.x, p.y, p.z,
           kFarthest_mm, scale);
  }
  if (mesh.triangles.empty()) fail(Errc::InvalidFile, "'{}': the mesh has no faces", path.string());
  if (std::none_of(mesh.triangles.begin(), mesh.triangles.end(), [&](const auto& f) {
        const Vec3 &a = mesh.vertices[f[0]], &b = mesh.vertices[f[1]], &c = mesh.vertices[f[2]];
        return (b - a).cross(c - a).length() > 0;
      }))
    fail(Errc::InvalidFile, "'{}': none of the mesh's {} faces has an area (its vertices lie on a line)", path.string(),
         mesh.triangles.size());
  weldMesh(mesh);
  smoothNormals(mesh, creaseAngle_rad);
  return mesh;
}

namespace {

// An axis-aligned box, grown point by point from an empty one.
struct Box {
  Vec3 low{std::numeric_limits<double>::infinity()}, high{-std::numeric_limits<double>::infinity()};
  void add(const Vec3& v) {
    low = Vec3(std::min(low.x, v.x), std::min(low.y, v.y), std::min(low.z, v.z));
    high = Vec3(std::max(high.x, v.x), std::max(high.y, v.y), std::max(high.z, v.z));
  }
  bool holds(const Vec3& p) const {
    return p.x >= low.x && p.y >= low.y && p.z >= low.z && p.x <= high.x && p.y <= high.y && p.z <= high.z;
  }
};

// The bounding box of the vertices the triangles use (a stray unused vertex
// does not count); the origin for no triangle.
Box bounds(const TriangleMesh& mesh) {
  Box box;
  for (const auto& t : mesh.triangles)
    for (const unsigned i : t) box.add(mesh.vertices[i]);
  if (mesh.triangles.empty()) box.low = box.high = Vec3(0, 0, 0);
  return box;
}

// One id per position, within `tolerance` (Chebyshev) of each other, on a grid
// of cells of that size (offset by an odd fraction of a cell, so that meshes
// symmetric about 0 do not straddle a cell wall there). Any two vertices in one
// cell are that close, so the cell's first vertex stands for it. With
// `neighbours`, a vertex also joins the first one within the tolerance in the
// 26 neighbouring cells (slower: a hash look-up each).
std::vector<unsigned> weldVertices(const TriangleMesh& mesh, double tolerance, bool neighbours) {
  const Vec3 low = bounds(mesh).low - Vec3(0.3183 * tolerance, 0.2719 * tolerance, 0.1415 * tolerance);
  using Cell = std::array<std::int64_t, 3>;
  auto cellOf = [&](const Vec3& p) {
    return Cell{static_cast<std::int64_t>(std::floor((p.x - low.x) / tolerance)),
                static_cast<std::int64_t>(std::floor((p.y - low.y) / tolerance)),
                static_cast<std::int64_t>(std::floor((p.z - low.z) / tolerance))};
  };
  // Only the vertices the triangles use (as bounds() measures them); the others keep their own ids.
  std::vector<char> used(mesh.vertices.size(), 0);
  for (const auto& t : mesh.triangles)
    for (const unsigned i : t) used[i] = 1;
  std::vector<unsigned> welded(mesh.vertices.size());
  std::iota(welded.begin(), welded.end(), 0u);
  if (!neighbours) {  // sorted by cell: a cell's vertices are adjacent
    std::vector<std::pair<Cell, unsigned>> order;
    for (size_t v = 0; v < mesh.vertices.size(); ++v)
      if (used[v]) order.emplace_back(cellOf(mesh.vertices[v]), static_cast<unsigned>(v));
    std::sort(order.begin(), order.end());
    for (size_t i = 0; i < order.size(); ++i)
      welded[order[i].second] = i > 0 && order[i].first == order[i - 1].first ? welded[order[i - 1].second]
                                                                              : order[i].second;
    return welded;
  }
  struct CellHash {
    size_t operator()(const Cell& c) const {
      return static_cast<size_t>(c[0] * 73856093LL ^ c[1] * 19349663LL ^ c[2] * 83492791LL);
    }
  };
  std::unordered_map<Cell, unsigned, CellHash> cells(2 * mesh.vertices.size());
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (!used[v]) continue;
    const Vec3& p = mesh.vertices[v];
    const Cell cell = cellOf(p);
    for (int n = 0; n < 27 && welded[v] == v; ++n) {
      const auto found = cells.find({cell[0] + n % 3 - 1, cell[1] + n / 3 % 3 - 1, cell[2] + n / 9 - 1});
      if (found == cells.end()) continue;
      const Vec3 d = mesh.vertices[found->second] - p;
      if (std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)}) <= tolerance) welded[v] = welded[found->second];
    }
    cells.try_emplace(cell, static_cast<unsigned>(v));
  }
  return welded;
}

// Whether a ray from p in a fixed, unremarkable direction crosses triangle t
// (Möller–Trumbore): the parity of such crossings over a closed surface says
// whether p is inside it.
bool parityRayCrosses(const TriangleMesh& mesh, const std::array<unsigned, 3>& t, const Vec3& p) {
  static const Vec3 dir = Vec3(0.5164, 0.6331, 0.5766).normalized();
  const Vec3 &a = mesh.vertices[t[0]], e1 = mesh.vertices[t[1]] - a, e2 = mesh.vertices[t[2]] - a;
  const Vec3 h = dir.cross(e2);
  const double det = e1.dot(h);
  if (det == 0) return false;
  const Vec3 s = p - a;
  const double u = s.dot(h) / det;
  if (u < 0 || u > 1) return false;
  const Vec3 q = s.cross(e1);
  const double v = dir.dot(q) / det;
  if (v < 0 || u + v > 1) return false;
  return e2.dot(q) / det > 0;
}

// Every edge of every triangle as its two welded ends, lower id first, and which way the triangle crosses it.
struct EdgeCrossing {
  std::uint64_t edge;
  unsigned triangle;
  std::int8_t corner;  // the edge runs from the triangle's vertex `corner` to the next
  bool forward;        // from the lower welded id to the higher
};

// For a closed, consistently wound mesh of several parts (closed surfaces that
// share no edge): each part must be wound outwards, or inwards where it is a
// cavity. A part inside an even number of the others (none: a solid; two: an
// island in a cavity) must enclose a positive volume, one inside an odd number
// a negative one. The whole mesh's volume being positive does not show a part
// wound the wrong way beside a larger one wound right.
std::optional<std::string> partWindingFault(const TriangleMesh& mesh, const std::vector<EdgeCrossing>& crossings) {
  // Parts: triangles joined through the edges they share (each edge's two crossings are adjacent, sorted).
  std::vector<unsigned> parent(mesh.triangles.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto root = [&](unsigned t) {
    while (parent[t] != t) t = parent[t] = parent[parent[t]];
    return t;
  };
  for (size_t i = 0; i + 1 < crossings.size(); i += 2)
    parent[root(crossings[i].triangle)] = root(crossings[i + 1].triangle);
  std::vector<unsigned> partOfRoot(mesh.triangles.size(), ~0u);  // (~0u: none yet)
  std::vector<char> counted(mesh.triangles.size(), 0);
  std::vector<std::vector<unsigned>> triangles;  // each part's, the first one naming it
  std::vector<double> volume6;
  std::vector<Box> box;  // each part's: only parts whose box holds a point can hold it
  for (const auto& c : crossings) {
    if (counted[c.triangle]) continue;
    counted[c.triangle] = 1;
    const unsigned r = root(c.triangle);
    if (partOfRoot[r] == ~0u) {
      partOfRoot[r] = static_cast<unsigned>(triangles.size());
      triangles.emplace_back();
      volume6.push_back(0);
      box.emplace_back();
    }
    const unsigned k = partOfRoot[r];
    triangles[k].push_back(c.triangle);
    const auto& t = mesh.triangles[c.triangle];
    volume6[k] += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]]));
    for (const unsigned i : t) box[k].add(mesh.vertices[i]);
  }
  if (triangles.size() < 2) return std::nullopt;
  // The parts' boxes on a grid over the mesh (about one cell per part), so
  // that a point is tested against the parts near it, not every part: a mesh
  // of 22 500 separate beads took 2 s, quadratic in the parts. A box over more
  // than kLargeCells cells is listed apart and tested for every point.
  const Box all = bounds(mesh);
  const int side = std::clamp(static_cast<int>(std::cbrt(static_cast<double>(triangles.size()))), 1, 128);
  constexpr long kLargeCells = 64;
  auto cellOf = [&](double x, int axis) {
    const double lo = all.low[axis], span = all.high[axis] - lo;
    const double f = span > 0 ? (x - lo) / span : 0;
    return std::clamp(static_cast<int>(f * side), 0, side - 1);
  };
  std::vector<std::vector<unsigned>> cells(static_cast<size_t>(side) * side * side);
  std::vector<unsigned> large;
  for (size_t k = 0; k < box.size(); ++k) {
    int lo[3], hi[3];
    long count = 1;
    for (int a = 0; a < 3; ++a) {
      lo[a] = cellOf(box[k].low[a], a), hi[a] = cellOf(box[k].high[a], a);
      count *= hi[a] - lo[a] + 1;
    }
    if (count > kLargeCells) {
      large.push_back(static_cast<unsigned>(k));
      continue;
    }
    for (int x = lo[0]; x <= hi[0]; ++x)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int z = lo[2]; z <= hi[2]; ++z)
          cells[(static_cast<size_t>(x) * side + y) * side + z].push_back(static_cast<unsigned>(k));
  }
  // How many of the other parts hold the centroid of part k's triangle t.
  auto partsAround = [&](size_t k, unsigned triangle) {
    const auto& t = mesh.triangles[triangle];
    const Vec3 p = (mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]) / 3.0;
    int around = 0;
    auto test = [&](unsigned other) {
      if (other == k || !box[other].holds(p)) return;
      bool inside = false;
      for (const unsigned i : triangles[other]) inside ^= parityRayCrosses(mesh, mesh.triangles[i], p);
      around += inside;
    };
    for (const unsigned other : cells[(static_cast<size_t>(cellOf(p.x, 0)) * side + cellOf(p.y, 1)) * side +
                                      cellOf(p.z, 2)])
      test(other);
    for (const unsigned other : large) test(other);
    return around;
  };
  for (size_t k = 0; k < triangles.size(); ++k) {
    // Up to eight points of the part (centroids of triangles spread over it). Parts that cross each other
    // (shells never merged into one solid) give points inside different numbers of the others: no verdict then.
    const auto& list = triangles[k];
    const int around = partsAround(k, list.front());
    const size_t samples = std::min<size_t>(8, list.size());
    bool agree = true;
    for (size_t i = 1; i < samples && agree; ++i)
      agree = partsAround(k, list[i * list.size() / samples]) % 2 == around % 2;
    if (!agree) continue;
    const auto& t = mesh.triangles[list.front()];
    if ((around % 2 == 0) != (volume6[k] > 0)) {
      auto at = [&](unsigned v) {
        const Vec3& q = mesh.vertices[v];
        return fmt::format("({:g}, {:g}, {:g})", q.x, q.y, q.z);
      };
      return fmt::format("a part wound the wrong way: the closed surface through triangle {} (counting from 0; "
                         "corners {}, {}, {}) encloses {:.6g} mm^3 and lies inside {} of the mesh's other {} parts: "
                         "{} (reverse its triangles' vertex order)", list.front(), at(t[0]), at(t[1]), at(t[2]),
                         volume6[k] / 6, around, triangles.size() - 1,
                         around % 2 ? "a cavity must be wound inwards" : "a solid must be wound outwards");
    }
  }
  return std::nullopt;
}

// What meshClosureFault found: `open` when an edge is not crossed once each way
// (which a coarser weld may mend), else a winding fault (which no weld mends).
struct ClosureFault {
  bool open = false;
  std::string why;
};

// meshClosureFault for vertices welded to `welded`.
std::optional<ClosureFault> closureFault(const TriangleMesh& mesh, const std::vector<unsigned>& welded) {
  std::vector<EdgeCrossing> crossings;
  crossings.reserve(3 * mesh.triangles.size());
  double volume6 = 0;  // six times the signed enclosed volume
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const unsigned w[3] = {welded[tri[0]], welded[tri[1]], welded[tri[2]]};
    if (w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) continue;  // no area
    volume6 += mesh.vertices[tri[0]].dot(mesh.vertices[tri[1]].cross(mesh.vertices[tri[2]]));
    for (int k = 0; k < 3; ++k) {
      const unsigned a = w[k], b = w[(k + 1) % 3];
      crossings.push_back({std::uint64_t{std::min(a, b)} << 32 | std::max(a, b), static_cast<unsigned>(t),
                           static_cast<std::int8_t>(k), a < b});
    }
  }
  if (crossings.empty()) return ClosureFault{false, "no triangle of non-zero size"};
  std::sort(crossings.begin(), crossings.end(), [](const EdgeCrossing& x, const EdgeCrossing& y) {
    return x.edge != y.edge ? x.edge < y.edge : x.triangle < y.triangle;
  });
  for (size_t i = 0; i < crossings.size();) {
    size_t j = i, forward = 0;
    for (; j < crossings.size() && crossings[j].edge == crossings[i].edge; ++j) forward += crossings[j].forward;
    const size_t backward = j - i - forward;
    if (forward != 1 || backward != 1) {
      const EdgeCrossing& c = crossings[i];
      const auto& tri = mesh.triangles[c.triangle];
      auto at = [&](unsigned v) {
        const Vec3& p = mesh.vertices[v];
        return fmt::format("({:g}, {:g}, {:g})", p.x, p.y, p.z);
      };
      const std::string which = fmt::format("the edge from {} to {} (triangle {}, counting from 0)",
                                            at(tri[c.corner]), at(tri[(c.corner + 1) % 3]), c.triangle);
      const size_t thisWay = c.forward ? forward : backward, otherWay = j - i - thisWay;
      if (j - i == 1)
        return ClosureFault{true, fmt::format("not closed: {} borders no other triangle (a hole)", which)};
      return ClosureFault{true, fmt::format("not closed or not consistently wound: {} is crossed {} time(s) this way "
                                            "and {} the other (a closed surface crosses each edge once each way)",
                                            which, thisWay, otherWay)};
    }
    i = j;
  }
  if (!(volume6 > 0))
    return ClosureFault{false, fmt::format("wound inwards: its enclosed volume is {:.6g} mm^3 (reverse every "
                                           "triangle's vertex order)", volume6 / 6)};
  if (auto fault = partWindingFault(mesh, crossings)) return ClosureFault{false, std::move(*fault)};
  return std::nullopt;
}

}  // namespace

namespace {

// Vertices within a float's precision of the mesh's size are one: formats that
// repeat a vertex per face (STL, seams) and rings of vertices at a sphere's
// pole still close. (Of the size, or of the distance from the origin where that
// is larger: a float's step grows with it.) Infinite for vertices that are not.
double weldTolerance(const TriangleMesh& mesh) {
  const auto [low, high] = bounds(mesh);
  const double extent = std::max({high.x - low.x, high.y - low.y, high.z - low.z, std::abs(low.x), std::abs(low.y),
                                  std::abs(low.z), std::abs(high.x), std::abs(high.y), std::abs(high.z)});
  if (!std::isfinite(extent)) return std::numeric_limits<double>::infinity();
  return extent > 0 ? 1e-7 * extent : 1.0;
}

}  // namespace

std::optional<std::string> meshClosureFault(const TriangleMesh& mesh) {
  // The quick weld first; the thorough one when that leaves the mesh open (two
  // such vertices on either side of a cell wall).
  const double tolerance = weldTolerance(mesh);
  if (!std::isfinite(tolerance)) {
    const auto [low, high] = bounds(mesh);
    return fmt::format("not measurable: its vertices span from ({:g}, {:g}, {:g}) to ({:g}, {:g}, {:g})", low.x, low.y,
                       low.z, high.x, high.y, high.z);
  }
  auto fault = closureFault(mesh, weldVertices(mesh, tolerance, false));
  if (fault && fault->open) fault = closureFault(mesh, weldVertices(mesh, tolerance, true));
  if (!fault) return std::nullopt;
  return std::move(fault->why);
}

namespace {

Rigid3 readPlacement(ConfigTable& t) {
  return placement(t.numbers("position_mm", 3, std::vector<double>{0, 0, 0}, -kFarthest_mm, kFarthest_mm),
                   t.numbers("rotation_deg", 3, std::vector<double>{0, 0, 0}, -360, 360));
}

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
    if (kind == "lens")
      pieces += (t.number("front_radius_mm") < 0 ? 1 : 0) + (t.number("back_radius_mm") > 0 ? 1 : 0);
    if (const auto maxCuts = static_cast<size_t>(IntervalList::kCapacity - 1 - pieces); cuts.size() > maxCuts)
      fail(Errc::Config, "{}: {} cut-outs; at most {} for this {} (a ray through all of them would cross more "
           "pieces than the tracer follows): make the part a mesh", t.where("cut"), cuts.size(), maxCuts, kind);
    // A cut that misses the part's box changes nothing, and one holding the
    // whole box leaves nothing: both are a wrong position, radius or unit.
    const Bounds box = solid->bounds();  // (conservative: a box around the part)
    for (ConfigTable& cut : cuts) {
      const auto c = cut.numbers("position_mm", 3, std::nullopt, -kFarthest_mm, kFarthest_mm);
      const double r = cut.number("radius_mm", std::nullopt, kSmallest_mm, 1e6);
      const Bounds::Ball fit = box.ball({c[0], c[1], c[2]}, r);
      if (fit == Bounds::Ball::Clear)
        fail(Errc::Config, "{}: the cut-out (radius {:g} mm) does not meet the part, which lies within {} in the "
             "object's frame: position_mm is in the object's frame, in millimetres", cut.where("position_mm"), r,
             box.text());
      if (fit == Bounds::Ball::HoldsAll)
        fail(Errc::Config, "{}: the cut-out (radius {:g} mm) holds the whole part ({} in the object's frame): "
             "nothing would be left", cut.where("radius_mm"), r, box.text());
      solid = Solid::combine(Solid::Kind::Difference, solid, Solid::sphere(r, Rigid3::translation({c[0], c[1], c[2]})));
      cut.finish();
    }
    if (!cuts.empty() && !meetsLines(*solid, box))
      fail(Errc::Config, "{}: the cut-outs together leave nothing of the part ({} in the object's frame; no line of "
           "a {} x {} grid across it along x, y or z meets what is left)", cuts.back().where("radius_mm"),
           box.text(), kGridLines, kGridLines);
    obj.shape = solid;
  }
  const std::string material = t.string("material", "absorber", {"dielectric", "absorber", "diffuse"});
  if (material != "absorber" && t.has("emitter"))  // (its ior, absorption or albedo would be read and not used)
    fail(Errc::Config, "{}: an emitting object is opaque, its material unused: leave out material = '{}' (or the "
         "emitter)", t.where("material"), material);
  if (material == "dielectric") {
    if (std::holds_alternative<Rectangle>(obj.shape))  // a path would enter it and never leave
      fail(Errc::Config, "{}: a rectangle has no inside: it cannot be a dielectric (make it a thin box, a solid or "
           "a closed mesh)", t.where("material"));
    obj.material = Dielectric{t.number("ior", std::nullopt, 1.0, 5.0), t.number("absorption_per_mm", 0.0, 0, 1e3)};
    if (const auto* mesh = std::get_if<TriangleMesh>(&obj.shape))  // rays enter and leave it: it must be closed
      if (const auto fault = meshClosureFault(*mesh))
        fail(Errc::Config, "{}: a dielectric mesh must bound a solid; '{}' is {}", t.where("file"), t.string("file"),
             *fault);
  }
  else if (material == "diffuse")
    obj.material = Diffuse{t.number("albedo", 0.8, 0, 1)};
  else
    obj.material = Absorber{};
  if (t.has("emitter")) {
    const std::string e = t.string("emitter", std::nullopt, {"parallel", "lambertian", "light_field"});
    if (e == "parallel") {
      obj.emission = ParallelEmission{t.number("radiance", 1.0, 0, 1e12),
                                      t.number("half_angle_rad", std::nullopt, kNarrowestCone_rad, std::numbers::pi / 2)};
    } else if (e == "lambertian") {
      obj.emission = LambertianEmission{t.number("radiance", 1.0, 0, 1e12)};
    } else {
      auto lightField = std::make_shared<LightField>(readNamedFile(t, "light_field", readLightFieldExr));
      // The display's plane is the light field's: a rectangle of its extent (SPEC §2: the emitter takes the
      // sensor's parameters). Another size would cut off elements or add a dark border without a word.
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

DisplayParameters readDisplay(ConfigTable& t) {
  const DisplayInfo defaults = defaultLenticularDisplay();
  DisplayParameters d;
  DisplayInfo& info = d.info;
  info.vendor = "lfi";
  info.model = "SimDisplay";
  d.worldFromDisplay = readPlacement(t);
  info.panelWidth_px = t.integer("panel_width_px", defaults.panelWidth_px, 1, 16384);
  info.panelHeight_px = t.integer("panel_height_px", defaults.panelHeight_px, 1, 16384);
  info.pixelPitch_mm = t.number("pixel_pitch_mm", defaults.pixelPitch_mm, 1e-4, 10);
  const std::string sub = t.string("subpixels", "rgb", {"mono", "rgb", "bgr"});
  info.subpixels = sub == "mono" ? SubpixelLayout::Mono : sub == "rgb" ? SubpixelLayout::RgbStripe
                                                                        : SubpixelLayout::BgrStripe;
  DisplayOpticsParams& o = info.optics;
  const bool barrier = t.string("optics", "lenslet", {"lenslet", "barrier"}) == "barrier";
  o.type = barrier ? OpticsType::Barrier : OpticsType::Lenslet;
  o.lensPitch_px = t.number("lens_pitch_px", defaults.optics.lensPitch_px, 1, 1000);
  o.slant_rad = t.number("slant_rad", defaults.optics.slant_rad, -0.785, 0.785);
  o.offset_px = t.number("offset_px", defaults.optics.offset_px, -1e6, 1e6);
  o.gap_mm = t.number("gap_mm", defaults.optics.gap_mm, 1e-3, 100);  // (DisplayInfo::validate's range)
  if (barrier)
    o.slitWidth_mm = t.number("slit_width_mm", std::nullopt, 1e-6, 1e3);
  else
    o.focalLength_mm = t.number("focal_length_mm", o.gap_mm, 1e-6, 1e6);
  info.viewCount = t.integer("view_count", defaults.viewCount, 1, 1 << 20);
  info.brightnessMin = t.integer("brightness_min", defaults.brightnessMin, 0, 1 << 20);
  info.brightnessMax = t.integer("brightness_max", defaults.brightnessMax, 0, 1 << 20);
  if (info.brightnessMax < info.brightnessMin)
    fail(Errc::Config, "{}: brightness_max = {} is below brightness_min = {}",
         t.where(t.has("brightness_max") ? "brightness_max" : "brightness_min"), info.brightnessMax,
         info.brightnessMin);
  d.brightness = t.number("brightness", 1.0, 0, 1e12);
  t.finish();
  try {
    info.validate();
  } catch (const Error& e) {
    fail(Errc::Config, "{}: [display]: {}", t.file(), e.what());
  }
  return d;
}

// Whether `p` lies inside the closed mesh: the parity of the triangles a ray
// from p crosses (a direction no axis-aligned or diagonal edge lies along).
bool insideClosedMesh(const TriangleMesh& mesh, const Vec3& p) {
  bool inside = false;
  for (const auto& t : mesh.triangles) inside ^= parityRayCrosses(mesh, t, p);
  return inside;
}

// Rays start in air: a sensor whose rays would start inside a solid gives a
// wrong image without a word. Checks a sample of the points where the
// sensor's rays start (a solid small enough to fit between them is missed),
// a grid over a rectangle of half sizes halfX, halfY about the origin of its
// plane, each moved by `reach` in eight directions (a stop's disc), against
// every solid and every closed mesh (an open one has no inside).
void requireOutsideSolids(const std::vector<Object>& objects, const Rigid3& worldFromPlane, double halfX, double halfY,
                          double reach, const std::string& where) {
  constexpr int kGrid = 17, kDirections = 8;
  for (const Object& object : objects) {
    std::function<bool(const Vec3&)> contains;  // in the object's frame
    if (const auto* solid = std::get_if<std::shared_ptr<const Solid>>(&object.shape)) {
      contains = [solid](const Vec3& p) { return (*solid)->contains(p); };
    } else if (const auto* mesh = std::get_if<TriangleMesh>(&object.shape)) {
      // Whether it is closed is asked only once a point falls in its box (the closure check costs time).
      contains = [mesh, box = bounds(*mesh), closed = std::optional<bool>()](const Vec3& p) mutable {
        if (!box.holds(p)) return false;
        if (!closed) closed = !meshClosureFault(*mesh);
        return *closed && insideClosedMesh(*mesh, p);
      };
    } else {
      continue;
    }
    const Rigid3 objectFromWorld = object.worldFromObject.inverse();
    for (int i = 0; i < kGrid; ++i)
      for (int j = 0; j < kGrid; ++j) {
        const double x = halfX * (2.0 * i / (kGrid - 1) - 1), y = halfY * (2.0 * j / (kGrid - 1) - 1);
        for (int k = 0; k <= (reach > 0 ? kDirections : 0); ++k) {  // k = 0: the grid point itself
          const double a = 2 * std::numbers::pi * k / kDirections, r = k == 0 ? 0.0 : reach;
          const Vec3 p = worldFromPlane.point({x + r * std::cos(a), y + r * std::sin(a), 0});
          if (contains(objectFromWorld.point(p)))
            fail(Errc::Config, "{}: the sensor's rays would start inside object '{}' (at ({:.4g}, {:.4g}, {:.4g}) "
                 "mm); the tracer starts them in air: move the sensor or the object", where, object.name, p.x, p.y,
                 p.z);
        }
      }
  }
}

}  // namespace

SceneDescription loadSceneFile(const fs::path& path) {
  ConfigTable root = ConfigTable::parseFile(path);
  root.requireKnownKeys({"format", "version", "ambient_ior", "render", "camera", "light_field_sensor", "camera_sensor",
                         "object", "display"});
  root.string("format", std::nullopt, {"lfi-scene"});
  root.integer("version", std::nullopt, 1, 1);
  SceneDescription d;
  d.name = path.stem().string();
  d.ambientIor = root.number("ambient_ior", 1.0, 1.0, 5.0);
  if (root.has("render")) {
    ConfigTable r = root.table("render");
    d.render.samplesPerPixel = r.integer("samples_per_pixel", 16, 1, kMostSamplesPerPixel);
    d.render.seed = static_cast<std::uint64_t>(r.integer64("seed", 1, 0, kLargestSeed));
    d.render.splitDepth = r.integer("split_depth", 4, 0, RenderOptions::kMaxSplitDepth);
    d.render.maxDepth = r.integer("max_depth", 64, 1, 1024);
    r.finish();
  }
  const bool hasCamera = root.has("camera"), hasLightField = root.has("light_field_sensor");
  std::string sensorWhere;  // the sensor's position_mm, to name it
  if (hasCamera == hasLightField)
    fail(Errc::Config, "{}: give exactly one sensor: [camera] or [light_field_sensor]",
         hasCamera ? root.where("light_field_sensor") : path.string());
  if (hasCamera) {
    ConfigTable c = root.table("camera");
    TelecentricCamera cam;
    cam.focalLength_mm = c.number("focal_length_mm", std::nullopt, 1e-3, 1e5);
    cam.imageDistance_mm = c.number("image_distance_mm", std::nullopt, 1e-3, 1e5);
    cam.stopDiameter_mm = c.number("stop_diameter_mm", std::nullopt, 1e-6, 1e4);
    cam.pixelPitch_mm = c.number("pixel_pitch_mm", std::nullopt, 1e-6, 100);
    cam.width = c.integer("width", std::nullopt, 1, 65536);
    cam.height = c.integer("height", std::nullopt, 1, 65536);
    if (static_cast<std::int64_t>(cam.width) * cam.height > kMaxExrPixels)
      fail(Errc::Config, "{}: {} x {} pixels is more than a radiance EXR holds (2^30): the render could not be "
           "written", c.where("height"), cam.width, cam.height);
    cam.worldFromCamera = readPlacement(c);
    sensorWhere = c.where("position_mm");
    c.finish();
    if (cam.imageDistance_mm <= cam.focalLength_mm)
      fail(Errc::Config, "{} = {} must exceed focal_length_mm = {} (otherwise no real object is in focus)",
           c.where("image_distance_mm"), cam.imageDistance_mm, cam.focalLength_mm);
    try {
      cam.validate();
    } catch (const Error& e) {
      fail(Errc::Config, "{}: [camera]: {}", path.string(), e.what());
    }
    // b just past f puts the focused plane, and the field with it, out of any bench's reach.
    const TelecentricCamera::RayMap map(cam);
    if (const double reach = map.pixel * std::max(map.halfW, map.halfH) + map.stop; !(reach <= kFarthest_mm))
      fail(Errc::Config, "{} = {}: with focal_length_mm = {}, the field reaches {:g} mm from the axis, past {:g} mm",
           c.where("image_distance_mm"), cam.imageDistance_mm, cam.focalLength_mm, reach, kFarthest_mm);
    d.sensor = cam;
  } else {
    ConfigTable c = root.table("light_field_sensor");
    LightFieldSensor lfs;
    lfs.geometry.spatialX = c.integer("spatial_x", std::nullopt, 1, 1 << 15);
    lfs.geometry.spatialY = c.integer("spatial_y", std::nullopt, 1, 1 << 15);
    lfs.geometry.angular = c.integer("angular", std::nullopt, 1, 1024);
    lfs.geometry.pixelPitch_mm = c.number("pixel_pitch_mm", std::nullopt, 1e-6, 100);
    lfs.geometry.distance_mm = c.number("distance_mm", 0.0, 0, 1e6);
    lfs.worldFromSensor = readPlacement(c);
    sensorWhere = c.where("position_mm");
    c.finish();
    try {
      lfs.geometry.validate();
    } catch (const Error& e) {
      fail(Errc::Config, "{} (with spatial_x, spatial_y): {}", c.where("angular"), e.what());
    }
    if (const double reach = std::max(lfs.geometry.extentX_mm(), lfs.geometry.extentY_mm()) / 2;
        !(reach <= kFarthest_mm))
      fail(Errc::Config, "{} = {}: with spatial_x = {}, spatial_y = {} and angular = {}, the sensor reaches {:g} mm "
           "from its centre, past {:g} mm", c.where("pixel_pitch_mm"), lfs.geometry.pixelPitch_mm,
           lfs.geometry.spatialX, lfs.geometry.spatialY, lfs.geometry.angular, reach, kFarthest_mm);
    d.sensor = lfs;
  }
  if (root.has("camera_sensor")) {
    if (!hasCamera) fail(Errc::Config, "{}: [camera_sensor] needs a [camera]", root.where("camera_sensor"));
    ConfigTable c = root.table("camera_sensor");
    d.cameraSensor.fullWell_e = c.number("full_well_e", d.cameraSensor.fullWell_e, 1, 1e9);
    d.cameraSensor.readNoise_e = c.number("read_noise_e", d.cameraSensor.readNoise_e, 0, 1e6);
    d.cameraSensor.bitDepth = c.integer("bit_depth", d.cameraSensor.bitDepth, 8, 16);
    d.cameraSensor.electronsPerUnitPerUs =
        c.number("electrons_per_unit_per_us", d.cameraSensor.electronsPerUnitPerUs, 1e-12, 1e12);
    c.finish();
  }
  // Errors, the study's report and the tracer's messages name objects: one name each.
  std::map<std::string, std::string> named;  // name -> where
  for (ConfigTable& o : root.tables("object")) {
    d.objects.push_back(readObject(o));
    const std::string& name = d.objects.back().name;
    if (name.empty()) fail(Errc::Config, "{} is empty: errors and reports name an object by it", o.where("name"));
    if (const auto [at, fresh] = named.emplace(name, o.where("name")); !fresh)
      fail(Errc::Config, "{}: '{}' names another object too ({})", o.where("name"), name, at->second);
  }
  if (root.has("display")) {
    if (named.contains("display"))
      fail(Errc::Config, "{}: 'display' names the [display] panel's object: call this one something else",
           named["display"]);
    ConfigTable t = root.table("display");
    d.display = readDisplay(t);
    const DisplayInfo& info = d.display->info;
    Object obj;
    obj.name = "display";
    obj.shape = Rectangle{info.panelWidth_px * info.pixelPitch_mm, info.panelHeight_px * info.pixelPitch_mm};
    obj.worldFromObject = d.display->worldFromDisplay;
    obj.emission = makePanelEmission(std::make_shared<const PanelOptics>(info), cv::Mat(), d.display->brightness);
    d.displayObject = static_cast<int>(d.objects.size());
    d.objects.push_back(std::move(obj));
  }
  if (d.objects.empty()) fail(Errc::Config, "{}: the scene has no [[object]]", path.string());
  if (const auto* cam = std::get_if<TelecentricCamera>(&d.sensor)) {
    const TelecentricCamera::RayMap map(*cam);  // origins: the field, moved by up to the stop's radius
    requireOutsideSolids(d.objects, cam->worldFromCamera, map.pixel * map.halfW, map.pixel * map.halfH, map.stop,
                         sensorWhere);
  } else {
    const auto& lfs = std::get<LightFieldSensor>(d.sensor);
    const double e = lfs.geometry.elementPitch_mm();  // origins: the element centres
    requireOutsideSolids(d.objects, lfs.worldFromSensor, 0.5 * (lfs.geometry.extentX_mm() - e),
                         0.5 * (lfs.geometry.extentY_mm() - e), 0, sensorWhere);
  }
  root.finish();
  return d;
}

const char* lensKey(LensFault::Part part) {
  switch (part) {
    case LensFault::Part::Thickness: return "centre_thickness_mm";
    case LensFault::Part::Diameter: return "diameter_mm";
    case LensFault::Part::FrontRadius: return "front_radius_mm";
    case LensFault::Part::BackRadius: return "back_radius_mm";
    case LensFault::Part::Edge: return "centre_thickness_mm";
  }
  return "diameter_mm";
}

}  // namespace lfi::sim
