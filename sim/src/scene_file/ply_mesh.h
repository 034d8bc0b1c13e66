// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim: a reader for Stanford PLY meshes (ASCII and binary,
// either byte order), written for untrusted files. Debian's Assimp 5.2.5 hangs,
// aborts (its assertions are on) or crashes on some corrupt PLY headers and
// counts (found by fuzzing), so PLY files do not reach it: every count, type,
// length and index here is checked against the file before it is used, and
// each error names the file and the line (ASCII, header) or byte offset
// (binary body).
//
// What is read: the `vertex` element's x, y, z (any numeric type) and the
// `face` element's `vertex_indices` (or `vertex_index`) list; polygons of n > 3
// vertices are fanned into n - 2 triangles, faces of fewer than 3 vertices
// (points, lines) have no surface and are dropped; every other element and
// property is skipped. A second `vertex` or `face` element is an error.

#include "lfi/sim/scene.h"

#include <cstdint>
#include <filesystem>
#include <string_view>

namespace lfi::sim::detail {

// True when `head` (the file's first bytes) starts with the PLY magic line.
bool isPly(std::string_view head);
// True also for what only resembles it ("PLY", a byte order mark before it):
// such a file is read, and refused, by lfi's reader, never by Assimp's PLY
// importer (which fuzzing hung and crashed).
bool looksLikePly(std::string_view head);

// The most triangles a mesh file may make (a 100 MB file may fan one face into
// 10^8 of them): 2^26, about 5 GB of triangles, normals and their bookkeeping
// while loading; an optical part's mesh has far fewer.
inline constexpr std::uint64_t kMostTriangles = std::uint64_t{1} << 26;

// The mesh's vertices and triangles (no normals). Throws Errc::InvalidFile.
TriangleMesh readPly(const std::filesystem::path& path);

}  // namespace lfi::sim::detail
