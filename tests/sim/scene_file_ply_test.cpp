// SPDX-License-Identifier: Apache-2.0
// PLY mesh files (lfi's own reader): ASCII and both binary byte orders read
// alike, and corrupt or seeded-damaged files are errors naming file and place.

#include "lfi/sim/scene_file.h"

#include "lfi_test_support.h"
#include "scene_file_fixture.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::SceneFile;
using lfi::testing_support::throwsError;

// PLY bodies built byte by byte: values in either byte order.
class PlyBody {
 public:
  explicit PlyBody(bool bigEndian) : big_(bigEndian) {}
  template <typename T>
  PlyBody& put(T value) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &value, sizeof(T));
    if (big_) std::reverse(b, b + sizeof(T));
    bytes_.append(reinterpret_cast<const char*>(b), sizeof(T));
    return *this;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  bool big_;
  std::string bytes_;
};

// The octahedron's 6 vertices and 8 outward faces.
const double kOcta[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
const std::vector<std::vector<int>> kOctaFaces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                                  {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};

// A binary PLY of the octahedron with what a real exporter adds: a comment,
// a per-vertex colour, a second list on the faces and an element lfi skips.
std::string binaryOcta(bool bigEndian) {
  std::string text = fmt::format(
      "ply\nformat binary_{}_endian 1.0\ncomment from a test\nelement vertex 6\nproperty double x\n"
      "property uchar red\nproperty float y\nproperty float z\nelement face 8\n"
      "property list uchar int vertex_indices\nproperty list ushort float texcoord\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n",
      bigEndian ? "big" : "little");
  PlyBody body(bigEndian);
  for (const auto& v : kOcta)
    body.put(v[0]).put(std::uint8_t{200}).put(static_cast<float>(v[1])).put(static_cast<float>(v[2]));
  for (const auto& f : kOctaFaces) {
    body.put(static_cast<std::uint8_t>(f.size()));
    for (int i : f) body.put(std::int32_t{i});
    body.put(std::uint16_t{2}).put(0.25f).put(0.5f);
  }
  body.put(std::int32_t{0}).put(std::int32_t{1});
  return text + body.bytes();
}

TEST_F(SceneFile, PlyReadsAsciiAndBothBinaryByteOrdersAlike) {
  std::string ascii =
      "ply\r\nformat ascii 1.0\r\nelement vertex 6\r\nproperty float x\r\nproperty float y\r\n"
      "property float z\r\nelement face 7\r\nproperty list uchar int vertex_indices\r\nend_header\r\n";
  for (const auto& v : kOcta) ascii += fmt::format("{} {} {}\r\n", v[0], v[1], v[2]);
  ascii += "4 4 0 2 1\n";  // faces 0 and 1 as one quad, fanned from vertex 4 into (4 0 2) and (4 2 1)
  for (size_t f = 2; f < kOctaFaces.size(); ++f)
    ascii += fmt::format("3 {} {} {}\n", kOctaFaces[f][0], kOctaFaces[f][1], kOctaFaces[f][2]);
  write("octa.ply", ascii);
  write("little.ply", binaryOcta(false));
  write("big.ply", binaryOcta(true));
  for (const char* file : {"octa.ply", "little.ply", "big.ply"}) {
    SCOPED_TRACE(file);
    const TriangleMesh mesh = loadMesh(dir_ / file, std::numbers::pi);  // (no vertex repeated at a crease)
    ASSERT_EQ(mesh.vertices.size(), 6u);
    for (size_t i = 0; i < 6; ++i) EXPECT_EQ(mesh.vertices[i], Vec3(kOcta[i][0], kOcta[i][1], kOcta[i][2]));
    ASSERT_EQ(mesh.triangles.size(), 8u);
    // Every triangle winds outwards, and the smooth normals point along the vertices.
    for (const auto& t : mesh.triangles) {
      const Vec3 n = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      EXPECT_GT(n.dot(mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]), 0);
    }
    if (std::string(file) == "octa.ply") {
      EXPECT_EQ(mesh.triangles[0], (std::array<unsigned, 3>{4, 0, 2}));
      EXPECT_EQ(mesh.triangles[1], (std::array<unsigned, 3>{4, 2, 1}));
    }
    for (size_t f = 2; f < 8; ++f)
      EXPECT_EQ(mesh.triangles[f], (std::array<unsigned, 3>{static_cast<unsigned>(kOctaFaces[f][0]),
                                                            static_cast<unsigned>(kOctaFaces[f][1]),
                                                            static_cast<unsigned>(kOctaFaces[f][2])}));
  }
}

TEST_F(SceneFile, CorruptPlyIsAnErrorNamingFileAndPlace) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n";
  const std::string binary = binaryOcta(false);
  struct Case {
    std::string name, text;
    std::vector<std::string> fragments;
  };
  const std::vector<Case> cases = {
      // The shapes of the files that hung, aborted or crashed Debian's Assimp 5.2.5 (found by fuzzing).
      {"cut-in-header.ply", header.substr(0, 60), {"no 'end_header'"}},
      {"bad-end-header.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
       "eheader\n" +
           std::string(12, '\x7f'),
       {"line 5", "unknown header keyword 'eheader'"}},
      {"missing-face.ply", header + vertices, {"line 13", "face 0", "ends before"}},
      // An ASCII instance is one line: a row short of a value, or with one more, or rows past the counts.
      {"short-row.ply",
       header + "0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
       {"line 10", "property 'z' of vertex 0", "its line ends before it"}},
      {"long-row.ply",
       header + "0 0 0 5\n1 0 0\n0 1 0\n3 0 1 2\n",
       {"line 10", "vertex 0: '5' is a value past the element's declared properties"}},
      {"long-face.ply", header + vertices + "3 0 1 2 2\n", {"line 13", "face 0: '2' is a value past"}},
      {"extra-rows.ply", header + vertices + "3 0 1 2\n3 0 2 1\n", {"line 14", "values after the last element"}},
      {"negative-length.ply", header + vertices + "-1 0 1 2\n", {"face 0", "'-1' is not an integer"}},
      {"inf-length.ply", header + vertices + "-inf 0 1 2\n", {"'-inf' is not an integer"}},
      // Counts and indices the file cannot back.
      {"count-past-end.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\n"
       "property float y\nproperty float z\nelement face 0\n"
       "property list uchar int vertex_indices\nend_header\n0000",
       {"line 3", "'vertex' declares 1000000000 instances"}},
      {"index-out-of-range.ply", header + vertices + "3 0 1 7\n", {"vertex index 7 is not among the 3 vertices"}},
      {"long-list.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n" +
           std::string("\xff\xff\xff\x7f", 4),
       {"byte ", "a list of 2147483647 values does not fit"}},
      {"cut-in-body.ply", binary.substr(0, binary.size() - 17), {"byte ", "texcoord' of face 7", "ends inside"}},
      {"long-body.ply",
       binary + "\n" + std::string(13, '\0'),
       {"14 bytes after the last element", "count in the header"}},
      // Malformed headers and values.
      {"not-a-number.ply",
       header + "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n",
       {"line 11", "property 'y' of vertex 1", "'zero'"}},
      // Fewer bytes than the declared rows need (3 values and their separators each): named before reading.
      {"short-of-rows.ply", header + "0 0 0\n1 0 0\n", {"line 3", "'vertex' declares 3 instances"}},
      {"no-faces.ply",
       "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n",
       {"no 'face' element"}},
      {"no-format.ply", "ply\nelement vertex 0\nend_header\n", {"no 'format' line"}},
      {"unknown-type.ply",
       "ply\nformat ascii 1.0\nelement vertex 0\nproperty real x\nend_header\n",
       {"line 4", "unknown property type 'real'"}},
      {"binary-keyword.ply",
       "ply\nformat ascii 1.0\nelem\x01\xffnt vertex 0\nend_header\n",
       {"line 3", "'elem\\x01\\xffnt'"}},
      {"not-ply.ply", "solid cube\nendsolid cube\n", {"not a PLY file"}},
      // What only resembles PLY goes to lfi's reader, not to Assimp's PLY importer, whatever the name.
      {"upper.dat", "PLY\nformat ascii 1.0\nend_header\n", {"not a PLY file"}},
      {"bom.obj", "\xef\xbb\xbfply\nformat ascii 1.0\nend_header\n", {"not a PLY file"}},
      // Assimp would guess a file's format from its content, PLY among them: a file not named by a format it
      // knows is refused (here PLY after a newline, and a file with no extension, which Assimp also sniffs).
      {"newline-first.dat", "\nply\nformat ascii 1.0\nend_header\n", {"not a mesh format lfi reads", "'.dat'"}},
      {"no-extension", "plyX\nformat ascii 1.0\nend_header\n", {"not a mesh format lfi reads", "no extension"}},
      // A mesh must have a surface.
      {"flat.ply", header + "0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n", {"none of the mesh's 1 faces has an area"}},
      // A repeated element, which a reader could read past its property list (a case fuzzing found).
      {"two-faces.ply",
       header.substr(0, header.size() - 11) + "element face 1\nend_header\n" + vertices + "3 0 1 2\n",
       {"line 9", "a second 'face'"}},
      {"two-vertices.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "property float z\nelement vertex 1\nproperty float w\nend_header\n0 0 0\n1\n",
       {"line 7", "a second 'vertex'"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    write(c.name, c.text);
    std::vector<std::string> fragments = c.fragments;
    fragments.push_back((dir_ / c.name).string());
    EXPECT_TRUE(throwsError([&] { loadMesh(dir_ / c.name); }, Errc::InvalidFile, fragments));
  }
}

TEST_F(SceneFile, MutatedPlyFilesLoadCheckedOrAreNamedErrors) {
  // Seeded mutations of an ASCII and both binary octahedra (the kinds of
  // damage that crashed Assimp): byte changes, bit flips, cuts, repeated
  // bytes and repeated lines.
  // Each either loads as a mesh whose every index is in range and every
  // vertex finite, or is an lfi::Error naming the file; never a crash or hang.
  std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\n"
      "property float z\nelement face 8\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& v : kOcta) ascii += fmt::format("{} {} {}\n", v[0], v[1], v[2]);
  for (const auto& f : kOctaFaces) ascii += fmt::format("3 {} {} {}\n", f[0], f[1], f[2]);
  const std::string seeds[] = {ascii, binaryOcta(false), binaryOcta(true)};
  std::mt19937 rng(20261122);
  int loaded = 0, refused = 0;
  for (int n = 0; n < 1500; ++n) {
    std::string bytes = seeds[n % 3];
    for (int edits = 1 + static_cast<int>(rng() % 3); edits > 0; --edits) lfi::testing_support::damage(bytes, rng);
    const fs::path file = write("m.ply", bytes);
    try {
      const TriangleMesh mesh = loadMesh(file);
      for (const auto& t : mesh.triangles)
        for (unsigned i : t) ASSERT_LT(i, mesh.vertices.size()) << "case " << n;
      for (const Vec3& v : mesh.vertices) ASSERT_TRUE(std::isfinite(v.x + v.y + v.z)) << "case " << n;
      ++loaded;
    } catch (const Error& e) {
      ASSERT_NE(std::string(e.what()).find(file.string()), std::string::npos) << "case " << n << ": " << e.what();
      ++refused;
    }
  }
  // Both outcomes occur: the mutations reach past the header checks.
  EXPECT_GT(loaded, 50);
  EXPECT_GT(refused, 500);
}

}  // namespace
