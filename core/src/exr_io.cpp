// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/exr_io.h"

#include "lfi/core/error.h"
#include "lfi/core/image.h"
#include "lfi/core/input_file.h"

#include <Iex.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfDoubleAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfThreading.h>
#include <sched.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <map>
#include <string_view>
#include <thread>

namespace lfi {

namespace fs = std::filesystem;

namespace {

constexpr const char* kKind = "lfi.kind";
constexpr const char* kVersion = "lfi.formatVersion";
constexpr const char* kChecksum = "lfi.checksum";
constexpr const char* kUnits = "lfi.units";
constexpr const char* kFrame = "lfi.frame";
constexpr const char* kParametrisation = "lfi.parametrisation";
constexpr const char* kSpatialX = "lfi.spatialX";
constexpr const char* kSpatialY = "lfi.spatialY";
constexpr const char* kAngular = "lfi.angular";
constexpr const char* kPixelPitch = "lfi.pixelPitch_mm";
constexpr const char* kDistance = "lfi.distance_mm";
constexpr const char* kObjectPixel = "lfi.objectPixel_mm";
constexpr const char* kDescription = "lfi.description";
constexpr const char* kSettingsPrefix = "lfi.settings.";

// The conventions in words (docs/file-formats.md), written into every file and
// required of every file read: lfi reads no other parametrisation.
constexpr const char* kLightFieldFrameText =
    "plane frame: origin at the grid centre, +z the viewing/emitting side; "
    "pixel (col,row) = (ex*n+u, ey*n+v), row increases with +y";
constexpr const char* kLightFieldParametrisationText =
    "lenslet image of SxxSy spatial elements of nxn angular elements; "
    "in-element position (px,py) in [-1,1]^2 sees direction "
    "normalise(-px,-py,sqrt(1-px^2-py^2)); px^2+py^2>=1 is 0";
constexpr const char* kRadianceFrameText = "camera image: row 0 at world +y, columns along world +x";

constexpr const char* kLightFieldKind = "light-field";
constexpr const char* kRadianceKind = "radiance-image";

std::string checksumText(unsigned long crc) {
  return fmt::format("crc32:{:08x}", crc);
}

// The lfi.* attributes but lfi.checksum, as the text the checksum covers
// (format version 2, docs/file-formats.md): by name, one line each,
// "name type value": an int in decimal, a double in its shortest exact
// decimal form, a string as its length, ':' and its bytes.
std::string canonicalAttributes(const fs::path& path, const Imf::Header& header) {
  std::string text;
  for (auto it = header.begin(); it != header.end(); ++it) {  // by name (a std::map)
    const std::string_view name = it.name();
    if (!name.starts_with("lfi.") || name == kChecksum) continue;
    const Imf::Attribute& a = it.attribute();
    if (const auto* i = dynamic_cast<const Imf::IntAttribute*>(&a))
      text += fmt::format("{} int {}\n", name, i->value());
    else if (const auto* d = dynamic_cast<const Imf::DoubleAttribute*>(&a))
      text += fmt::format("{} double {}\n", name, d->value());
    else if (const auto* str = dynamic_cast<const Imf::StringAttribute*>(&a))
      text += fmt::format("{} string {}:{}\n", name, str->value().size(), str->value());
    else
      fail(Errc::InvalidFile, "'{}': attribute '{}' has type '{}'; lfi attributes are int, double or string",
           path.string(), shown(name), shown(a.typeName()));
  }
  return text;
}

// The CPUs this process may run on: its affinity mask, which a cpuset (a
// container's CPU limit) or taskset narrows; hardware_concurrency() counts
// the machine's.
int usableCpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) return std::max(1, CPU_COUNT(&set));
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));  // (more than CPU_SETSIZE CPUs)
}

void setOpenExrThreads(int threads) {
  try {
    Imf::setGlobalThreadCount(threads > 0 ? threads : usableCpus());
  } catch (const std::exception&) {
    // An OpenEXR built without threads: files are written on the calling thread.
  }
}

// Process-wide OpenEXR settings, made once before lfi's first file:
// - OpenEXR sizes its per-line tables from a file's data window when it opens
//   the file; with a maximum image size its sanity check refuses a larger one
//   first (no lfi file is larger);
// - OpenEXR compresses and decompresses on a global thread pool that has no
//   threads unless the application gives it some: one per CPU the process may
//   run on, unless the application already chose a count (setExrThreads;
//   lfi-frame-bench measures it: a 49 MB light field's write and read take
//   about half as long on 2).
void configureOpenExr() {
  static const bool configured = [] {
    Imf::Header::setMaxImageSize(static_cast<int>(kMaxExrSide), static_cast<int>(kMaxExrSide));
    if (Imf::globalThreadCount() == 0) setOpenExrThreads(0);
    return true;
  }();
  (void)configured;
}

// What loadExr() refuses is refused here too, before anything is written: a
// file that could not be read back must not replace a good one.
constexpr const char* kUnitsPrefix = "lengths mm, angles rad, pixels ";

void writeExr(const fs::path& path, const cv::Mat& image, Imf::Header header, Overwrite overwrite,
              const std::string& pixelUnit = RadianceImageInfo{}.pixelUnit) {
  configureOpenExr();  // (the read-back check opens the file too)
  requireImageType(image, CV_32FC1, "EXR image '" + path.string() + "'");
  if (image.cols > kMaxExrSide || image.rows > kMaxExrSide || static_cast<long>(image.total()) > kMaxExrPixels)
    fail(Errc::InvalidArgument,
         "cannot write '{}': {}x{} pixels is more than an lfi file holds (2^17 a side, 2^30 "
         "pixels)",
         path.string(), image.cols, image.rows);
  if (const auto bad = firstNonFinite(image))
    fail(Errc::InvalidArgument, "cannot write '{}': pixel ({}, {}) is {}; radiance must be finite", path.string(),
         bad->x, bad->y, image.at<float>(*bad));
  cv::Mat pixels = image.isContinuous() ? image : image.clone();
  header.compression() = Imf::ZIP_COMPRESSION;
  header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
  header.insert(kVersion, Imf::IntAttribute(kExrFormatVersion));
  header.insert(kUnits, Imf::StringAttribute(kUnitsPrefix + pixelUnit));
  header.insert(kChecksum, Imf::StringAttribute(checksumText(fileChecksum(canonicalAttributes(path, header), pixels))));
  writeFileAtomically(path, overwrite, [&](const fs::path& temporary) {
    try {
      {
        Imf::OutputFile file(temporary.c_str(), header);
        Imf::FrameBuffer frame;
        frame.insert("Y", Imf::Slice(Imf::FLOAT, const_cast<char*>(pixels.ptr<char>()), sizeof(float), pixels.step));
        file.setFrameBuffer(frame);
        file.writePixels(pixels.rows);
      }
      // OpenEXR writes the line offsets and flushes in the destructor, which
      // swallows errors (a full disk): read the file back before it replaces anything.
      if (!Imf::InputFile(temporary.c_str()).isComplete())
        fail(Errc::Io, "cannot write '{}': the file came out incomplete (is the disk full?)", path.string());
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      fail(Errc::Io, "cannot write '{}': {}", path.string(), e.what());
    }
  });
}

// An opened, fully read and validated EXR: the pixels and the header.
struct LoadedExr {
  Imf::Header header;
  cv::Mat pixels;
};

template <typename Attribute>
const Attribute& requireAttribute(const fs::path& path, const Imf::Header& header, const char* name) {
  const auto it = header.find(name);
  if (it == header.end()) fail(Errc::InvalidFile, "'{}': attribute '{}' is missing", path.string(), name);
  const Imf::Attribute* any = &it.attribute();
  const auto* typed = dynamic_cast<const Attribute*>(any);
  if (!typed)
    fail(Errc::InvalidFile, "'{}': attribute '{}' has type '{}', expected '{}'", path.string(), name, any->typeName(),
         Attribute::staticTypeName());
  return *typed;
}

// A string attribute that states a convention must state lfi's, word for word.
void requireConvention(const fs::path& path, const Imf::Header& header, const char* name, const std::string& text) {
  const std::string& value = requireAttribute<Imf::StringAttribute>(path, header, name).value();
  if (value != text)
    fail(Errc::InvalidFile,
         "'{}': attribute '{}' is '{}', not lfi's convention '{}': the file is in another "
         "parametrisation, which lfi does not read",
         path.string(), name, shown(value), text);
}

// The OpenEXR attribute types of a fixed size, and their sizes in bytes.
// clang-format off
const std::map<std::string, std::uint32_t, std::less<>> kFixedAttributeSizes = {
    {"box2i", 16},  {"box2f", 16},   {"compression", 1}, {"double", 8},     {"envmap", 1},          {"float", 4},
    {"int", 4},     {"keycode", 28}, {"lineOrder", 1},   {"m33f", 36},      {"m33d", 72},           {"m44f", 64},
    {"m44d", 128},  {"rational", 8}, {"tiledesc", 9},    {"timecode", 8},   {"v2i", 8},             {"v2f", 8},
    {"v2d", 16},    {"v3i", 12},     {"v3f", 12},        {"v3d", 24},       {"chromaticities", 32}, {"deepImageState", 1}};
// clang-format on

// Walks the (first) header of an OpenEXR file as the file format lays it out:
// magic number, version field, then attributes (name, type name, int32 size,
// value) up to an empty name. A size past the end of the file is an error
// here: OpenEXR would first allocate it (a 2 KB file declaring a 1.9 GB
// attribute took it seconds and that memory); so is a size other than what the
// value of its type takes (kFixedAttributeSizes, a channel list's entries).
// Files that are not OpenEXR are left to OpenEXR's own error.
void checkHeaderSizes(const fs::path& path) {
  std::error_code error;
  const auto fileSize = static_cast<std::uint64_t>(fs::file_size(path, error));
  if (error) return;  // not a regular file: OpenEXR names the problem
  std::ifstream in(path, std::ios::binary);
  unsigned char start[8];
  if (!in.read(reinterpret_cast<char*>(start), 8) || start[0] != 0x76 || start[1] != 0x2f || start[2] != 0x31 ||
      start[3] != 0x01)
    return;
  // Version field bits 9 (tiled), 11 (deep) and 12 (multi-part): lfi writes single-part scanline files, and
  // this walk would check only the first of several headers.
  if (const unsigned flags = start[5]; (flags & 0x1a) != 0)
    fail(Errc::InvalidFile, "'{}': a {} OpenEXR file; lfi files are single-part scanline images", path.string(),
         (flags & 0x10)   ? "multi-part"
         : (flags & 0x08) ? "deep"
                          : "tiled");
  auto cString = [&](std::string& s) {  // names are at most 255 bytes
    s.clear();
    for (char c; in.get(c) && c != '\0';)
      if (s.size() < 256) s += c;
    return static_cast<bool>(in);
  };
  auto u32 = [](const unsigned char* b) {
    return b[0] | b[1] << 8 | b[2] << 16 | static_cast<std::uint32_t>(b[3]) << 24;
  };
  for (std::string name, type; cString(name) && !name.empty();) {
    unsigned char size[4];
    if (!cString(type) || !in.read(reinterpret_cast<char*>(size), 4)) return;  // truncated: OpenEXR says so
    const std::uint32_t n = u32(size);
    const auto at = static_cast<std::uint64_t>(in.tellg());
    if (n > fileSize - std::min(at, fileSize))
      fail(Errc::InvalidFile,
           "'{}': attribute '{}' declares {} bytes, more than the file's remaining {} "
           "(truncated or corrupt)",
           path.string(), shown(name), n, fileSize - std::min(at, fileSize));
    // OpenEXR reads a value of a fixed-size type, and a channel list, by its own length, not the declared one,
    // and goes on parsing where its read ended: a declared size that differs would have the rest of the header
    // read from inside this value (a 700-byte file then declared a 1.9 GB string there, found by fuzzing).
    std::uint32_t expected = n;
    if (const auto fixed = kFixedAttributeSizes.find(type); fixed != kFixedAttributeSizes.end()) {
      expected = fixed->second;
    } else if (type == "chlist") {  // channels: name, 16 bytes; then an empty name
      // (OpenEXR reads channels up to the empty name, past the declared size if need be: a list without its
      // empty name inside the declared bytes takes more than they hold.)
      std::uint64_t used = 0;
      std::string channel;
      bool ended = false;
      while (used < n && cString(channel)) {
        used += channel.size() + 1;
        if ((ended = channel.empty())) break;
        used += 16;
        in.seekg(16, std::ios::cur);
      }
      if (!ended) ++used;  // (the empty name, at least)
      expected = static_cast<std::uint32_t>(std::min<std::uint64_t>(used, 0xffffffffu));
      in.clear();
      in.seekg(static_cast<std::streamoff>(at), std::ios::beg);
    }
    if (expected != n)
      fail(Errc::InvalidFile, "'{}': attribute '{}' of type '{}' declares {} bytes, its value takes {} (corrupt)",
           path.string(), shown(name), shown(type), n, expected);
    in.seekg(static_cast<std::streamoff>(n), std::ios::cur);
  }
}

LoadedExr loadExr(const fs::path& path, const char* expectedKind) {
  requireInputFile(path);
  checkHeaderSizes(path);
  configureOpenExr();
  LoadedExr out;
  int version = 0;
  try {
    Imf::InputFile file(path.c_str());
    out.header = file.header();
    const auto& kind = requireAttribute<Imf::StringAttribute>(path, out.header, kKind).value();
    if (kind != expectedKind)
      fail(Errc::InvalidFile, "'{}': attribute '{}' is '{}', expected '{}'", path.string(), kKind, kind, expectedKind);
    version = requireAttribute<Imf::IntAttribute>(path, out.header, kVersion).value();
    if (version < 1 || version > kExrFormatVersion)
      fail(Errc::InvalidFile, "'{}': attribute '{}' is {}, this build reads versions 1 to {}", path.string(), kVersion,
           version, kExrFormatVersion);
    const Imf::Channel* channel = out.header.channels().findChannel("Y");
    int channels = 0;
    for (auto it = out.header.channels().begin(); it != out.header.channels().end(); ++it) ++channels;
    if (!channel || channel->type != Imf::FLOAT || channels != 1)
      fail(Errc::InvalidFile, "'{}': expected one FLOAT channel 'Y' ({} channel(s))", path.string(), channels);
    const Imath::Box2i dw = out.header.dataWindow();
    const long width = static_cast<long>(dw.max.x) - dw.min.x + 1, height = static_cast<long>(dw.max.y) - dw.min.y + 1;
    if (width < 1 || height < 1 || width > kMaxExrSide || height > kMaxExrSide || width * height > kMaxExrPixels)
      fail(Errc::InvalidFile, "'{}': data window {}x{} is out of range (at most 2^17 a side and 2^30 pixels)",
           path.string(), width, height);
    // Every scan line's chunk listed before the image is allocated: a file cut short (or a few bytes that claim
    // a large data window) would otherwise have its whole image allocated and read before it fails.
    if (!file.isComplete())
      fail(Errc::InvalidFile,
           "'{}': the file holds fewer scan lines than its {}x{} data window (truncated or "
           "corrupt)",
           path.string(), width, height);
    out.pixels.create(static_cast<int>(height), static_cast<int>(width), CV_32FC1);
    Imf::FrameBuffer frame;
    const std::ptrdiff_t origin = static_cast<std::ptrdiff_t>(dw.min.x) * static_cast<std::ptrdiff_t>(sizeof(float)) +
                                  static_cast<std::ptrdiff_t>(dw.min.y) * static_cast<std::ptrdiff_t>(out.pixels.step);
    char* base = out.pixels.ptr<char>() - origin;
    frame.insert("Y", Imf::Slice(Imf::FLOAT, base, sizeof(float), out.pixels.step));
    file.setFrameBuffer(frame);
    file.readPixels(dw.min.y, dw.max.y);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    fail(Errc::InvalidFile, "'{}': not a readable OpenEXR file (truncated or corrupt): {}", path.string(), e.what());
  }
  // A version 1 file covers only the pixels; its attributes are read unchecked.
  const std::string expected = requireAttribute<Imf::StringAttribute>(path, out.header, kChecksum).value();
  const std::string actual = checksumText(
      version == 1 ? pixelChecksum(out.pixels) : fileChecksum(canonicalAttributes(path, out.header), out.pixels));
  if (expected != actual)
    fail(Errc::Checksum, "'{}': {} do not match attribute '{}' (recorded {}, computed {})", path.string(),
         version == 1 ? "pixel data" : "lfi attributes or pixel data", kChecksum, shown(expected), actual);
  if (const auto bad = firstNonFinite(out.pixels))
    fail(Errc::InvalidFile, "'{}': pixel ({}, {}) is {}; radiance must be finite", path.string(), bad->x, bad->y,
         out.pixels.at<float>(*bad));
  return out;
}

}  // namespace

unsigned long pixelChecksum(const cv::Mat& image, unsigned long crc) {
  const size_t rowBytes = image.cols * image.elemSize();
  for (int r = 0; r < image.rows; ++r) crc = crc32(crc, image.ptr<Bytef>(r), static_cast<uInt>(rowBytes));
  return crc;
}

unsigned long fileChecksum(std::string_view attributes, const cv::Mat& pixels) {
  uLong crc = crc32(0L, Z_NULL, 0);
  for (size_t at = 0; at < attributes.size();) {  // in pieces that fit zlib's uInt
    const size_t n = std::min<size_t>(attributes.size() - at, 1u << 30);
    crc = crc32(crc, reinterpret_cast<const Bytef*>(attributes.data() + at), static_cast<uInt>(n));
    at += n;
  }
  return pixelChecksum(pixels, crc);
}

void writeLightFieldExr(const fs::path& path, const LightField& lightField, Overwrite overwrite) {
  const LightFieldGeometry& g = lightField.geometry();
  g.validate();
  // (at() and lensletImage() may have changed the image since it was checked)
  if (lightField.lensletImage().type() != CV_32FC1 || lightField.lensletImage().cols != g.width() ||
      lightField.lensletImage().rows != g.height())
    fail(Errc::InvalidArgument,
         "cannot write '{}': the lenslet image is {}x{} (type {}); the geometry needs {}x{} "
         "CV_32FC1",
         path.string(), lightField.lensletImage().cols, lightField.lensletImage().rows,
         lightField.lensletImage().type(), g.width(), g.height());
  if (const auto bad = firstNegative(lightField.lensletImage()))
    fail(Errc::InvalidArgument, "cannot write '{}': lenslet pixel ({}, {}) is {}; radiance cannot be negative",
         path.string(), bad->x, bad->y, lightField.lensletImage().at<float>(*bad));
  Imf::Header header(g.width(), g.height());
  header.insert(kKind, Imf::StringAttribute(kLightFieldKind));
  header.insert(kSpatialX, Imf::IntAttribute(g.spatialX));
  header.insert(kSpatialY, Imf::IntAttribute(g.spatialY));
  header.insert(kAngular, Imf::IntAttribute(g.angular));
  header.insert(kPixelPitch, Imf::DoubleAttribute(g.pixelPitch_mm));
  header.insert(kDistance, Imf::DoubleAttribute(g.distance_mm));
  header.insert(kFrame, Imf::StringAttribute(kLightFieldFrameText));
  header.insert(kParametrisation, Imf::StringAttribute(kLightFieldParametrisationText));
  writeExr(path, lightField.lensletImage(), std::move(header), overwrite);
}

LightField readLightFieldExr(const fs::path& path) {
  LoadedExr exr = loadExr(path, kLightFieldKind);
  LightFieldGeometry g;
  g.spatialX = requireAttribute<Imf::IntAttribute>(path, exr.header, kSpatialX).value();
  g.spatialY = requireAttribute<Imf::IntAttribute>(path, exr.header, kSpatialY).value();
  g.angular = requireAttribute<Imf::IntAttribute>(path, exr.header, kAngular).value();
  g.pixelPitch_mm = requireAttribute<Imf::DoubleAttribute>(path, exr.header, kPixelPitch).value();
  g.distance_mm = requireAttribute<Imf::DoubleAttribute>(path, exr.header, kDistance).value();
  requireConvention(path, exr.header, kFrame, kLightFieldFrameText);
  requireConvention(path, exr.header, kParametrisation, kLightFieldParametrisationText);
  requireConvention(path, exr.header, kUnits, kUnitsPrefix + RadianceImageInfo{}.pixelUnit);
  try {
    g.validate();
  } catch (const Error& e) {
    fail(Errc::InvalidFile, "'{}': {}", path.string(), e.what());
  }
  if (exr.pixels.cols != g.width() || exr.pixels.rows != g.height())
    fail(Errc::InvalidFile, "'{}': image is {}x{} but attributes {}={}, {}={}, {}={} need {}x{}", path.string(),
         exr.pixels.cols, exr.pixels.rows, kSpatialX, g.spatialX, kSpatialY, g.spatialY, kAngular, g.angular, g.width(),
         g.height());
  try {  // (LightField checks the pixels: a negative radiance, say, is the file's fault here)
    return LightField(g, std::move(exr.pixels));
  } catch (const Error& e) {
    fail(Errc::InvalidFile, "'{}': {}", path.string(), e.what());
  }
}

void writeRadianceExr(const fs::path& path, const cv::Mat& image, const RadianceImageInfo& info, Overwrite overwrite) {
  requireImageType(image, CV_32FC1, "radiance image for '" + path.string() + "'");
  if (!(info.objectPixel_mm >= 0) || !std::isfinite(info.objectPixel_mm))
    fail(Errc::InvalidArgument, "cannot write '{}': objectPixel_mm = {} must be finite and >= 0", path.string(),
         info.objectPixel_mm);
  Imf::Header header(image.cols, image.rows);
  header.insert(kKind, Imf::StringAttribute(kRadianceKind));
  header.insert(kObjectPixel, Imf::DoubleAttribute(info.objectPixel_mm));
  header.insert(kFrame, Imf::StringAttribute(kRadianceFrameText));
  header.insert(kDescription, Imf::StringAttribute(info.description));
  for (const auto& [key, value] : info.settings) {
    if (key.empty() || key.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") != std::string::npos)
      fail(Errc::InvalidArgument, "cannot write '{}': setting '{}' is not a key of a-z, 0-9 and '_'", path.string(),
           shown(key));
    header.insert(kSettingsPrefix + key, Imf::StringAttribute(value));
  }
  if (info.pixelUnit.empty())
    fail(Errc::InvalidArgument, "cannot write '{}': the pixels' unit is empty", path.string());
  writeExr(path, image, std::move(header), overwrite, info.pixelUnit);
}

cv::Mat readRadianceExr(const fs::path& path, RadianceImageInfo* info) {
  LoadedExr exr = loadExr(path, kRadianceKind);
  const double objectPixel = requireAttribute<Imf::DoubleAttribute>(path, exr.header, kObjectPixel).value();
  if (!(objectPixel >= 0) || !std::isfinite(objectPixel))
    fail(Errc::InvalidFile, "'{}': attribute '{}' = {} must be finite and >= 0", path.string(), kObjectPixel,
         objectPixel);
  requireConvention(path, exr.header, kFrame, kRadianceFrameText);
  const std::string& units = requireAttribute<Imf::StringAttribute>(path, exr.header, kUnits).value();
  const std::string prefix = kUnitsPrefix;
  if (!units.starts_with(prefix) || units.size() == prefix.size())
    fail(Errc::InvalidFile, "'{}': attribute '{}' is '{}', not lfi's '{}<the pixels' unit>'", path.string(), kUnits,
         shown(units), prefix);
  if (info) {
    info->objectPixel_mm = objectPixel;
    const auto* d = exr.header.findTypedAttribute<Imf::StringAttribute>(kDescription);
    info->description = d ? d->value() : std::string();
    info->pixelUnit = units.substr(prefix.size());
    info->settings.clear();
    for (auto it = exr.header.begin(); it != exr.header.end(); ++it) {
      const std::string_view name = it.name();
      if (!name.starts_with(kSettingsPrefix)) continue;
      const auto* value = dynamic_cast<const Imf::StringAttribute*>(&it.attribute());
      if (!value)
        fail(Errc::InvalidFile, "'{}': attribute '{}' has type '{}', expected 'string'", path.string(), shown(name),
             shown(it.attribute().typeName()));
      info->settings.emplace(std::string(name.substr(std::string_view(kSettingsPrefix).size())), value->value());
    }
  }
  return exr.pixels;
}

void setExrThreads(int threads) {
  if (threads < 0) fail(Errc::InvalidArgument, "setExrThreads: {} threads; give 0 (one per CPU) or more", threads);
  configureOpenExr();
  setOpenExrThreads(threads);
}

}  // namespace lfi
