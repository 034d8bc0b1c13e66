// SPDX-License-Identifier: Apache-2.0
#pragma once
// Reading human-edited TOML files (benches, scenes) with errors that name the
// file, line and key. Every key read is recorded; finish() turns any key that
// was never read (a typo, a key from another version) into an error, as
// pbrt's ReportUnused does.

#include <toml++/toml.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace lfi {

class ConfigTable {
 public:
  // Parses a file; throws Errc::NotFound or Errc::Config (with line and column).
  static ConfigTable parseFile(const std::filesystem::path& path);

  // A number of the file replaced: "table.key" (dotted for nested tables)
  // and its value. The key must be a number in the file: an integer's value
  // must be whole.
  struct Override {
    std::string key;
    double value;
  };
  // Parses a file with `overrides` applied before anything reads it, so
  // that every check sees the values; the errors name the file and the
  // overridden key's line. An override whose key the file has not, or has
  // as no number, throws Errc::Config naming it.
  static ConfigTable parseFile(const std::filesystem::path& path, const std::vector<Override>& overrides);

  double number(const std::string& key, std::optional<double> fallback = std::nullopt, double min = -1e300,
                double max = 1e300);
  int integer(const std::string& key, std::optional<int> fallback = std::nullopt, int min = -(1 << 30),
              int max = 1 << 30);
  // The same for TOML's whole range of integers (64-bit signed).
  std::int64_t integer64(const std::string& key, std::optional<std::int64_t> fallback, std::int64_t min,
                         std::int64_t max);
  std::string string(const std::string& key, std::optional<std::string> fallback = std::nullopt,
                     const std::vector<std::string>& allowed = {});
  // An array of numbers of fixed length (e.g. a position [x, y, z]), each in [min, max].
  std::vector<double> numbers(const std::string& key, size_t count,
                              std::optional<std::vector<double>> fallback = std::nullopt, double min = -1e300,
                              double max = 1e300);
  // The same for an array of minCount .. maxCount numbers.
  std::vector<double> numbers(const std::string& key, size_t minCount, size_t maxCount,
                              std::optional<std::vector<double>> fallback, double min, double max);
  // A non-empty array of strings, each one of `allowed` (when given) and none twice.
  std::vector<std::string> strings(const std::string& key, std::optional<std::vector<std::string>> fallback,
                                   const std::vector<std::string>& allowed = {});
  bool has(const std::string& key) const;
  ConfigTable table(const std::string& key);
  // An array of tables ([[key]] in TOML); empty when the key is absent.
  std::vector<ConfigTable> tables(const std::string& key);
  // The folder of the file, for resolving relative paths in it.
  std::filesystem::path directory() const { return std::filesystem::path(file_).parent_path(); }
  // Throws Errc::Config for the first key of this table that was not read
  // (call it on every subtable too).
  void finish() const;
  // Throws Errc::Config, listing `known`, for the first key of this table (by
  // line) that is not among them: before anything is read, so that a
  // misspelt table ("[camra]") is named as such rather than as a missing one.
  void requireKnownKeys(const std::vector<std::string>& known) const;

  const std::string& file() const { return file_; }
  std::string where(const std::string& key) const;  // "file:line: key 'a.b'"

 private:
  ConfigTable(std::shared_ptr<const toml::table> root, const toml::table* table, std::string file, std::string path);
  const toml::node* node(const std::string& key);

  std::shared_ptr<const toml::table> root_;
  const toml::table* table_;
  std::string file_;
  std::string path_;
  std::set<std::string> used_;
};

}  // namespace lfi
