// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/config.h"

#include "lfi/core/error.h"
#include "lfi/core/input_file.h"

#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>

namespace lfi {

ConfigTable::ConfigTable(std::shared_ptr<const toml::table> root, const toml::table* table, std::string file,
                         std::string path)
    : root_(std::move(root)), table_(table), file_(std::move(file)), path_(std::move(path)) {}

ConfigTable ConfigTable::parseFile(const std::filesystem::path& path) {
  requireInputFile(path);
  try {
    auto root = std::make_shared<const toml::table>(toml::parse_file(path.string()));
    return ConfigTable(root, root.get(), path.string(), "");
  } catch (const toml::parse_error& e) {
    fail(Errc::Config, "{}:{}:{}: {}", path.string(), e.source().begin.line, e.source().begin.column,
         std::string(e.description()));
  }
}

ConfigTable ConfigTable::parseFile(const std::filesystem::path& path, const std::vector<Override>& overrides) {
  ConfigTable parsed = parseFile(path);
  auto root = std::make_shared<toml::table>(*parsed.root_);
  for (const Override& o : overrides) {
    toml::node* n = root->at_path(o.key).node();
    if (!n || !n->is_number()) fail(Errc::Config, "{}: has no number '{}' to set", path.string(), o.key);
    if (!std::isfinite(o.value)) fail(Errc::Config, "{}: '{}' cannot be set to {}", path.string(), o.key, o.value);
    const toml::source_region where = n->source();
    if (n->is_integer()) {
      if (o.value != std::floor(o.value) || std::abs(o.value) > 9.0e15)
        fail(Errc::Config, "{}:{}: the whole number '{}' cannot be set to {}", path.string(), where.begin.line, o.key,
             o.value);
      n->as_integer()->get() = static_cast<std::int64_t>(o.value);  // (in place: the node keeps its line)
    } else {
      n->as_floating_point()->get() = o.value;
    }
  }
  return ConfigTable(root, root.get(), path.string(), "");
}

std::string ConfigTable::where(const std::string& key) const {
  const std::string full = path_.empty() ? key : path_ + "." + key;
  const toml::node* n = table_->get(key);
  const auto line = n ? n->source().begin.line : table_->source().begin.line;
  return fmt::format("{}:{}: key '{}'", file_, line, full);
}

bool ConfigTable::has(const std::string& key) const {
  return table_->contains(key);
}

const toml::node* ConfigTable::node(const std::string& key) {
  used_.insert(key);
  return table_->get(key);
}

double ConfigTable::number(const std::string& key, std::optional<double> fallback, double min, double max) {
  const toml::node* n = node(key);
  if (!n) {
    if (!fallback) fail(Errc::Config, "{} is missing", where(key));
    return *fallback;
  }
  std::optional<double> v =
      n->is_integer() ? std::optional<double>(static_cast<double>(*n->value<int64_t>())) : n->value<double>();
  if (!v || !n->is_number()) fail(Errc::Config, "{} must be a number", where(key));
  if (!std::isfinite(*v) || *v < min || *v > max)
    fail(Errc::Config, "{} = {} is outside [{}, {}]", where(key), *v, min, max);
  return *v;
}

int ConfigTable::integer(const std::string& key, std::optional<int> fallback, int min, int max) {
  return static_cast<int>(integer64(key, fallback, min, max));
}

std::int64_t ConfigTable::integer64(const std::string& key, std::optional<std::int64_t> fallback, std::int64_t min,
                                    std::int64_t max) {
  const toml::node* n = node(key);
  if (!n) {
    if (!fallback) fail(Errc::Config, "{} is missing", where(key));
    return *fallback;
  }
  if (!n->is_integer()) fail(Errc::Config, "{} must be an integer", where(key));
  const std::int64_t v = *n->value<std::int64_t>();
  if (v < min || v > max) fail(Errc::Config, "{} = {} is outside [{}, {}]", where(key), v, min, max);
  return v;
}

std::string ConfigTable::string(const std::string& key, std::optional<std::string> fallback,
                                const std::vector<std::string>& allowed) {
  const toml::node* n = node(key);
  if (!n) {
    if (!fallback) fail(Errc::Config, "{} is missing", where(key));
    return *fallback;
  }
  if (!n->is_string()) fail(Errc::Config, "{} must be a string", where(key));
  std::string v = *n->value<std::string>();
  if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), v) == allowed.end())
    fail(Errc::Config, "{} = '{}' is not one of: {}", where(key), v, fmt::join(allowed, ", "));
  return v;
}

std::vector<double> ConfigTable::numbers(const std::string& key, size_t count,
                                         std::optional<std::vector<double>> fallback, double min, double max) {
  return numbers(key, count, count, std::move(fallback), min, max);
}

std::vector<double> ConfigTable::numbers(const std::string& key, size_t minCount, size_t maxCount,
                                         std::optional<std::vector<double>> fallback, double min, double max) {
  const toml::node* n = node(key);
  if (!n) {
    if (!fallback) fail(Errc::Config, "{} is missing", where(key));
    return *fallback;
  }
  const std::string count =
      minCount == maxCount ? fmt::format("{}", minCount) : fmt::format("{} to {}", minCount, maxCount);
  const toml::array* a = n->as_array();
  if (!a || a->size() < minCount || a->size() > maxCount)
    fail(Errc::Config, "{} must be an array of {} numbers", where(key), count);
  std::vector<double> out;
  for (const toml::node& e : *a) {
    std::optional<double> v =
        e.is_integer() ? std::optional<double>(static_cast<double>(*e.value<int64_t>())) : e.value<double>();
    if (!e.is_number() || !v || !std::isfinite(*v))
      fail(Errc::Config, "{} must be an array of {} numbers", where(key), count);
    if (*v < min || *v > max)
      fail(Errc::Config, "{}: {} (element {}) is outside [{}, {}]", where(key), *v, out.size(), min, max);
    out.push_back(*v);
  }
  return out;
}

std::vector<std::string> ConfigTable::strings(const std::string& key, std::optional<std::vector<std::string>> fallback,
                                              const std::vector<std::string>& allowed) {
  const toml::node* n = node(key);
  if (!n) {
    if (!fallback) fail(Errc::Config, "{} is missing", where(key));
    return *fallback;
  }
  const toml::array* a = n->as_array();
  if (!a || a->empty()) fail(Errc::Config, "{} must be a non-empty array of strings", where(key));
  std::vector<std::string> out;
  for (const toml::node& e : *a) {
    const std::optional<std::string> v = e.value<std::string>();
    if (!v) fail(Errc::Config, "{} must be a non-empty array of strings", where(key));
    if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), *v) == allowed.end())
      fail(Errc::Config, "{}: '{}' is not one of {}", where(key), *v, fmt::join(allowed, ", "));
    if (std::find(out.begin(), out.end(), *v) != out.end())
      fail(Errc::Config, "{}: '{}' is there twice", where(key), *v);
    out.push_back(*v);
  }
  return out;
}

std::vector<ConfigTable> ConfigTable::tables(const std::string& key) {
  const toml::node* n = node(key);
  std::vector<ConfigTable> out;
  if (!n) return out;
  const std::string path = path_.empty() ? key : path_ + "." + key;
  const toml::array* a = n->as_array();
  // (An empty array is none: toml++ does not count it as an array of tables.)
  if (!a || (!a->empty() && !a->is_array_of_tables()))
    fail(Errc::Config, "{} must be an array of tables ([[{}]])", where(key), path);
  for (size_t i = 0; i < a->size(); ++i)
    out.push_back(ConfigTable(root_, a->get(i)->as_table(), file_, fmt::format("{}[{}]", path, i)));
  return out;
}

ConfigTable ConfigTable::table(const std::string& key) {
  const toml::node* n = node(key);
  if (!n) fail(Errc::Config, "{}: table [{}] is missing", file_, path_.empty() ? key : path_ + "." + key);
  if (!n->is_table()) fail(Errc::Config, "{} must be a table", where(key));
  return ConfigTable(root_, n->as_table(), file_, path_.empty() ? key : path_ + "." + key);
}

void ConfigTable::finish() const {
  for (const auto& [k, v] : *table_) {
    const std::string key(k.str());
    if (!used_.count(key))
      fail(Errc::Config, "{}:{}: unknown key '{}'", file_, v.source().begin.line,
           path_.empty() ? key : path_ + "." + key);
  }
}

void ConfigTable::requireKnownKeys(const std::vector<std::string>& known) const {
  const toml::node* first = nullptr;
  std::string firstKey;
  for (const auto& [k, v] : *table_)
    if (std::find(known.begin(), known.end(), k.str()) == known.end() &&
        (!first || v.source().begin.line < first->source().begin.line))
      first = &v, firstKey = k.str();
  if (first)
    fail(Errc::Config, "{}:{}: unknown key '{}' (known here: {})", file_, first->source().begin.line,
         path_.empty() ? firstKey : path_ + "." + firstKey, fmt::join(known, ", "));
}

}  // namespace lfi
