// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim's scene file reader: what its files share. The mesh
// helpers serve loading a mesh, checking that it bounds a solid and telling
// whether a sensor's rays start inside it; the table readers serve the scene
// file and its [[object]] tables.

#include "lfi/core/config.h"
#include "lfi/sim/scene.h"

#include <algorithm>
#include <array>
#include <limits>
#include <vector>

namespace lfi::sim::detail {

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
Box bounds(const TriangleMesh& mesh);

// One id per position, within `tolerance` (Chebyshev) of each other, on a grid
// of cells of that size (offset by an odd fraction of a cell, so that meshes
// symmetric about 0 do not straddle a cell wall there). Any two vertices in one
// cell are that close, so the cell's first vertex stands for it. With
// `neighbours`, a vertex also joins the first one within the tolerance in the
// 26 neighbouring cells (slower: a hash look-up each).
std::vector<unsigned> weldVertices(const TriangleMesh& mesh, double tolerance, bool neighbours);

// Vertices within a float's precision of the mesh's size are one: formats that
// repeat a vertex per face (STL, seams) and rings of vertices at a sphere's
// pole still close. (Of the size, or of the distance from the origin where that
// is larger: a float's step grows with it.) Infinite for vertices that are not.
double weldTolerance(const TriangleMesh& mesh);

// Whether a ray from p in a fixed, unremarkable direction crosses triangle t
// (Möller–Trumbore): the parity of such crossings over a closed surface says
// whether p is inside it.
bool parityRayCrosses(const TriangleMesh& mesh, const std::array<unsigned, 3>& t, const Vec3& p);

// position_mm and rotation_deg of a table (by default the origin, unturned).
Rigid3 readPlacement(ConfigTable& t);

// One [[object]] table: its shape (a solid with its cut-outs, a rectangle or a
// mesh file), material and emitter.
Object readObject(ConfigTable& t);

}  // namespace lfi::sim::detail
