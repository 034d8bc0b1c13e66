// SPDX-License-Identifier: Apache-2.0
// EXR files lfi must refuse, naming them: truncated, damaged or mutated bytes, sizes that
// would make OpenEXR allocate gigabytes, other OpenEXR layouts, and what is not an EXR file.

#include "exr_io_fixture.h"

#include "lfi/core/error.h"
#include "lfi_test_support.h"

#include "lfi/core/config.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdint>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace lfi::exr_test {
namespace {

using lfi::testing_support::throwsError;

// Where attribute `name` of `type` keeps its 4-byte size in an EXR header's
// bytes (its value follows); npos when there is no such attribute.
size_t attributeSizeAt(const std::string& bytes, const std::string& name, const std::string& type) {
  const std::string field = name + '\0' + type + '\0';
  const size_t at = bytes.find(field);
  return at == std::string::npos ? at : at + field.size();
}

std::string readBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}
void writeBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

TEST_F(ExrIo, TruncatedFileIsInvalid) {
  const LightFieldGeometry g = geometry();
  const fs::path valid = file("valid.exr");
  lfi::writeLightFieldExr(valid, LightField(g, randomFloats(g.height(), g.width(), 7)));
  const auto size = fs::file_size(valid);
  ASSERT_GT(size, 200u);
  for (const auto keep : {size - 1, size - 16, size / 2, std::uintmax_t{300}, std::uintmax_t{100}, std::uintmax_t{8},
                          std::uintmax_t{0}}) {
    const fs::path cut = file(fmt::format("cut-{}.exr", keep));
    fs::copy_file(valid, cut);
    fs::resize_file(cut, keep);
    EXPECT_TRUE(
        throwsError([&] { lfi::readLightFieldExr(cut); }, Errc::InvalidFile, {"'" + cut.string() + "'", "truncated"}))
        << "truncated to " << keep << " of " << size << " bytes";
  }
}

TEST_F(ExrIo, AttributeSizePastTheEndOfTheFileIsNamed) {
  // A few bytes can declare a huge attribute; OpenEXR would allocate it
  // (1.9 GB for a 2 KB file, found by fuzzing) before failing.
  lfi::writeRadianceExr(file("r.exr"), randomFloats(8, 8, 20), {0.01, "a description"});
  std::string bytes = readBytes(file("r.exr"));
  const size_t at = attributeSizeAt(bytes, "lfi.description", "string");
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 4, std::string("\x00\x00\x00\x70", 4));  // 0x70000000 bytes, little-endian
  std::ofstream(file("huge.exr"), std::ios::binary) << bytes;
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("huge.exr")); }, Errc::InvalidFile,
                          {file("huge.exr").string(), "'lfi.description'", "declares 1879048192 bytes"}));
}

TEST_F(ExrIo, AttributeSizeOtherThanItsValueTakesIsNamed) {
  // OpenEXR reads a compression or a channel list by its own length and parses the header's rest from where
  // it stopped: a larger declared size had it read a 1.9 GB string from inside the value (found by fuzzing).
  lfi::writeRadianceExr(file("r.exr"), randomFloats(8, 8, 22), {0.01, "sizes"});
  const std::string valid = readBytes(file("r.exr"));
  const auto withSize = [&](const char* name, const char* type, std::uint32_t declared) {
    std::string bytes = valid;
    const size_t at = attributeSizeAt(bytes, name, type);
    EXPECT_NE(at, std::string::npos) << name;
    for (int i = 0; i < 4; ++i) bytes[at + i] = static_cast<char>(declared >> (8 * i) & 0xff);
    std::ofstream(file("sized.exr"), std::ios::binary | std::ios::trunc) << bytes;
    return file("sized.exr");
  };
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(withSize("compression", "compression", 2)); }, Errc::InvalidFile,
                          {"'compression' of type 'compression' declares 2 bytes, its value takes 1"}));
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(withSize("channels", "chlist", 20)); }, Errc::InvalidFile,
                          {"'channels' of type 'chlist' declares 20 bytes, its value takes 19"}));
  // A channel list whose declared bytes end before its empty name: OpenEXR reads on into the header.
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(withSize("channels", "chlist", 18)); }, Errc::InvalidFile,
                          {"'channels' of type 'chlist' declares 18 bytes"}));
}

TEST_F(ExrIo, HugeDataWindowIsRefusedBeforeOpenExrSizesItsTables) {
  // A 2^28-row data window in a 1 KB file, with line-based and with DWAB
  // compression: refused by OpenEXR's own sanity check (the reader sets its
  // maximum image size), before the reader sizes its per-line tables.
  lfi::writeRadianceExr(file("r.exr"), randomFloats(8, 8, 21), {0.01, "tall"});
  std::string bytes = readBytes(file("r.exr"));
  const size_t window = attributeSizeAt(bytes, "dataWindow", "box2i");
  const size_t compressionAt = attributeSizeAt(bytes, "compression", "compression");
  ASSERT_NE(window, std::string::npos);
  ASSERT_NE(compressionAt, std::string::npos);
  bytes.replace(window + 4 + 12, 4, std::string("\xff\xff\xff\x0f", 4));  // ymax 2^28 - 1
  for (const char compression : {'\x03', '\x09'}) {                       // ZIP (as written), DWAB
    bytes[compressionAt + 4] = compression;
    std::ofstream(file("tall.exr"), std::ios::binary) << bytes;
    EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("tall.exr")); }, Errc::InvalidFile,
                            {file("tall.exr").string(), "height"}))
        << static_cast<int>(compression);
  }
}

TEST_F(ExrIo, MutatedFilesAreRefusedOrReadBackUnchanged) {
  // Seeded damage to a light field file: byte changes, bit flips, cuts and
  // repeats anywhere (OpenEXR's header, offsets, compressed pixels, lfi's
  // attributes). With the checksum over the attributes and the pixels, a
  // damaged file is either an lfi::Error naming it or, where the damage
  // touched nothing that is read, the very same light field.
  const LightFieldGeometry g = geometry();
  const LightField original(g, randomFloats(g.height(), g.width(), 19));
  lfi::writeLightFieldExr(file("seed.exr"), original);
  const std::string seed = readBytes(file("seed.exr"));
  std::mt19937 rng(20261122);
  int unchanged = 0, refused = 0;
  for (int n = 0; n < 400; ++n) {
    std::string bytes = seed;
    lfi::testing_support::damage(bytes, rng);
    const fs::path path = file("mutated.exr");
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
    try {
      const LightField loaded = lfi::readLightFieldExr(path);
      ASSERT_TRUE(loaded.geometry() == g) << "case " << n;
      ASSERT_TRUE(bitIdentical(loaded.lensletImage(), original.lensletImage())) << "case " << n;
      ++unchanged;
    } catch (const lfi::Error& e) {
      ASSERT_NE(std::string(e.what()).find(path.string()), std::string::npos) << "case " << n << ": " << e.what();
      ++refused;
    }
  }
  EXPECT_GT(refused, 300);
  EXPECT_GT(unchanged, 0);  // damage to bytes nothing reads (OpenEXR's header padding, say) is harmless
}

TEST_F(ExrIo, FileThatIsNotExrIsInvalid) {
  const fs::path path = file("notes.exr");
  std::ofstream(path) << "this is a text file, not an OpenEXR image\n";
  // lfi names the file itself (quoted), not only through OpenEXR's message.
  const std::string quoted = "'" + path.string() + "'";
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(path); }, Errc::InvalidFile, {quoted, "OpenEXR"}));
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(path); }, Errc::InvalidFile, {quoted, "OpenEXR"}));
  // A directory is not an EXR file either.
  fs::create_directory(file("dir.exr"));
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("dir.exr")); }, Errc::InvalidFile, {"dir.exr"}));
}

TEST_F(ExrIo, MissingFileIsNotFound) {
  const fs::path path = file("nothing-here.exr");
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(path); }, Errc::NotFound, {path.string()}));
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(path); }, Errc::NotFound, {path.string()}));
}

// Not files: a FIFO (a reader would wait on it for ever) and a directory.
TEST_F(ExrIo, WhatIsNotARegularFileIsNamed) {
  const fs::path fifo = file("pipe.exr");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(fifo); }, Errc::InvalidFile, {"pipe.exr", "a FIFO"}));
  EXPECT_TRUE(throwsError([&] { lfi::ConfigTable::parseFile(fifo); }, Errc::InvalidFile, {"pipe.exr"}));
  fs::create_directory(file("d.toml"));
  EXPECT_TRUE(throwsError([&] { lfi::ConfigTable::parseFile(file("d.toml")); }, Errc::InvalidFile, {"d.toml"}));
  EXPECT_TRUE(throwsError([&] { lfi::ConfigTable::parseFile(file("none.toml")); }, Errc::NotFound, {"none.toml"}));
}

// lfi writes single-part scanline files with one channel, Y. OpenEXR reads
// others; lfi refuses them, naming what they are (a second part's header was
// read unchecked, and a 1 KB file could ask for gigabytes).
TEST_F(ExrIo, OtherKindsOfOpenExrFileAreRefused) {
  const LightFieldGeometry g = geometry();
  const fs::path path = file("lf.exr");
  lfi::writeLightFieldExr(path, LightField(g, randomFloats(g.height(), g.width(), 17)));
  const std::string original = readBytes(path);
  for (const auto& [flag, name] : {std::pair{0x02, "tiled"}, std::pair{0x08, "deep"}, std::pair{0x10, "multi-part"}}) {
    std::string bytes = original;
    bytes[5] = static_cast<char>(bytes[5] | flag);
    writeBytes(path, bytes);
    EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(path); }, Errc::InvalidFile, {"lf.exr", name})) << name;
  }
  // A second channel beside Y.
  Imf::Header header(4, 4);
  header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
  header.channels().insert("Z", Imf::Channel(Imf::FLOAT));
  header.insert("lfi.kind", Imf::StringAttribute("radiance-image"));
  header.insert("lfi.formatVersion", Imf::IntAttribute(2));
  std::vector<float> pixels(16, 1.0f);
  {
    Imf::OutputFile out(file("yz.exr").c_str(), header);
    Imf::FrameBuffer frame;
    frame.insert("Y", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(pixels.data()), sizeof(float), 4 * sizeof(float)));
    frame.insert("Z", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(pixels.data()), sizeof(float), 4 * sizeof(float)));
    out.setFrameBuffer(frame);
    out.writePixels(4);
  }
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("yz.exr")); }, Errc::InvalidFile, {"yz.exr", "2 channel"}));
}

}  // namespace
}  // namespace lfi::exr_test
