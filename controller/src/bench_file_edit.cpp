// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/bench_file_edit.h"

#include "lfi/controller/bench_file.h"
#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/core/input_file.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <toml++/toml.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <vector>

namespace fs = std::filesystem;

namespace lfi {

namespace {

bool bareKey(const std::string& key) {
  return !key.empty() && std::all_of(key.begin(), key.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

std::vector<std::string> splitPath(const std::string& path) {
  std::vector<std::string> parts;
  for (size_t start = 0;;) {
    const size_t dot = path.find('.', start);
    parts.push_back(path.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
    if (!bareKey(parts.back()))
      fail(Errc::InvalidArgument, "bench file edit: '{}' is not a table name of bare keys", path);
    if (dot == std::string::npos) return parts;
    start = dot + 1;
  }
}

toml::table parseText(const std::string& text, const fs::path& file) {
  try {
    return toml::parse(text, file.string());
  } catch (const toml::parse_error& e) {
    fail(Errc::Config, "{}:{}:{}: {}", file.string(), e.source().begin.line, e.source().begin.column, e.description());
  }
}

// The byte offset of a toml++ source position (1-based line, 1-based column in code points).
size_t offsetOf(const std::string& text, const toml::source_position& at) {
  size_t offset = 0;
  for (toml::source_index line = 1; line < at.line; ++line) {
    const size_t end = text.find('\n', offset);
    if (end == std::string::npos) return text.size();
    offset = end + 1;
  }
  for (toml::source_index column = 1; column < at.column && offset < text.size() && text[offset] != '\n'; ++column) {
    ++offset;  // past the lead byte, then any continuation bytes of the code point
    while (offset < text.size() && (static_cast<unsigned char>(text[offset]) & 0xC0) == 0x80) ++offset;
  }
  return offset;
}

size_t lineEnd(const std::string& text, size_t offset) {
  const size_t end = text.find('\n', offset);
  return end == std::string::npos ? text.size() : end;
}

// The table at `parts`, or nullptr; one that only exists as a parent of another ([a.b] without [a]) counts as
// absent too (it has no place of its own in the text).
const toml::table* findTable(const toml::table& root, const std::vector<std::string>& parts, size_t count) {
  const toml::table* t = &root;
  for (size_t k = 0; k < count && t; ++k) {
    const toml::node* n = t->get(parts[k]);
    t = n ? n->as_table() : nullptr;
  }
  if (t && count > 0 && t->source().begin.line == 0) return nullptr;
  return t;
}

// How a table stands in the text: under a [header] of its own; only through the headers of its sub-tables ([a.b]
// or [[a.b]] without [a]: toml++ places it at that header); or in the lines of another table, inline ({...}) or by
// dotted keys (a.b = 1).
enum class Written { OwnHeader, ThroughSubTables, InLines };

Written written(const std::string& text, const toml::table& t) {
  if (t.is_inline()) return Written::InLines;
  if (t.source().begin.line == 0) return Written::ThroughSubTables;
  const size_t at = offsetOf(text, t.source().begin);
  if (at >= text.size() || text[at] != '[') return Written::InLines;
  if (text.compare(at, 2, "[[") == 0) return Written::ThroughSubTables;  // ([[a.b]] without [a]: the same)
  for (auto&& [k, v] : t)
    if (v.is_table() && v.source().begin == t.source().begin) return Written::ThroughSubTables;
  return Written::OwnHeader;
}

// The last line of the table's own lines: its header's, or its last key's, a key of a table in it written by
// dotted keys too (a sub-table's [header] or [[header]] starts the lines of another).
toml::source_index lastLine(const std::string& text, const toml::table& table, toml::source_index line) {
  for (auto&& [k, v] : table) {
    if (const toml::table* sub = v.as_table(); sub && !sub->is_inline()) {
      if (written(text, *sub) != Written::OwnHeader) line = lastLine(text, *sub, line);
      continue;
    }
    if (v.is_array_of_tables() && text.compare(offsetOf(text, v.source().begin), 2, "[[") == 0) continue;
    line = std::max(line, v.source().end.line);
  }
  return line;
}

// The offset just after the table's own lines.
size_t afterLastKey(const std::string& text, const toml::table& table) {
  const size_t end = lineEnd(text, offsetOf(text, {lastLine(text, table, table.source().begin.line), 1}));
  return end == text.size() ? end : end + 1;
}

// Inserts `lines` (each ending in a newline) at `at`, the start of a line or the end of the text: after a last
// line that has no newline of its own, on lines of their own all the same.
void insertLines(std::string& text, size_t at, const std::string& lines) {
  if (at == text.size() && !text.empty() && text.back() != '\n') {
    text += '\n';
    at = text.size();
  }
  text.insert(at, lines);
}

// The whole file, checked first as every reader of a user's file does (input_file.h).
std::string readText(const fs::path& file) {
  requireInputFile(file, "bench file");
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in) fail(Errc::Io, "bench file '{}' cannot be read", file.string());
  return text.str();
}

std::string withComment(const std::string& value, const std::string& comment) {
  return comment.empty() ? value : value + "  # " + comment;
}

}  // namespace

BenchFileEdit::BenchFileEdit(fs::path file) : file_(std::move(file)) {
  original_ = text_ = readText(file_);
  parseText(text_, file_);
}

void BenchFileEdit::set(const std::string& table, const std::string& key, const std::string& value,
                        const std::string& comment) {
  const std::vector<std::string> parts = table.empty() ? std::vector<std::string>{} : splitPath(table);
  if (!bareKey(key)) fail(Errc::InvalidArgument, "bench file edit: '{}' is not a bare key", key);
  if (comment.find('\n') != std::string::npos || value.find('\n') != std::string::npos)
    fail(Errc::InvalidArgument, "bench file edit: a value or comment of more than one line for {}.{}", table, key);
  const toml::table root = parseText(text_, file_);
  // The table, where it is: every name on the way to it a table (a value or an array of tables takes no key).
  const toml::table* t = &root;
  bool inlined = false;  // the table, or one it is in, is written inline: it takes no line
  for (size_t k = 0; k < parts.size() && t; ++k) {
    const toml::node* n = t->get(parts[k]);
    if (n && !n->is_table())
      fail(Errc::InvalidArgument, "bench file edit: {} in '{}' holds a value or an array of tables, not a table",
           fmt::join(parts.begin(), parts.begin() + static_cast<std::ptrdiff_t>(k) + 1, "."), file_.string());
    t = n ? n->as_table() : nullptr;
    inlined = inlined || (t && t->is_inline());
  }
  const std::string line = withComment(fmt::format("{} = {}", key, value), comment);
  if (parts.empty() && !t->get(key)) {  // a new key of the file's own: after its last one, before any table
    insertLines(text_, afterLastKey(text_, root), line + "\n");
    return;
  }
  if (t) {
    if (const toml::node* old = t->get(key)) {
      if (old->is_table() || old->is_array_of_tables())
        fail(Errc::InvalidArgument, "bench file edit: {}.{} in '{}' is a table or an array of tables, not a value",
             table, key, file_.string());
      // The value in place; with a comment, the rest of its last line (the old comment) goes, which must be no more.
      const size_t begin = offsetOf(text_, old->source().begin), end = offsetOf(text_, old->source().end);
      const size_t stop = comment.empty() ? end : lineEnd(text_, end);
      const size_t after = text_.find_first_not_of(" \t\r", end);
      if (!comment.empty() && after < stop && text_[after] != '#')
        fail(Errc::InvalidArgument,
             "bench file edit: {}.{} in '{}' shares its line with more than a comment (an inline table): no "
             "comment can follow its value",
             table, key, file_.string());
      text_.replace(begin, stop - begin, withComment(value, comment));
      return;
    }
    const Written w = written(text_, *t);
    if (w == Written::OwnHeader) {
      insertLines(text_, afterLastKey(text_, *t), line + "\n");
      return;
    }
    if (w == Written::InLines || inlined)
      fail(Errc::InvalidArgument,
           "bench file edit: [{}] in '{}' is written inline or by dotted keys, not under a [{}] header of its own: "
           "add '{}' to it by hand",
           table, file_.string(), table, line);
  }
  // A new table (or one only there as the parent of its sub-tables): after its parent's keys, or at the end.
  if (inlined)
    fail(Errc::InvalidArgument, "bench file edit: [{}] in '{}' would be in an inline table: add '{}' to it by hand",
         table, file_.string(), line);
  const std::string header = fmt::format("[{}]\n{}\n", table, line);
  const toml::table* parent = parts.size() > 1 ? findTable(root, parts, parts.size() - 1) : nullptr;
  if (parent && written(text_, *parent) == Written::OwnHeader) {
    insertLines(text_, afterLastKey(text_, *parent), header);
    return;
  }
  if (!text_.empty() && text_.back() != '\n') text_ += '\n';
  text_ += "\n" + header;
}

void BenchFileEdit::remove(const std::string& table, const std::string& key) {
  const toml::table root = parseText(text_, file_);
  const std::vector<std::string> parts = splitPath(table);
  const toml::table* t = findTable(root, parts, parts.size());
  const toml::node* old = t ? t->get(key) : nullptr;
  if (!old) return;
  if (old->is_table() || old->is_array_of_tables())
    fail(Errc::InvalidArgument, "bench file edit: {}.{} in '{}' is a table or an array of tables, not a value", table,
         key, file_.string());
  // The whole line, which must hold nothing but the key, its value and a comment.
  const size_t begin = offsetOf(text_, old->source().begin), end = offsetOf(text_, old->source().end);
  const size_t start = text_.rfind('\n', begin) == std::string::npos ? 0 : text_.rfind('\n', begin) + 1;
  const size_t stop = lineEnd(text_, end), after = text_.find_first_not_of(" \t\r", end);
  const std::string head = text_.substr(start, begin - start);
  if (head.find_first_not_of(" \t") != head.find(key) || (after < stop && text_[after] != '#'))
    fail(Errc::InvalidArgument, "bench file edit: {}.{} in '{}' shares its line with other keys: remove it by hand",
         table, key, file_.string());
  text_.erase(start, std::min(stop + 1, text_.size()) - start);
}

std::optional<std::string> BenchFileEdit::string(const std::string& table, const std::string& key) const {
  const std::vector<std::string> parts = splitPath(table);
  const toml::table root = parseText(text_, file_);
  const toml::table* t = findTable(root, parts, parts.size());
  if (!t) return std::nullopt;
  const toml::node* n = t->get(key);
  if (!n || !n->is_string()) return std::nullopt;
  return n->value<std::string>();
}

std::string tomlString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      out += fmt::format("\\u{:04X}", static_cast<unsigned>(static_cast<unsigned char>(c)));
      continue;
    }
    out += c;
  }
  return out + "\"";
}

std::string BenchFileEdit::changes() const {
  const auto lines = [](const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) out.push_back(line);
    return out;
  };
  const std::vector<std::string> a = lines(original_), b = lines(text_);
  // The longest common subsequence of lines, then the lines off it.
  std::vector<std::vector<int>> common(a.size() + 1, std::vector<int>(b.size() + 1, 0));
  for (size_t i = a.size(); i-- > 0;)
    for (size_t j = b.size(); j-- > 0;)
      common[i][j] = a[i] == b[j] ? common[i + 1][j + 1] + 1 : std::max(common[i + 1][j], common[i][j + 1]);
  std::string out;
  size_t i = 0, j = 0;
  while (i < a.size() || j < b.size()) {
    if (i < a.size() && j < b.size() && a[i] == b[j]) {
      ++i, ++j;
    } else if (i < a.size() && (j == b.size() || common[i + 1][j] >= common[i][j + 1])) {
      out += fmt::format("- {:4} | {}\n", i + 1, a[i]);
      ++i;
    } else {
      out += fmt::format("+ {:4} | {}\n", j + 1, b[j]);
      ++j;
    }
  }
  return out;
}

fs::path calibrationFile(const fs::path& benchFile, const std::string& stampUtc, const std::string& what,
                         const std::string& extension) {
  std::string stamp = stampUtc;
  std::erase(stamp, ':');
  return benchFile.parent_path() / (benchFile.stem().string() + ".calibrations") / (stamp + "-" + what + extension);
}

PublishedCalibration publishCalibration(const BenchFileEdit& edit, const std::string& what, const std::string& stampUtc,
                                        const std::string& recordJson) {
  const fs::path& file = edit.file();
  const fs::path folder = calibrationFile(file, stampUtc, what, "").parent_path();
  PublishedCalibration out{calibrationFile(file, stampUtc, what, ".before.toml"),
                           calibrationFile(file, stampUtc, what, ".json")};
  {
    if (readText(file) != edit.original())
      fail(Errc::Exists,
           "bench file '{}' changed since the calibration read it: not replaced (run the "
           "calibration again)",
           file.string());
  }
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) fail(Errc::Io, "cannot create the calibration folder '{}': {}", folder.string(), ec.message());
  writeFileAtomically(out.backup, Overwrite::Refuse, edit.original());
  // From here on a failure takes the backup and the record back: no record of a calibration not applied.
  struct Undo {
    std::vector<fs::path> files;
    ~Undo() {
      std::error_code ignored;
      for (const fs::path& f : files) fs::remove(f, ignored);
    }
  } undo{{out.backup}};
  writeFileAtomically(out.record, Overwrite::Refuse, recordJson);
  undo.files.push_back(out.record);
  writeFileAtomically(file, Overwrite::Allow, [&](const fs::path& temporary) {
    {
      std::ofstream o(temporary, std::ios::binary);
      o << edit.text();
      if (!o.flush()) fail(Errc::Io, "cannot write '{}'", temporary.string());
    }
    try {
      readBenchFile(temporary);
    } catch (const Error& e) {
      fail(Errc::Config, "the calibrated bench file would not read back, '{}' is left as it was: {}", file.string(),
           e.what());
    }
  });
  undo.files.clear();
  return out;
}

}  // namespace lfi
