// SPDX-License-Identifier: Apache-2.0
// Loading a mesh file (loadMesh): PLY through lfi's own reader, the other
// formats through Assimp; the vertices scaled and bounded, welded, and given
// smooth or sharp normals by the crease angle.

#include "lfi/sim/scene_file.h"

#include "lfi/core/error.h"
#include "lfi/core/input_file.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include "ply_mesh.h"
#include "scene_file_internal.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <numbers>
#include <numeric>

namespace lfi::sim {

namespace fs = std::filesystem;

namespace {

// Assimp opens the files a mesh file names (a glTF file's buffers, an OBJ
// file's materials) itself: only regular files, so that a FIFO or a device
// there fails instead of blocking the load.
// (DefaultIOSystem's Exists() opens the file too, and would block on a FIFO.)
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
    fail(Errc::InvalidFile,
         "'{}': not a mesh format lfi reads ({}): name the file by its format: .ply (lfi's own "
         "reader), or .obj, .stl, .gltf, .glb or another extension Assimp reads",
         path.string(), extension.empty() ? std::string("no extension") : "'" + extension + "'");
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
  mesh.normals.assign(nv, Vec3(0, 0, 1));            // (for a vertex no face uses)
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

// Joins the vertices the closure check counts as one (weldTolerance): each
// face corner is pointed at the first of its vertex's group (the others stay,
// unused, so that the file's vertex numbers keep their meaning). Smooth
// normals need it: a format that repeats a vertex per face (STL, PLY from some
// exporters), a seam, or a UV sphere's ring of pole vertices (sin π is not 0,
// so the south pole's copies differ by 1e-16) would give each copy the normal
// of its own few faces; at a tessellated ball's south pole that would tilt the
// normal by 0.03 rad and turn the rays through it by 0.013.
void weldMesh(TriangleMesh& mesh) {
  // (The quick weld: a pair it leaves apart across a cell wall keeps a normal
  // each; the closure check also searches the neighbouring cells.)
  const std::vector<unsigned> welded = detail::weldVertices(mesh, detail::weldTolerance(mesh), false);
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
      fail(Errc::InvalidFile,
           "'{}': vertex {} (counting from 0) at ({:g}, {:g}, {:g}) mm is more than {:g} mm from "
           "the origin: not a part of a bench (wrong units? the scale is {:g})",
           path.string(), v, p.x, p.y, p.z, kFarthest_mm, scale);
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

}  // namespace lfi::sim
