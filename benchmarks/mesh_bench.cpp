// SPDX-License-Identifier: Apache-2.0
// lfi-mesh-bench: loading a triangle mesh (sim::loadMesh: the file read, the
// vertices welded, the smooth normals with creases) next to bounds measured in
// the same run, in one process:
//
//   step                    what is timed                       bound
//   PLY (lfi's reader)      loadMesh of a binary PLY            reading the file's bytes into memory
//   OBJ (Assimp)            loadMesh of the same mesh as OBJ    the PLY load (Assimp parses text: not like
//                                                               for like, but the format a user has most often)
//   closure check           meshClosureFault (what a dielectric mesh must pass)
//
// The mesh: a UV sphere of radius 5 mm, 2 x s x (s/2 - 1) triangles (s = --segments),
// written by this program into a temporary folder. A ratio is the median of
// the turns' ratios, with their range (bench_util.h). Self-check before the
// figures: both files load as the same mesh (vertex and triangle counts), and
// it is closed.
//
// Usage: lfi-mesh-bench [--segments S] [--turns N] [--quick] [--dir FOLDER]

#include "lfi/sim/scene_file.h"

#include "bench_util.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace lfi;
using lfi::bench::bestOf;
using lfi::bench::ratiosByTurn;
using lfi::bench::secondsInTurns;
using lfi::bench::spreadOf;

namespace {

struct Sphere {
  std::vector<std::array<float, 3>> vertices;
  std::vector<std::array<std::int32_t, 3>> triangles;
};

// A pole vertex at each end and s/2 - 1 rings of s vertices between them;
// 2 x s x (s/2 - 1) triangles, wound outwards, none of them degenerate (an
// importer may drop those, and the two loads would differ).
Sphere uvSphere(int segments) {
  Sphere m;
  const int rings = segments / 2;
  m.vertices.push_back({0, 0, 5});
  for (int j = 1; j < rings; ++j)
    for (int i = 0; i < segments; ++i) {
      const double theta = std::numbers::pi * j / rings, phi = 2 * std::numbers::pi * i / segments;
      m.vertices.push_back({static_cast<float>(5 * std::sin(theta) * std::cos(phi)),
                            static_cast<float>(5 * std::sin(theta) * std::sin(phi)),
                            static_cast<float>(5 * std::cos(theta))});
    }
  m.vertices.push_back({0, 0, -5});
  const std::int32_t south = static_cast<std::int32_t>(m.vertices.size()) - 1;
  auto ring = [&](int j, int i) { return 1 + (j - 1) * segments + (i % segments); };  // j = 1 .. rings - 1
  for (int i = 0; i < segments; ++i) {
    m.triangles.push_back({0, ring(1, i), ring(1, i + 1)});
    m.triangles.push_back({south, ring(rings - 1, i + 1), ring(rings - 1, i)});
  }
  for (int j = 1; j + 1 < rings; ++j)
    for (int i = 0; i < segments; ++i) {
      const std::int32_t a = ring(j, i), b = ring(j, i + 1), c = ring(j + 1, i), d = ring(j + 1, i + 1);
      m.triangles.push_back({a, c, b});
      m.triangles.push_back({b, c, d});
    }
  return m;
}

void writePly(const fs::path& path, const Sphere& m) {
  std::ofstream f(path, std::ios::binary);
  f << "ply\nformat binary_little_endian 1.0\nelement vertex " << m.vertices.size()
    << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << m.triangles.size()
    << "\nproperty list uchar int vertex_indices\nend_header\n";
  f.write(reinterpret_cast<const char*>(m.vertices.data()), static_cast<std::streamsize>(m.vertices.size() * 12));
  for (const auto& t : m.triangles) {
    const char three = 3;
    f.write(&three, 1);
    f.write(reinterpret_cast<const char*>(t.data()), 12);
  }
  if (!f) throw std::runtime_error(fmt::format("cannot write '{}'", path.string()));
}

void writeObj(const fs::path& path, const Sphere& m) {
  std::string text;
  for (const auto& v : m.vertices) text += fmt::format("v {:.6f} {:.6f} {:.6f}\n", v[0], v[1], v[2]);
  for (const auto& t : m.triangles) text += fmt::format("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
  std::ofstream f(path, std::ios::binary);
  f << text;
  if (!f) throw std::runtime_error(fmt::format("cannot write '{}'", path.string()));
}

std::vector<char> readBytes(const fs::path& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw std::runtime_error(fmt::format("cannot open '{}': {}", path.string(), std::strerror(errno)));
  std::vector<char> bytes(fs::file_size(path));
  const size_t got = std::fread(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
  if (got != bytes.size()) throw std::runtime_error(fmt::format("short read of '{}'", path.string()));
  return bytes;
}

int run(int argc, char** argv) {
  int segments = 1000, turns = 5;
  bool quick = false;
  std::string parent = fs::temp_directory_path().string();
  CLI::App app("lfi-mesh-bench: mesh loading against reading the file's bytes, and Assimp, in one process");
  app.add_option("--segments", segments, "The sphere's segments around (2 x s x (s/2 - 1) triangles)")
      ->check(CLI::Range(8, 4000));
  app.add_option("--turns", turns, "Turns; a ratio is the median of theirs")->check(CLI::Range(1, 1000));
  app.add_flag("--quick", quick, "A sphere of 100 segments, 2 turns (a smoke run)");
  app.add_option("--dir", parent, "Folder for the mesh files (a temporary folder is made inside it)")
      ->check(CLI::ExistingDirectory);
  CLI11_PARSE(app, argc, argv);
  if (quick) {
    if (app.count("--segments") == 0) segments = 100;
    if (app.count("--turns") == 0) turns = 2;
  }
  segments -= segments % 2;

  const lfi::bench::TemporaryFolder dir(parent, "lfi-mesh-bench");
  const Sphere sphere = uvSphere(segments);
  const fs::path ply = dir.path() / "sphere.ply", obj = dir.path() / "sphere.obj";
  writePly(ply, sphere);
  writeObj(obj, sphere);

  // Self-check: both files give the same mesh, and it bounds a solid.
  const sim::TriangleMesh fromPly = sim::loadMesh(ply), fromObj = sim::loadMesh(obj);
  if (fromPly.triangles.size() != fromObj.triangles.size() || fromPly.vertices.size() != fromObj.vertices.size())
    throw std::runtime_error(fmt::format(
        "self-check: the PLY loads as {} vertices and {} triangles, the OBJ as {} "
        "and {}",
        fromPly.vertices.size(), fromPly.triangles.size(), fromObj.vertices.size(), fromObj.triangles.size()));
  if (const auto fault = sim::meshClosureFault(fromPly))
    throw std::runtime_error("self-check: the sphere is not closed: " + *fault);

  std::vector<char> bytes;
  sim::TriangleMesh mesh;
  std::optional<std::string> fault;
  const auto s =
      secondsInTurns(turns, {[&] { bytes = readBytes(ply); }, [&] { mesh = sim::loadMesh(ply); },
                             [&] { mesh = sim::loadMesh(obj); }, [&] { fault = sim::meshClosureFault(fromPly); }});
  const double megabytes = static_cast<double>(fs::file_size(ply)) / 1e6;
  fmt::print("lfi-mesh-bench: UV sphere, {} vertices, {} triangles; binary PLY {:.1f} MB, OBJ {:.1f} MB; {} turns\n",
             sphere.vertices.size(), sphere.triangles.size(), megabytes, fs::file_size(obj) / 1e6, turns);
  fmt::print("  bound: the PLY's bytes read          {:9.2f} ms  {:6.0f} MB/s\n", 1e3 * bestOf(s, 0),
             megabytes / bestOf(s, 0));
  fmt::print("  loadMesh, binary PLY (lfi's reader)  {:9.2f} ms\n", 1e3 * bestOf(s, 1));
  fmt::print("  loadMesh, OBJ (Assimp)               {:9.2f} ms\n", 1e3 * bestOf(s, 2));
  fmt::print("  meshClosureFault (dielectric check)  {:9.2f} ms\n", 1e3 * bestOf(s, 3));
  auto ratio = [&](const char* label, size_t a, size_t b) {
    const auto r = spreadOf(ratiosByTurn(s, a, b));
    fmt::print("  ratio {:<34} {:7.2f}  (turns {:.2f}-{:.2f})\n", label, r.median, r.low, r.high);
  };
  ratio("PLY load / its bytes read", 1, 0);
  ratio("OBJ load (Assimp) / PLY load", 2, 1);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return lfi::bench::runGuarded("lfi-mesh-bench", [&] { return run(argc, argv); });
}
