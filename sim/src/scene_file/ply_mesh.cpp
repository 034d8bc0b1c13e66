// SPDX-License-Identifier: Apache-2.0
#include "ply_mesh.h"

#include "lfi/core/error.h"

#include <cctype>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace lfi::sim::detail {

namespace fs = std::filesystem;

namespace {

enum class Type { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<Type> typeNamed(std::string_view name) {
  static constexpr std::pair<std::string_view, Type> kNames[] = {
      {"char", Type::Int8},     {"int8", Type::Int8},       {"uchar", Type::UInt8},    {"uint8", Type::UInt8},
      {"short", Type::Int16},   {"int16", Type::Int16},     {"ushort", Type::UInt16},  {"uint16", Type::UInt16},
      {"int", Type::Int32},     {"int32", Type::Int32},     {"uint", Type::UInt32},    {"uint32", Type::UInt32},
      {"float", Type::Float32}, {"float32", Type::Float32}, {"double", Type::Float64}, {"float64", Type::Float64}};
  for (const auto& [n, t] : kNames)
    if (n == name) return t;
  return std::nullopt;
}

size_t sizeOf(Type t) {
  switch (t) {
    case Type::Int8:
    case Type::UInt8:
      return 1;
    case Type::Int16:
    case Type::UInt16:
      return 2;
    case Type::Int32:
    case Type::UInt32:
    case Type::Float32:
      return 4;
    case Type::Float64:
      return 8;
  }
  return 8;
}

bool integral(Type t) {
  return t != Type::Float32 && t != Type::Float64;
}

struct Property {
  std::string name;
  Type type = Type::Float32;  // the items' type for a list
  std::optional<Type> count;  // a list's count type
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
  int line = 0;  // of its header line
};

enum class Format { Ascii, LittleEndian, BigEndian };

// The header's lines, split at '\n' (a trailing '\r' dropped), and where the body starts.
class HeaderLines {
 public:
  explicit HeaderLines(std::string_view bytes) : bytes_(bytes) {}
  // The next line, or nullopt at the end of the file.
  std::optional<std::string_view> next() {
    if (at_ >= bytes_.size()) return std::nullopt;
    const size_t end = bytes_.find('\n', at_);
    if (end == std::string_view::npos) return std::nullopt;  // a header line always ends in '\n'
    std::string_view line = bytes_.substr(at_, end - at_);
    at_ = end + 1;
    ++number_;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return line;
  }
  int number() const { return number_; }
  size_t offset() const { return at_; }

 private:
  std::string_view bytes_;
  size_t at_ = 0;
  int number_ = 0;
};

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

// Reads the body's values one at a time, in the file's format. Integral values
// come back exactly (as int64); each error names the position.
class BodyReader {
 public:
  BodyReader(const fs::path& path, std::string_view body, size_t offset, int line, Format format)
      : path_(path), body_(body), offset_(offset), line_(line), format_(format) {}

  bool ascii() const { return format_ == Format::Ascii; }
  size_t remaining() const { return body_.size() - at_; }
  // What the next values belong to, for the errors.
  void at(const Element& element, std::uint64_t instance, const Property& property) {
    element_ = &element, instance_ = instance, property_ = &property;
  }

  // ASCII: an instance is one line (the format's rule), so a row short of a
  // value, or with one too many, is an error at that row rather than a shift
  // of every value after it. beginInstance() before an instance's values,
  // endInstance() after them.
  void beginInstance() { rowLine_ = -1; }
  void endInstance() {
    if (!ascii()) return;
    size_t i = at_;
    while (i < body_.size() && body_[i] != '\n' && std::isspace(static_cast<unsigned char>(body_[i]))) ++i;
    if (i == body_.size() || body_[i] == '\n') return;
    size_t end = i;
    while (end < body_.size() && !std::isspace(static_cast<unsigned char>(body_[end]))) ++end;
    lfi::fail(Errc::InvalidFile,
              "'{}': line {}: {} {}: '{}' is a value past the element's declared properties "
              "(a line holds one instance)",
              path_.string(), line_, shown(element_->name), instance_, shown(body_.substr(i, end - i)));
  }
  // Anything but white space after the last element is an error (a count
  // short of the rows or faces that follow; a binary file may end with a
  // line end or spaces some writers leave).
  void end() {
    if (!ascii()) {
      const auto rest = body_.substr(at_);
      if (rest.find_first_not_of(" \t\r\n") != std::string_view::npos)
        lfi::fail(Errc::InvalidFile,
                  "'{}': byte {}: {} bytes after the last element's declared instances (a count "
                  "in the header is short)",
                  path_.string(), offset_ + at_, remaining());
      return;
    }
    rowLine_ = -1;
    while (at_ < body_.size() && std::isspace(static_cast<unsigned char>(body_[at_])))
      if (body_[at_++] == '\n') ++line_;
    if (at_ < body_.size())
      lfi::fail(Errc::InvalidFile,
                "'{}': line {}: values after the last element's declared instances (a "
                "count in the header is short)",
                path_.string(), line_);
  }

  double real(Type t) {
    if (ascii()) {
      const std::string_view token = nextToken();
      double v = 0;
      const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
      if (ec != std::errc() || end != token.data() + token.size()) bad(token, "a number");
      return v;
    }
    if (integral(t)) return static_cast<double>(binaryInteger(t));
    if (t == Type::Float32) {
      const std::uint32_t bits = static_cast<std::uint32_t>(raw(4));
      float f;
      std::memcpy(&f, &bits, 4);
      return f;
    }
    const std::uint64_t bits = raw(8);
    double d;
    std::memcpy(&d, &bits, 8);
    return d;
  }

  std::int64_t integer(Type t) {
    if (!ascii()) return binaryInteger(t);
    const std::string_view token = nextToken();
    std::int64_t v = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
    if (ec != std::errc() || end != token.data() + token.size() || v < lowest(t) || v > highest(t))
      bad(token, "an integer of the property's type");
    return v;
  }

  void skip(Type t) {
    if (ascii())
      nextToken();
    else
      raw(sizeOf(t));
  }

  // Throws Errc::InvalidFile naming the file, the position and the value's property.
  template <typename... Args>
  [[noreturn]] void fail(fmt::format_string<Args...> f, Args&&... args) const {
    const std::string where = ascii() ? fmt::format("line {}", line_) : fmt::format("byte {}", offset_ + at_);
    lfi::fail(Errc::InvalidFile, "'{}': {}: property '{}' of {} {}: {}", path_.string(), where, shown(property_->name),
              shown(element_->name), instance_, fmt::format(f, std::forward<Args>(args)...));
  }

 private:
  static std::int64_t lowest(Type t) {
    switch (t) {
      case Type::Int8:
        return std::numeric_limits<std::int8_t>::min();
      case Type::Int16:
        return std::numeric_limits<std::int16_t>::min();
      case Type::Int32:
        return std::numeric_limits<std::int32_t>::min();
      default:
        return 0;
    }
  }
  static std::int64_t highest(Type t) {
    switch (t) {
      case Type::Int8:
        return std::numeric_limits<std::int8_t>::max();
      case Type::UInt8:
        return std::numeric_limits<std::uint8_t>::max();
      case Type::Int16:
        return std::numeric_limits<std::int16_t>::max();
      case Type::UInt16:
        return std::numeric_limits<std::uint16_t>::max();
      case Type::Int32:
        return std::numeric_limits<std::int32_t>::max();
      default:
        return std::numeric_limits<std::uint32_t>::max();
    }
  }

  std::string_view nextToken() {
    while (at_ < body_.size() && std::isspace(static_cast<unsigned char>(body_[at_])))
      if (body_[at_++] == '\n') ++line_;
    if (at_ == body_.size()) fail("the file ends before it");
    if (rowLine_ < 0)
      rowLine_ = line_;
    else if (line_ != rowLine_)
      line_ = rowLine_, fail("its line ends before it (a line holds one instance)");  // (named by the row's line)
    const size_t start = at_;
    while (at_ < body_.size() && !std::isspace(static_cast<unsigned char>(body_[at_]))) ++at_;
    return body_.substr(start, at_ - start);
  }

  [[noreturn]] void bad(std::string_view token, const char* expected) const {
    fail("'{}' is not {}", shown(token), expected);
  }

  // n bytes in the file's byte order, as an unsigned number.
  std::uint64_t raw(size_t n) {
    if (remaining() < n) fail("the file ends inside it");
    std::uint64_t v = 0;
    for (size_t i = 0; i < n; ++i) {
      const auto byte = static_cast<std::uint64_t>(static_cast<unsigned char>(body_[at_ + i]));
      v |= byte << (8 * (format_ == Format::LittleEndian ? i : n - 1 - i));
    }
    at_ += n;
    return v;
  }

  std::int64_t binaryInteger(Type t) {
    const std::uint64_t v = raw(sizeOf(t));
    switch (t) {
      case Type::Int8:
        return static_cast<std::int8_t>(v);
      case Type::Int16:
        return static_cast<std::int16_t>(v);
      case Type::Int32:
        return static_cast<std::int32_t>(v);
      default:
        return static_cast<std::int64_t>(v);
    }
  }

  const fs::path& path_;
  std::string_view body_;
  const Element* element_ = nullptr;
  std::uint64_t instance_ = 0;
  const Property* property_ = nullptr;
  size_t at_ = 0;
  size_t offset_;     // of the body in the file
  int line_;          // ASCII: the current line
  int rowLine_ = -1;  // ASCII: the line of the current instance's first value (-1: none read yet)
  Format format_;
};

[[noreturn]] void headerFail(const fs::path& path, int line, std::string_view what) {
  fail(Errc::InvalidFile, "'{}': line {}: {}", path.string(), line, what);
}

std::string readWholeFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(Errc::Io, "'{}': cannot open the mesh file", path.string());
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) fail(Errc::Io, "'{}': cannot read the mesh file", path.string());
  return std::move(bytes).str();
}

}  // namespace

bool isPly(std::string_view head) {
  return head.starts_with("ply\n") || head.starts_with("ply\r\n");
}

bool looksLikePly(std::string_view head) {
  if (head.starts_with("\xef\xbb\xbf")) head.remove_prefix(3);  // a UTF-8 byte order mark
  if (head.size() < 4) return false;
  auto lower = [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); };
  return lower(head[0]) == 'p' && lower(head[1]) == 'l' && lower(head[2]) == 'y' &&
         std::isspace(static_cast<unsigned char>(head[3]));
}

TriangleMesh readPly(const fs::path& path) {
  const std::string bytes = readWholeFile(path);
  if (!isPly(bytes)) fail(Errc::InvalidFile, "'{}': not a PLY file (the first line is not 'ply')", path.string());
  HeaderLines header(bytes);
  header.next();  // "ply"
  std::optional<Format> format;
  std::vector<Element> elements;
  for (;;) {
    const std::optional<std::string_view> line = header.next();
    if (!line) fail(Errc::InvalidFile, "'{}': the header has no 'end_header' line", path.string());
    const std::vector<std::string_view> w = words(*line);
    if (w.empty()) continue;
    if (w[0] == "end_header") break;
    if (w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "format") {
      if (format) headerFail(path, header.number(), "a second 'format' line");
      if (w.size() != 3 || w[2] != "1.0")
        headerFail(path, header.number(), "expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
      if (w[1] == "ascii")
        format = Format::Ascii;
      else if (w[1] == "binary_little_endian")
        format = Format::LittleEndian;
      else if (w[1] == "binary_big_endian")
        format = Format::BigEndian;
      else
        headerFail(path, header.number(), fmt::format("unknown format '{}'", shown(w[1])));
    } else if (w[0] == "element") {
      if (w.size() != 3) headerFail(path, header.number(), "expected 'element <name> <count>'");
      Element e{std::string(w[1]), 0, {}, header.number()};
      const auto [end, ec] = std::from_chars(w[2].data(), w[2].data() + w[2].size(), e.count);
      if (ec != std::errc() || end != w[2].data() + w[2].size())
        headerFail(path, header.number(),
                   fmt::format("element '{}': count '{}' is not a whole number", shown(e.name), shown(w[2])));
      elements.push_back(std::move(e));
    } else if (w[0] == "property") {
      if (elements.empty()) headerFail(path, header.number(), "a property before any element");
      Property p;
      if (w.size() == 5 && w[1] == "list") {
        const auto count = typeNamed(w[2]), item = typeNamed(w[3]);
        if (!count || !integral(*count))
          headerFail(path, header.number(), fmt::format("list count type '{}' is not an integer type", shown(w[2])));
        if (!item) headerFail(path, header.number(), fmt::format("unknown property type '{}'", shown(w[3])));
        p = {std::string(w[4]), *item, count};
      } else if (w.size() == 3) {
        const auto type = typeNamed(w[1]);
        if (!type) headerFail(path, header.number(), fmt::format("unknown property type '{}'", shown(w[1])));
        p = {std::string(w[2]), *type, std::nullopt};
      } else {
        headerFail(path, header.number(),
                   "expected 'property <type> <name>' or 'property list <count type> <type> <name>'");
      }
      elements.back().properties.push_back(std::move(p));
    } else {
      headerFail(path, header.number(), fmt::format("unknown header keyword '{}'", shown(w[0])));
    }
  }
  if (!format) fail(Errc::InvalidFile, "'{}': the header has no 'format' line", path.string());

  // The vertex positions and the faces' index lists.
  const Element* vertex = nullptr;
  const Element* face = nullptr;
  int vx = -1, vy = -1, vz = -1, indices = -1;
  for (const Element& e : elements) {
    if ((e.name == "vertex" && vertex) || (e.name == "face" && face))
      headerFail(path, e.line, fmt::format("a second '{}' element", e.name));
    if (e.name == "vertex") {
      vertex = &e;
      for (size_t i = 0; i < e.properties.size(); ++i) {
        const Property& p = e.properties[i];
        int* slot = p.name == "x" ? &vx : p.name == "y" ? &vy : p.name == "z" ? &vz : nullptr;
        if (slot && !p.count) *slot = static_cast<int>(i);
      }
    } else if (e.name == "face") {
      face = &e;
      for (size_t i = 0; i < e.properties.size(); ++i) {
        const Property& p = e.properties[i];
        if (p.count && (p.name == "vertex_indices" || p.name == "vertex_index")) indices = static_cast<int>(i);
      }
    }
  }
  if (!vertex || vx < 0 || vy < 0 || vz < 0)
    fail(Errc::InvalidFile, "'{}': the header has no 'vertex' element with properties x, y and z", path.string());
  if (!face || indices < 0)
    fail(Errc::InvalidFile, "'{}': the header has no 'face' element with a 'vertex_indices' list", path.string());
  if (!integral(face->properties[static_cast<size_t>(indices)].type))
    fail(Errc::InvalidFile, "'{}': the faces' 'vertex_indices' are not integers", path.string());
  if (vertex->count > std::numeric_limits<unsigned>::max())
    fail(Errc::InvalidFile, "'{}': {} vertices are more than a mesh holds", path.string(), vertex->count);

  const std::string_view body = std::string_view(bytes).substr(header.offset());
  BodyReader in(path, body, header.offset(), header.number() + 1, *format);
  TriangleMesh mesh;
  std::vector<std::int64_t> polygon;
  for (const Element& e : elements) {
    if (e.properties.empty()) continue;  // nothing to read, however many
    // Every instance takes some bytes (ASCII: a character and a separator per
    // value, the last instance of the file perhaps without its newline;
    // binary: its fixed-size values and list counts): a count the rest of the
    // file cannot hold is an error before anything is allocated.
    size_t least = 0;
    for (const Property& p : e.properties) least += in.ascii() ? 2 : sizeOf(p.count ? *p.count : p.type);
    if (e.count > (in.remaining() + (in.ascii() ? 1 : 0)) / least)
      fail(Errc::InvalidFile,
           "'{}': line {}: element '{}' declares {} instances, more than the file's remaining {} "
           "bytes can hold",
           path.string(), e.line, shown(e.name), e.count, in.remaining());
    const bool isVertex = &e == vertex, isFace = &e == face;
    if (isVertex) mesh.vertices.reserve(static_cast<size_t>(e.count));
    for (std::uint64_t n = 0; n < e.count; ++n) {
      in.beginInstance();
      double xyz[3] = {0, 0, 0};
      for (size_t i = 0; i < e.properties.size(); ++i) {
        const Property& p = e.properties[i];
        const int at = static_cast<int>(i);
        in.at(e, n, p);
        if (!p.count) {
          if (isVertex && (at == vx || at == vy || at == vz))
            xyz[at == vx ? 0 : at == vy ? 1 : 2] = in.real(p.type);
          else
            in.skip(p.type);
          continue;
        }
        const std::int64_t length = in.integer(*p.count);
        if (length < 0 || static_cast<std::uint64_t>(length) > in.remaining() / (in.ascii() ? 1 : sizeOf(p.type)))
          in.fail("a list of {} values does not fit in the file", length);
        if (!isFace || at != indices) {
          for (std::int64_t k = 0; k < length; ++k) in.skip(p.type);
          continue;
        }
        polygon.clear();
        for (std::int64_t k = 0; k < length; ++k) {
          const std::int64_t index = in.integer(p.type);
          if (index < 0 || static_cast<std::uint64_t>(index) >= vertex->count)
            in.fail("vertex index {} is not among the {} vertices", index, vertex->count);
          polygon.push_back(index);
        }
        if (polygon.size() > 2 && mesh.triangles.size() + polygon.size() - 2 > kMostTriangles)
          in.fail("the faces so far make more than {} triangles, the most a mesh may have", kMostTriangles);
        for (size_t k = 2; k < polygon.size(); ++k)  // a fan of n - 2 triangles; points and lines have no surface
          mesh.triangles.push_back({static_cast<unsigned>(polygon[0]), static_cast<unsigned>(polygon[k - 1]),
                                    static_cast<unsigned>(polygon[k])});
      }
      in.endInstance();
      if (isVertex) mesh.vertices.push_back({xyz[0], xyz[1], xyz[2]});
    }
  }
  in.end();
  return mesh;
}

}  // namespace lfi::sim::detail
