#include "lfi/core/exr_io.h"

#include "lfi/core/config.h"
#include "lfi/core/error.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfDoubleAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfThreading.h>
#include <OpenEXR/ImfVecAttribute.h>
#include <fmt/format.h>
#include "lfi_test_support.h"

#include <gtest/gtest.h>
#include <sched.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;
using lfi::Errc;
using lfi::LightField;
using lfi::LightFieldGeometry;

using lfi::testing_support::throwsError;

// A fresh directory per test, removed with everything in it at the end.
class ExrIo : public testing::Test {
protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    dir_ =
        fs::path(testing::TempDir()) / fmt::format("lfi-exr-{}-{}-{}", info->name(), ::getpid(), counter.fetch_add(1));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  fs::path file(const std::string& name) const { return dir_ / name; }

  fs::path dir_;
};

LightFieldGeometry geometry() {
  LightFieldGeometry g;
  g.spatialX = 5;
  g.spatialY = 3;
  g.angular = 4;
  g.pixelPitch_mm = 0.0375;
  g.distance_mm = 17.25;
  return g;
}

// Random finite, non-negative floats over the whole bit range (all exponents, denormals, +0).
cv::Mat randomFloats(int rows, int cols, unsigned seed) {
  cv::Mat m(rows, cols, CV_32FC1);
  std::mt19937 rng(seed);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      float x;
      do {
        x = std::bit_cast<float>(static_cast<std::uint32_t>(rng()) & 0x7fffffffu);  // (radiance: not negative)
      } while (!std::isfinite(x));
      m.at<float>(r, c) = x;
    }
  return m;
}

cv::Mat specialFloats(int rows, int cols, unsigned seed, bool negatives = true) {
  cv::Mat m = randomFloats(rows, cols, seed);
  using L = std::numeric_limits<float>;
  const float specials[] = {0.0f,      -0.0f,        L::denorm_min(), -L::denorm_min(), L::min() / 3,
                            -L::min(), L::min(),     L::max(),        L::lowest(),      1.0f,
                            -1.0f,     L::epsilon(), -123.456f,       1e-30f,           -1e30f};
  int at = 0;
  for (const float x : specials)
    if (negatives || !(x < 0)) m.at<float>(at / cols, at % cols) = x, ++at;  // (-0 is not negative)
  return m;
}

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

bool bitIdentical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int r = 0; r < a.rows; ++r)
    if (std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()) != 0) return false;
  return true;
}

std::string checksumText(unsigned long crc) { return fmt::format("crc32:{:08x}", crc); }
std::string checksumText(const cv::Mat& pixels) {
  return checksumText(lfi::pixelChecksum(pixels));
}

// The canonical text of a header's lfi attributes, as docs/file-formats.md
// defines it: every lfi.* attribute but lfi.checksum, by name, one line each.
std::string canonicalText(const Imf::Header& header) {
  std::string text;
  for (auto it = header.begin(); it != header.end(); ++it) {
    const std::string name = it.name();
    if (!name.starts_with("lfi.") || name == "lfi.checksum") continue;
    if (const auto* i = dynamic_cast<const Imf::IntAttribute*>(&it.attribute()))
      text += fmt::format("{} int {}\n", name, i->value());
    else if (const auto* d = dynamic_cast<const Imf::DoubleAttribute*>(&it.attribute()))
      text += fmt::format("{} double {}\n", name, d->value());
    else if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
      text += fmt::format("{} string {}:{}\n", name, s->value().size(), s->value());
  }
  return text;
}

// Writes an EXR with the OpenEXR API directly: one FLOAT channel "Y" with the given
// pixels and the header as prepared by `edit` (which may add or leave out attributes).
// Unless `edit` records one, lfi.checksum is the correct version 2 checksum.
void writeRawExr(const fs::path& path, const cv::Mat& pixels, const std::function<void(Imf::Header&)>& edit) {
  Imf::Header header(pixels.cols, pixels.rows);
  header.compression() = Imf::ZIP_COMPRESSION;
  header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
  edit(header);
  if (!header.findTypedAttribute<Imf::StringAttribute>("lfi.checksum"))
    header.insert("lfi.checksum", Imf::StringAttribute(checksumText(lfi::fileChecksum(canonicalText(header), pixels))));
  Imf::OutputFile out(path.c_str(), header);
  Imf::FrameBuffer frame;
  frame.insert("Y", Imf::Slice(Imf::FLOAT, const_cast<char*>(pixels.ptr<char>()), sizeof(float), pixels.step));
  out.setFrameBuffer(frame);
  out.writePixels(pixels.rows);
}

// The conventions a light field file states in words (docs/file-formats.md).
const char* kLightFieldFrame =
    "plane frame: origin at the grid centre, +z the viewing/emitting side; pixel (col,row) = (ex*n+u, ey*n+v), row "
    "increases with +y";
const char* kLightFieldParametrisation =
    "lenslet image of SxxSy spatial elements of nxn angular elements; in-element position (px,py) in [-1,1]^2 sees "
    "direction normalise(-px,-py,sqrt(1-px^2-py^2)); px^2+py^2>=1 is 0";
const char* kLightFieldUnits = "lengths mm, angles rad, pixels linear relative radiance";

// All but `leftOut`. (Not inserted and erased: OpenEXR 3.1's Header::erase leaks the attribute.)
void insertConventions(Imf::Header& h, const std::string& leftOut = {}) {
  for (const auto& [name, text] : {std::pair{"lfi.frame", kLightFieldFrame},
                                   {"lfi.parametrisation", kLightFieldParametrisation},
                                   {"lfi.units", kLightFieldUnits}})
    if (name != leftOut) h.insert(name, Imf::StringAttribute(text));
}

// The attributes of a light field file as lfi writes them, each optional.
struct RawLightFieldAttributes {
  LightFieldGeometry geometry = ::geometry();
  bool withAngular = true;
  std::string checksum;  // empty: the correct one
  std::function<void(Imf::Header&)> conventions = [](Imf::Header& h) { insertConventions(h); };  // lfi.frame, ...
};

void writeRawLightField(const fs::path& path, const cv::Mat& pixels, const RawLightFieldAttributes& a) {
  writeRawExr(path, pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(lfi::kExrFormatVersion));
    if (!a.checksum.empty()) h.insert("lfi.checksum", Imf::StringAttribute(a.checksum));
    h.insert("lfi.spatialX", Imf::IntAttribute(a.geometry.spatialX));
    h.insert("lfi.spatialY", Imf::IntAttribute(a.geometry.spatialY));
    if (a.withAngular) h.insert("lfi.angular", Imf::IntAttribute(a.geometry.angular));
    h.insert("lfi.pixelPitch_mm", Imf::DoubleAttribute(a.geometry.pixelPitch_mm));
    h.insert("lfi.distance_mm", Imf::DoubleAttribute(a.geometry.distance_mm));
    a.conventions(h);
  });
}

TEST_F(ExrIo, LightFieldRoundTripIsBitExact) {
  const LightFieldGeometry g = geometry();
  const LightField original(g, specialFloats(g.height(), g.width(), 1, false));
  const fs::path path = file("lf.exr");
  lfi::writeLightFieldExr(path, original);
  const LightField loaded = lfi::readLightFieldExr(path);
  EXPECT_EQ(loaded.geometry().spatialX, g.spatialX);
  EXPECT_EQ(loaded.geometry().spatialY, g.spatialY);
  EXPECT_EQ(loaded.geometry().angular, g.angular);
  EXPECT_EQ(loaded.geometry().pixelPitch_mm, g.pixelPitch_mm);  // exact: stored as double
  EXPECT_EQ(loaded.geometry().distance_mm, g.distance_mm);
  EXPECT_TRUE(loaded.geometry() == g);
  EXPECT_TRUE(bitIdentical(loaded.lensletImage(), original.lensletImage()));
  // Negative zero and denormals survive (a value comparison would not notice a lost sign of zero).
  EXPECT_TRUE(std::signbit(loaded.lensletImage().at<float>(0, 1)));
  EXPECT_EQ(loaded.lensletImage().at<float>(0, 2), std::numeric_limits<float>::denorm_min());
}

TEST_F(ExrIo, LightFieldRoundTripWithNonContinuousImageAndOneByOneElements) {
  LightFieldGeometry g = geometry();
  g.spatialX = 7;
  g.spatialY = 1;
  g.angular = 1;
  g.distance_mm = 0;
  // A region of a larger image: rows are not contiguous in memory.
  const cv::Mat big = randomFloats(9, 20, 2);
  const LightField original(g, big(cv::Rect(3, 4, 7, 1)));
  ASSERT_FALSE(big(cv::Rect(3, 4, 7, 2)).isContinuous());
  lfi::writeLightFieldExr(file("roi.exr"), original);
  const LightField loaded = lfi::readLightFieldExr(file("roi.exr"));
  EXPECT_TRUE(loaded.geometry() == g);
  EXPECT_TRUE(bitIdentical(loaded.lensletImage(), original.lensletImage()));
}

TEST_F(ExrIo, RadianceRoundTripKeepsPixelsAndInfo) {
  const cv::Mat big = specialFloats(40, 60, 3);
  const cv::Mat image = big(cv::Rect(5, 2, 33, 31));  // odd size, not continuous
  lfi::RadianceImageInfo info;
  info.objectPixel_mm = 0.00345;
  info.description = "lens N-BK7, parallel illumination, 64 spp";
  lfi::writeRadianceExr(file("r.exr"), image, info);
  lfi::RadianceImageInfo loadedInfo;
  const cv::Mat loaded = lfi::readRadianceExr(file("r.exr"), &loadedInfo);
  EXPECT_TRUE(bitIdentical(loaded, image));
  EXPECT_EQ(loadedInfo.objectPixel_mm, info.objectPixel_mm);
  EXPECT_EQ(loadedInfo.description, info.description);
  EXPECT_EQ(loadedInfo.pixelUnit, "linear relative radiance");  // the default
  // The info is optional.
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(file("r.exr")), image));
  // A camera frame says its pixels are digital numbers, in lfi.units.
  info.pixelUnit = "camera digital numbers (DN)";
  lfi::writeRadianceExr(file("dn.exr"), image, info);
  lfi::readRadianceExr(file("dn.exr"), &loadedInfo);
  EXPECT_EQ(loadedInfo.pixelUnit, info.pixelUnit);
  EXPECT_EQ(Imf::InputFile(file("dn.exr").c_str()).header().typedAttribute<Imf::StringAttribute>("lfi.units").value(),
            "lengths mm, angles rad, pixels camera digital numbers (DN)");
  info.pixelUnit.clear();
  EXPECT_TRUE(throwsError([&] { lfi::writeRadianceExr(file("none.exr"), image, info); }, Errc::InvalidArgument,
                          {"none.exr", "unit"}));
}

TEST_F(ExrIo, KindsAreNotInterchangeable) {
  const LightFieldGeometry g = geometry();
  lfi::writeLightFieldExr(file("lf.exr"), LightField(g, randomFloats(g.height(), g.width(), 4)));
  lfi::writeRadianceExr(file("r.exr"), randomFloats(8, 8, 5), {});
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("lf.exr")); }, Errc::InvalidFile,
                          {file("lf.exr").string(), "lfi.kind", "light-field"}));
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("r.exr")); }, Errc::InvalidFile,
                          {file("r.exr").string(), "lfi.kind", "radiance-image"}));
}

TEST_F(ExrIo, RawWriterProducesReadableFiles) {
  // Control for the failure tests below: the hand-written file is accepted when nothing is wrong.
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 6);
  writeRawLightField(file("raw.exr"), pixels, {});
  const LightField loaded = lfi::readLightFieldExr(file("raw.exr"));
  EXPECT_TRUE(loaded.geometry() == g);
  EXPECT_TRUE(bitIdentical(loaded.lensletImage(), pixels));
}

// A file that states another convention, or none, is refused: lfi would read
// it in its own and get every ray wrong.
TEST_F(ExrIo, ALightFieldInAnotherParametrisationIsRefused) {
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 40);
  struct Case {
    std::string name, attribute;
    std::optional<std::string> value;  // none: left out
    std::string says;
  };
  const std::vector<Case> cases = {
      {"no-frame", "lfi.frame", std::nullopt, "missing"},
      {"z-away", "lfi.frame", "plane frame: +z away from the part", "not lfi's convention"},
      {"no-parametrisation", "lfi.parametrisation", std::nullopt, "missing"},
      {"two-plane", "lfi.parametrisation", "two-plane (u,v,s,t)", "not lfi's convention"},
      {"inches", "lfi.units", "lengths in, angles deg, pixels linear relative radiance", "not lfi's convention"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    RawLightFieldAttributes a;
    a.conventions = [&](Imf::Header& h) {
      insertConventions(h, c.attribute);
      if (c.value) h.insert(c.attribute, Imf::StringAttribute(*c.value));
    };
    writeRawLightField(file(c.name + ".exr"), pixels, a);  // (with the checksum of what it says)
    EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file(c.name + ".exr")); }, Errc::InvalidFile,
                            {file(c.name + ".exr").string(), "'" + c.attribute + "'", c.says}));
  }
}

// The same for a radiance image: its frame in lfi's words, and units with a pixel unit after lfi's prefix.
TEST_F(ExrIo, ARadianceImageInAnotherConventionIsRefused) {
  const cv::Mat pixels = randomFloats(6, 5, 41);
  auto write = [&](const std::string& name, const std::string& frame, const std::string& units) {
    writeRawExr(file(name), pixels, [&](Imf::Header& h) {
      h.insert("lfi.kind", Imf::StringAttribute("radiance-image"));
      h.insert("lfi.formatVersion", Imf::IntAttribute(lfi::kExrFormatVersion));
      h.insert("lfi.objectPixel_mm", Imf::DoubleAttribute(0.1));
      h.insert("lfi.frame", Imf::StringAttribute(frame));
      h.insert("lfi.units", Imf::StringAttribute(units));
    });
  };
  const std::string frame = "camera image: row 0 at world +y, columns along world +x";
  write("good.exr", frame, "lengths mm, angles rad, pixels camera digital numbers (DN)");
  lfi::RadianceImageInfo info;
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(file("good.exr"), &info), pixels));
  EXPECT_EQ(info.pixelUnit, "camera digital numbers (DN)");
  write("flipped.exr", "camera image: row 0 at world -y", "lengths mm, angles rad, pixels linear relative radiance");
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("flipped.exr")); }, Errc::InvalidFile,
                          {file("flipped.exr").string(), "'lfi.frame'", "not lfi's convention"}));
  write("inches.exr", frame, "lengths in, pixels linear relative radiance");
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("inches.exr")); }, Errc::InvalidFile,
                          {file("inches.exr").string(), "'lfi.units'"}));
  write("no-unit.exr", frame, "lengths mm, angles rad, pixels ");
  EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("no-unit.exr")); }, Errc::InvalidFile,
                          {file("no-unit.exr").string(), "'lfi.units'"}));
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
  for (const char compression : {'\x03', '\x09'}) {  // ZIP (as written), DWAB
    bytes[compressionAt + 4] = compression;
    std::ofstream(file("tall.exr"), std::ios::binary) << bytes;
    EXPECT_TRUE(throwsError([&] { lfi::readRadianceExr(file("tall.exr")); }, Errc::InvalidFile,
                            {file("tall.exr").string(), "height"}))
        << static_cast<int>(compression);
  }
}

TEST_F(ExrIo, MissingAttributeIsNamed) {
  const LightFieldGeometry g = geometry();
  RawLightFieldAttributes a;
  a.withAngular = false;
  writeRawLightField(file("no-angular.exr"), randomFloats(g.height(), g.width(), 8), a);
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("no-angular.exr")); }, Errc::InvalidFile,
                          {file("no-angular.exr").string(), "lfi.angular", "missing"}));
}

TEST_F(ExrIo, MistypedAttributeIsNamed) {
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 9);
  // pixelPitch_mm as a string instead of a double.
  writeRawExr(file("typed.exr"), pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(lfi::kExrFormatVersion));
    h.insert("lfi.spatialX", Imf::IntAttribute(g.spatialX));
    h.insert("lfi.spatialY", Imf::IntAttribute(g.spatialY));
    h.insert("lfi.angular", Imf::IntAttribute(g.angular));
    h.insert("lfi.pixelPitch_mm", Imf::StringAttribute("0.0375"));
    h.insert("lfi.distance_mm", Imf::DoubleAttribute(g.distance_mm));
  });
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("typed.exr")); }, Errc::InvalidFile,
                          {"lfi.pixelPitch_mm", "string", "double"}));
}

TEST_F(ExrIo, OutOfRangeAttributeIsInvalidFile) {
  RawLightFieldAttributes a;
  a.geometry.angular = 0;
  a.geometry.spatialX = 20;  // keeps width() = 0 != 20 out of the way: validation comes first
  writeRawLightField(file("zero.exr"), randomFloats(12, 20, 10), a);
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("zero.exr")); }, Errc::InvalidFile,
                          {file("zero.exr").string(), "angular"}));
}

TEST_F(ExrIo, SizeThatDoesNotMatchAttributesIsNamed) {
  const LightFieldGeometry g = geometry();                             // needs 20x12
  const cv::Mat pixels = randomFloats(g.height(), g.width() + 4, 11);  // 24x12
  writeRawLightField(file("size.exr"), pixels, {});
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("size.exr")); }, Errc::InvalidFile,
                          {file("size.exr").string(), "24x12", "20x12"}));
}

TEST_F(ExrIo, NonFinitePixelIsNamed) {
  const LightFieldGeometry g = geometry();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<std::pair<std::string, float>> cases = {
      {"nan", std::numeric_limits<float>::quiet_NaN()}, {"inf", inf}, {"minus-inf", -inf}};
  for (const auto& [name, bad] : cases) {
    cv::Mat pixels = randomFloats(g.height(), g.width(), 12);
    pixels.at<float>(7, 13) = bad;  // row 7, column 13
    const fs::path path = file(name + ".exr");
    writeRawLightField(path, pixels, {});  // with the correct checksum of these pixels
    EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(path); }, Errc::InvalidFile,
                            {path.string(), "pixel (13, 7)", "finite"}))
        << name;
  }
  // Negative radiance: refused by the reader, and by the writer and the light field before it.
  cv::Mat pixels = randomFloats(g.height(), g.width(), 13);
  pixels.at<float>(3, 5) = -0.25f;
  writeRawLightField(file("negative.exr"), pixels, {});
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("negative.exr")); }, Errc::InvalidFile,
                          {file("negative.exr").string(), "pixel (5, 3) is -0.25", "cannot be negative"}));
  EXPECT_TRUE(throwsError([&] { LightField(g, pixels); }, Errc::InvalidArgument, {"(5, 3)", "cannot be negative"}));
  LightField field(g, randomFloats(g.height(), g.width(), 14));
  field.lensletImage().at<float>(3, 5) = -1;  // changed after the check
  EXPECT_TRUE(throwsError([&] { lfi::writeLightFieldExr(file("negative-out.exr"), field); }, Errc::InvalidArgument,
                          {"negative-out.exr", "(5, 3)", "cannot be negative"}));
  EXPECT_FALSE(fs::exists(file("negative-out.exr")));
}

// Writes `pixels` under `header` as it is (its recorded checksum included).
void rewrite(const fs::path& path, const Imf::Header& header, const cv::Mat& pixels) {
  Imf::OutputFile out(path.c_str(), header);
  Imf::FrameBuffer frame;
  frame.insert("Y", Imf::Slice(Imf::FLOAT, const_cast<char*>(pixels.ptr<char>()), sizeof(float), pixels.step));
  out.setFrameBuffer(frame);
  out.writePixels(pixels.rows);
}

TEST_F(ExrIo, ModifiedPixelFailsChecksum) {
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 13);
  const fs::path valid = file("valid.exr");
  lfi::writeLightFieldExr(valid, LightField(g, pixels));
  ASSERT_NO_THROW(lfi::readLightFieldExr(valid));
  // Keep lfi's header (with its checksum) as it is; change one pixel by one ulp.
  const Imf::Header header = Imf::InputFile(valid.c_str()).header();
  cv::Mat tampered = pixels.clone();
  tampered.at<float>(5, 9) = std::nextafter(tampered.at<float>(5, 9), std::numeric_limits<float>::max());
  const fs::path path = file("tampered.exr");
  rewrite(path, header, tampered);
  const std::string recorded = header.typedAttribute<Imf::StringAttribute>("lfi.checksum").value();
  EXPECT_EQ(recorded, checksumText(lfi::fileChecksum(canonicalText(header), pixels)));
  EXPECT_TRUE(throwsError(
      [&] { lfi::readLightFieldExr(path); }, Errc::Checksum,
      {path.string(), "lfi.checksum", recorded, checksumText(lfi::fileChecksum(canonicalText(header), tampered))}));
}

TEST_F(ExrIo, ModifiedAttributeFailsChecksum) {
  // One changed byte of a double moved the display distance from 30 to 3 mm
  // and went unnoticed while the checksum covered only the pixels (fuzzing,
  // session 8). Each lfi attribute is covered now, with the pixels intact.
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 14);
  const fs::path lightField = file("lf.exr"), radiance = file("r.exr");
  lfi::writeLightFieldExr(lightField, LightField(g, pixels));
  lfi::writeRadianceExr(radiance, pixels, {0.00345, "parallel illumination"});
  const std::vector<std::pair<fs::path, std::function<void(Imf::Header&)>>> edits = {
      {lightField, [](Imf::Header& h) { h.typedAttribute<Imf::DoubleAttribute>("lfi.distance_mm").value() /= 10; }},
      {lightField, [](Imf::Header& h) { h.typedAttribute<Imf::DoubleAttribute>("lfi.pixelPitch_mm").value() *= 2; }},
      {lightField, [](Imf::Header& h) { h.typedAttribute<Imf::StringAttribute>("lfi.frame").value() += " "; }},
      {lightField, [](Imf::Header& h) { h.insert("lfi.note", Imf::StringAttribute("added")); }},
      {radiance, [](Imf::Header& h) { h.typedAttribute<Imf::DoubleAttribute>("lfi.objectPixel_mm").value() = 0.01; }},
      {radiance, [](Imf::Header& h) { h.typedAttribute<Imf::StringAttribute>("lfi.description").value() = "area"; }},
  };
  int n = 0;
  for (const auto& [original, edit] : edits) {
    Imf::Header header = Imf::InputFile(original.c_str()).header();
    edit(header);
    const fs::path path = file(fmt::format("edited-{}.exr", n++));
    rewrite(path, header, pixels);
    const auto read = [&] {
      if (original == lightField)
        lfi::readLightFieldExr(path);
      else
        lfi::readRadianceExr(path);
    };
    EXPECT_TRUE(throwsError(read, Errc::Checksum, {path.string(), "lfi attributes or pixel data"})) << path;
  }
}

TEST_F(ExrIo, ChecksumIsCrc32OfTheCanonicalAttributesThenThePixels) {
  // The canonical text of docs/file-formats.md, spelled out for a small header.
  Imf::Header header(1, 1);
  header.insert("lfi.kind", Imf::StringAttribute("light-field"));
  header.insert("lfi.formatVersion", Imf::IntAttribute(2));
  header.insert("lfi.checksum", Imf::StringAttribute("crc32:00000000"));
  header.insert("lfi.distance_mm", Imf::DoubleAttribute(17.25));
  header.insert("lfi.pixelPitch_mm", Imf::DoubleAttribute(0.1));
  header.insert("other", Imf::StringAttribute("not lfi's"));
  EXPECT_EQ(canonicalText(header),
            "lfi.distance_mm double 17.25\nlfi.formatVersion int 2\nlfi.kind string 11:light-field\n"
            "lfi.pixelPitch_mm double 0.1\n");
  // CRC-32 of "123456789" is 0xcbf43926; the pixels go on from the text's CRC.
  const cv::Mat pixels = randomFloats(3, 4, 15);
  EXPECT_EQ(lfi::fileChecksum("123456789", cv::Mat()), 0xcbf43926ul);
  EXPECT_EQ(lfi::fileChecksum("", pixels), lfi::pixelChecksum(pixels));
  EXPECT_EQ(lfi::fileChecksum("123456789", pixels), lfi::pixelChecksum(pixels, 0xcbf43926ul));
  // And lfi's reader agrees with this test's canonical text (RawWriterProducesReadableFiles
  // reads a file sealed by it); lfi's writer records the same checksum.
  const LightFieldGeometry g = geometry();
  lfi::writeLightFieldExr(file("lf.exr"), LightField(g, randomFloats(g.height(), g.width(), 16)));
  const Imf::Header written = Imf::InputFile(file("lf.exr").c_str()).header();
  EXPECT_EQ(
      written.typedAttribute<Imf::StringAttribute>("lfi.checksum").value(),
      checksumText(lfi::fileChecksum(canonicalText(written), lfi::readLightFieldExr(file("lf.exr")).lensletImage())));
}

TEST_F(ExrIo, VersionOneFilesStillReadAndLaterVersionsAreRefused) {
  // Files written before format version 2 recorded the CRC of the pixels only.
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 17);
  writeRawExr(file("v1.exr"), pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(1));
    h.insert("lfi.checksum", Imf::StringAttribute(checksumText(pixels)));
    h.insert("lfi.spatialX", Imf::IntAttribute(g.spatialX));
    h.insert("lfi.spatialY", Imf::IntAttribute(g.spatialY));
    h.insert("lfi.angular", Imf::IntAttribute(g.angular));
    h.insert("lfi.pixelPitch_mm", Imf::DoubleAttribute(g.pixelPitch_mm));
    h.insert("lfi.distance_mm", Imf::DoubleAttribute(g.distance_mm));
    insertConventions(h);  // (in the same words since the first version)
  });
  const LightField loaded = lfi::readLightFieldExr(file("v1.exr"));
  EXPECT_TRUE(loaded.geometry() == g);
  EXPECT_TRUE(bitIdentical(loaded.lensletImage(), pixels));
  writeRawExr(file("v3.exr"), pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(3));
  });
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("v3.exr")); }, Errc::InvalidFile,
                          {file("v3.exr").string(), "lfi.formatVersion", "is 3", "versions 1 to 2"}));
}

TEST_F(ExrIo, LfiAttributeOfAnotherTypeIsNamed) {
  const LightFieldGeometry g = geometry();
  const cv::Mat pixels = randomFloats(g.height(), g.width(), 18);
  writeRawExr(file("v2f.exr"), pixels, [&](Imf::Header& h) {
    h.insert("lfi.kind", Imf::StringAttribute("light-field"));
    h.insert("lfi.formatVersion", Imf::IntAttribute(lfi::kExrFormatVersion));
    h.insert("lfi.checksum", Imf::StringAttribute("crc32:00000000"));
    h.insert("lfi.offset", Imf::V2fAttribute(Imath::V2f(1, 2)));
  });
  EXPECT_TRUE(throwsError([&] { lfi::readLightFieldExr(file("v2f.exr")); }, Errc::InvalidFile,
                          {file("v2f.exr").string(), "'lfi.offset'", "'v2f'"}));
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

TEST_F(ExrIo, ExistingFileIsKeptUnlessOverwriteAllowed) {
  const LightFieldGeometry g = geometry();
  const LightField first(g, randomFloats(g.height(), g.width(), 14));
  const LightField second(g, randomFloats(g.height(), g.width(), 15));
  const fs::path path = file("lf.exr");
  lfi::writeLightFieldExr(path, first);
  EXPECT_TRUE(throwsError([&] { lfi::writeLightFieldExr(path, second); }, Errc::Exists, {path.string()}));
  EXPECT_TRUE(throwsError([&] { lfi::writeLightFieldExr(path, second, lfi::Overwrite::Refuse); }, Errc::Exists,
                          {path.string()}));
  EXPECT_TRUE(bitIdentical(lfi::readLightFieldExr(path).lensletImage(), first.lensletImage()));
  lfi::writeLightFieldExr(path, second, lfi::Overwrite::Allow);
  EXPECT_TRUE(bitIdentical(lfi::readLightFieldExr(path).lensletImage(), second.lensletImage()));
  // Same for radiance images.
  const fs::path r = file("r.exr");
  lfi::writeRadianceExr(r, first.lensletImage(), {});
  EXPECT_TRUE(throwsError([&] { lfi::writeRadianceExr(r, second.lensletImage(), {}); }, Errc::Exists, {r.string()}));
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(r), first.lensletImage()));
  lfi::writeRadianceExr(r, second.lensletImage(), {}, lfi::Overwrite::Allow);
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(r), second.lensletImage()));
  // No temporaries are left behind.
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"lf.exr", "r.exr"}));
}

TEST_F(ExrIo, WritingRejectsWrongImages) {
  EXPECT_TRUE(throwsError([&] { lfi::writeRadianceExr(file("a.exr"), cv::Mat(4, 4, CV_8UC1), {}); },
                          Errc::InvalidArgument, {"a.exr"}));
  EXPECT_TRUE(
      throwsError([&] { lfi::writeRadianceExr(file("b.exr"), cv::Mat(), {}); }, Errc::InvalidArgument, {"b.exr"}));
  EXPECT_FALSE(fs::exists(file("a.exr")));
  EXPECT_FALSE(fs::exists(file("b.exr")));
  // What the reader would refuse is not written, and does not replace a good file.
  const cv::Mat good(4, 4, CV_32FC1, cv::Scalar(1));
  lfi::writeRadianceExr(file("c.exr"), good, {});
  cv::Mat bad = good.clone();
  bad.at<float>(2, 3) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(throwsError([&] { lfi::writeRadianceExr(file("c.exr"), bad, {}, lfi::Overwrite::Allow); },
                          Errc::InvalidArgument, {"c.exr", "(3, 2)", "finite"}));
  EXPECT_TRUE(throwsError(
      [&] { lfi::writeRadianceExr(file("c.exr"), good, {.objectPixel_mm = -1}, lfi::Overwrite::Allow); },
      Errc::InvalidArgument, {"c.exr", "objectPixel_mm"}));
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(file("c.exr")), good));
  // A light field whose image was changed through lensletImage() after it was checked.
  const LightFieldGeometry g = geometry();
  LightField lf(g, randomFloats(g.height(), g.width(), 16));
  lf.lensletImage().at<float>(1, 1) = std::numeric_limits<float>::infinity();
  EXPECT_TRUE(throwsError([&] { lfi::writeLightFieldExr(file("lf.exr"), lf); }, Errc::InvalidArgument,
                          {"lf.exr", "(1, 1)"}));
  lf.lensletImage() = cv::Mat(3, 3, CV_32FC1, cv::Scalar(0));
  EXPECT_TRUE(throwsError([&] { lfi::writeLightFieldExr(file("lf.exr"), lf); }, Errc::InvalidArgument,
                          {"lf.exr", "3x3"}));
  EXPECT_FALSE(fs::exists(file("lf.exr")));
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

TEST(PixelChecksum, IsCrc32OfPixelBytesRowByRow) {
  // CRC-32 (zlib polynomial) of the ASCII bytes "123456789" is 0xcbf43926.
  cv::Mat bytes(1, 9, CV_8UC1);
  std::memcpy(bytes.data, "123456789", 9);
  EXPECT_EQ(lfi::pixelChecksum(bytes), 0xcbf43926ul);
  // Row padding of a region is not part of the checksum.
  const cv::Mat big = randomFloats(6, 10, 16);
  const cv::Mat roi = big(cv::Rect(1, 1, 5, 4));
  EXPECT_EQ(lfi::pixelChecksum(roi), lfi::pixelChecksum(roi.clone()));
  cv::Mat changed = roi.clone();
  changed.at<float>(3, 4) = -changed.at<float>(3, 4);
  EXPECT_NE(lfi::pixelChecksum(changed), lfi::pixelChecksum(roi));
}

}  // namespace

// OpenEXR's pool has one thread per CPU the process may run on (a container's
// cpuset narrows it; hardware_concurrency() would not), or the count a
// program's --threads gives; files still round-trip on one thread.
TEST_F(ExrIo, OpenExrThreadsFollowTheProcessCpusOrTheGivenCount) {
  cpu_set_t all;
  ASSERT_EQ(sched_getaffinity(0, sizeof all, &all), 0);
  int first = 0;
  while (!CPU_ISSET(first, &all)) ++first;
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(first, &one);
  ASSERT_EQ(sched_setaffinity(0, sizeof one, &one), 0);
  lfi::setExrThreads(0);
  const int onOneCpu = Imf::globalThreadCount();
  ASSERT_EQ(sched_setaffinity(0, sizeof all, &all), 0);
  EXPECT_EQ(onOneCpu, 1);

  lfi::setExrThreads(3);
  EXPECT_EQ(Imf::globalThreadCount(), 3);
  lfi::setExrThreads(1);
  cv::Mat image(300, 200, CV_32FC1);
  cv::randu(image, 0.0f, 2.0f);
  lfi::writeRadianceExr(file("one-thread.exr"), image, {});
  EXPECT_EQ(cv::norm(lfi::readRadianceExr(file("one-thread.exr")), image, cv::NORM_INF), 0.0);

  lfi::setExrThreads(0);
  EXPECT_EQ(Imf::globalThreadCount(), CPU_COUNT(&all));
  EXPECT_TRUE(throwsError([] { lfi::setExrThreads(-1); }, Errc::InvalidArgument, {"-1"}));
  EXPECT_EQ(Imf::globalThreadCount(), CPU_COUNT(&all));
}
