// SPDX-License-Identifier: Apache-2.0
#pragma once
// Seeded edits of a TOML file's values, of the kinds a hand edit or a script
// gets wrong: a number replaced by zero, a sign, an extreme, NaN or infinity,
// an integer past 32 bits, a scaled or shifted value; a string replaced by
// another word of the same file (another shape, material or lookup); a value
// of another type; a key or an array element removed or repeated; a table of
// an array of tables repeated; a key no version knows. The file stays valid
// TOML, so that the edits reach the reader's checks of values, not the TOML
// parser (byte-level damage, tests/support/lfi_test_support.h, covers that).

#include <toml++/toml.h>

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace lfi::testing_support {

namespace toml_mutation_detail {

// A value, an array or a table, and where it sits: a table's key or an array's index.
struct Place {
  toml::node* node;
  toml::table* table;  // the parent, or
  toml::array* array;  // the parent
  std::string key;
  size_t index;
  std::string path;  // for messages: "object[1].radius_mm"
};

inline void collect(toml::table& table, const std::string& prefix, std::vector<Place>& places,
                    std::vector<std::string>& words);

inline void collect(toml::array& array, const std::string& prefix, std::vector<Place>& places,
                    std::vector<std::string>& words) {
  for (size_t i = 0; i < array.size(); ++i) {
    toml::node& n = array[i];
    const std::string path = fmt::format("{}[{}]", prefix, i);
    places.push_back({&n, nullptr, &array, {}, i, path});
    if (auto* t = n.as_table()) collect(*t, path, places, words);
    if (auto* a = n.as_array()) collect(*a, path, places, words);
    if (auto* s = n.as_string()) words.push_back(s->get());
  }
}

inline void collect(toml::table& table, const std::string& prefix, std::vector<Place>& places,
                    std::vector<std::string>& words) {
  for (auto&& [key, n] : table) {
    const std::string path = prefix.empty() ? std::string(key.str()) : prefix + "." + std::string(key.str());
    places.push_back({&n, &table, nullptr, std::string(key.str()), 0, path});
    if (auto* t = n.as_table()) collect(*t, path, places, words);
    if (auto* a = n.as_array()) collect(*a, path, places, words);
    if (auto* s = n.as_string()) words.push_back(s->get());
  }
}

template <typename V>
void put(const Place& p, V&& value) {
  if (p.table != nullptr)
    p.table->insert_or_assign(p.key, std::forward<V>(value));
  else
    p.array->replace(p.array->cbegin() + static_cast<std::ptrdiff_t>(p.index), std::forward<V>(value));
}

inline void erase(const Place& p) {
  if (p.table != nullptr)
    p.table->erase(p.key);
  else
    p.array->erase(p.array->cbegin() + static_cast<std::ptrdiff_t>(p.index));
}

}  // namespace toml_mutation_detail

// One seeded edit of `text` (valid TOML); returns the edited file and says
// what was done in `what` (for a failure's message).
inline std::string mutateTomlValue(const std::string& text, std::mt19937& rng, std::string& what) {
  using namespace toml_mutation_detail;
  toml::table root = toml::parse(text);
  std::vector<Place> places;
  std::vector<std::string> words{"", std::string(300, 'x'), "\xce\xbcm"};
  collect(root, "", places, words);
  if (places.empty()) return text;
  const Place& p = places[rng() % places.size()];
  auto pick = [&](const auto& list) { return list[rng() % std::size(list)]; };
  const double current = p.node->is_number() ? p.node->value<double>().value_or(1.0) : 1.0;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  switch (rng() % 9) {
    case 0: {
      const double v = pick(std::vector<double>{0.0, -0.0, -1.0, 1e-9, 1e-300, 1e300, 0.5, 2.0, 1e6,
                                                std::numeric_limits<double>::quiet_NaN(), kInf, -kInf});
      put(p, v);
      what = fmt::format("{} = {} (float)", p.path, v);
      break;
    }
    case 1: {
      const std::int64_t v = pick(std::vector<std::int64_t>{0, -1, 1, 3, 1000000, 2147483647, 2147483648, 4294967297,
                                                            std::numeric_limits<std::int64_t>::max(),
                                                            std::numeric_limits<std::int64_t>::min()});
      put(p, v);
      what = fmt::format("{} = {} (integer)", p.path, v);
      break;
    }
    case 2: {
      const double v = pick(std::vector<double>{-current, current * 1e3, current * 1e-3, current + 1, current - 1,
                                                std::nextafter(current, kInf)});
      if (p.node->is_integer() && std::abs(v) < 9e18 && v == std::floor(v))
        put(p, static_cast<std::int64_t>(v));
      else
        put(p, v);
      what = fmt::format("{} = {} (from {})", p.path, v, current);
      break;
    }
    case 3: {
      const std::string v = pick(words);
      put(p, v);
      what = fmt::format("{} = \"{}\"", p.path, v.size() > 40 ? v.substr(0, 40) + "..." : v);
      break;
    }
    case 4: {
      switch (rng() % 4) {
        case 0:
          put(p, std::string("1"));
          break;
        case 1:
          put(p, true);
          break;
        case 2:
          put(p, toml::array{1, 2});
          break;
        default:
          put(p, toml::table{{"a", 1}});
      }
      what = fmt::format("{}: another type", p.path);
      break;
    }
    case 5:
      erase(p);
      what = fmt::format("{} removed", p.path);
      break;
    case 6: {
      auto* a = p.node->as_array();
      if (a == nullptr || a->empty()) return mutateTomlValue(text, rng, what);
      if (rng() % 2 != 0) {
        const toml::node& first = (*a)[0];
        if (auto* t = first.as_table())
          a->push_back(toml::table(*t));  // (a copy before the array grows)
        else if (auto* n = first.as_floating_point())
          a->push_back(n->get());
        else if (auto* i = first.as_integer())
          a->push_back(i->get());
        else
          a->push_back(1);
        what = fmt::format("{}: one element more", p.path);
      } else {
        a->erase(a->cend() - 1);
        what = fmt::format("{}: one element less", p.path);
      }
      break;
    }
    case 7: {
      auto* t = p.node->as_table();
      if (t == nullptr) return mutateTomlValue(text, rng, what);
      t->insert_or_assign("colour", 1);
      what = fmt::format("{}: an unknown key 'colour'", p.path);
      break;
    }
    default: {
      if (p.array == nullptr || !p.node->is_table()) return mutateTomlValue(text, rng, what);
      p.array->push_back(toml::table(*p.node->as_table()));
      what = fmt::format("{}: repeated", p.path);
    }
  }
  std::ostringstream out;
  out << root;
  return out.str();
}

// 1 to maxEdits edits of `text`; `what` lists them.
inline std::string mutateTomlValues(std::string text, std::mt19937& rng, int maxEdits, std::string& what) {
  what.clear();
  for (int edits = 1 + static_cast<int>(rng() % static_cast<unsigned>(maxEdits)); edits > 0; --edits) {
    std::string one;
    text = mutateTomlValue(text, rng, one);
    what += (what.empty() ? "" : "; ") + one;
  }
  return text;
}

}  // namespace lfi::testing_support
