// SPDX-License-Identifier: Apache-2.0
// Whether a mesh bounds a solid the tracer can enter and leave
// (meshClosureFault): with vertices within a float's precision welded, every
// edge crossed once each way, and each part wound outwards (a cavity inwards).

#include "lfi/sim/scene_file.h"

#include "scene_file_internal.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

namespace lfi::sim::detail {

Box bounds(const TriangleMesh& mesh) {
  Box box;
  for (const auto& t : mesh.triangles)
    for (const unsigned i : t) box.add(mesh.vertices[i]);
  if (mesh.triangles.empty()) box.low = box.high = Vec3(0, 0, 0);
  return box;
}

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
      welded[order[i].second] =
          i > 0 && order[i].first == order[i - 1].first ? welded[order[i - 1].second] : order[i].second;
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

double weldTolerance(const TriangleMesh& mesh) {
  const auto [low, high] = bounds(mesh);
  const double extent = std::max({high.x - low.x, high.y - low.y, high.z - low.z, std::abs(low.x), std::abs(low.y),
                                  std::abs(low.z), std::abs(high.x), std::abs(high.y), std::abs(high.z)});
  if (!std::isfinite(extent)) return std::numeric_limits<double>::infinity();
  return extent > 0 ? 1e-7 * extent : 1.0;
}

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

namespace {

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
  // that a point is tested against the parts near it, not every part (which
  // is quadratic in the parts: 2 s for a mesh of 22 500 separate beads). A box
  // over more than kLargeCells cells is listed apart and tested for every point.
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
    for (const unsigned other :
         cells[(static_cast<size_t>(cellOf(p.x, 0)) * side + cellOf(p.y, 1)) * side + cellOf(p.z, 2)])
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
      return fmt::format(
          "a part wound the wrong way: the closed surface through triangle {} (counting from 0; "
          "corners {}, {}, {}) encloses {:.6g} mm^3 and lies inside {} of the mesh's other {} parts: "
          "{} (reverse its triangles' vertex order)",
          list.front(), at(t[0]), at(t[1]), at(t[2]), volume6[k] / 6, around, triangles.size() - 1,
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
      const std::string which = fmt::format("the edge from {} to {} (triangle {}, counting from 0)", at(tri[c.corner]),
                                            at(tri[(c.corner + 1) % 3]), c.triangle);
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
                                           "triangle's vertex order)",
                                           volume6 / 6)};
  if (auto fault = partWindingFault(mesh, crossings)) return ClosureFault{false, std::move(*fault)};
  return std::nullopt;
}

}  // namespace

}  // namespace lfi::sim::detail

namespace lfi::sim {

std::optional<std::string> meshClosureFault(const TriangleMesh& mesh) {
  // The quick weld first; the thorough one when that leaves the mesh open (two
  // such vertices on either side of a cell wall).
  const double tolerance = detail::weldTolerance(mesh);
  if (!std::isfinite(tolerance)) {
    const auto [low, high] = detail::bounds(mesh);
    return fmt::format("not measurable: its vertices span from ({:g}, {:g}, {:g}) to ({:g}, {:g}, {:g})", low.x, low.y,
                       low.z, high.x, high.y, high.z);
  }
  auto fault = detail::closureFault(mesh, detail::weldVertices(mesh, tolerance, false));
  if (fault && fault->open) fault = detail::closureFault(mesh, detail::weldVertices(mesh, tolerance, true));
  if (!fault) return std::nullopt;
  return std::move(fault->why);
}

}  // namespace lfi::sim
