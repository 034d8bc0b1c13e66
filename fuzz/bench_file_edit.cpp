// SPDX-License-Identifier: Apache-2.0
// The bench file editor the calibrations write their results with (controller/bench_file_edit.h), as a round
// trip. The first line names the edit, "<table> <key> [<n>]": n picks the value (a number, an array, a string)
// and whether a comment goes with it; the rest is the bench file, any text. An edit the editor takes must keep
// the user's file: the text still TOML, the key holding the value set, every other key and table as it was, and
// every line the edit did not touch still there, in order (the old value's lines are the ones it touches).
#include "fuzz_input.h"

#include "lfi/controller/bench_file_edit.h"

#include <toml++/toml.h>

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

namespace {

// Whether two nodes hold the same keys and values (a NaN the same as a NaN).
bool same(const toml::node& a, const toml::node& b) {
  if (a.type() != b.type()) return false;
  if (const toml::table* t = a.as_table()) {
    const toml::table& u = *b.as_table();
    if (t->size() != u.size()) return false;
    for (auto&& [key, value] : *t)
      if (const toml::node* other = u.get(key); !other || !same(value, *other)) return false;
    return true;
  }
  if (const toml::array* x = a.as_array()) {
    const toml::array& y = *b.as_array();
    if (x->size() != y.size()) return false;
    for (std::size_t i = 0; i < x->size(); ++i)
      if (!same(*x->get(i), *y.get(i))) return false;
    return true;
  }
  if (const auto* f = a.as_floating_point()) {
    const double p = f->get(), q = b.as_floating_point()->get();
    return p == q || (std::isnan(p) && std::isnan(q));
  }
  if (const auto* s = a.as_string()) return s->get() == b.as_string()->get();
  if (const auto* i = a.as_integer()) return i->get() == b.as_integer()->get();
  if (const auto* v = a.as_boolean()) return v->get() == b.as_boolean()->get();
  if (const auto* d = a.as_date()) return d->get() == b.as_date()->get();
  if (const auto* t = a.as_time()) return t->get() == b.as_time()->get();
  return a.as_date_time()->get() == b.as_date_time()->get();
}

// The table at the first `count` names of `path`, or nullptr.
toml::table* tableAt(toml::table& root, const std::vector<std::string>& path, std::size_t count) {
  toml::table* t = &root;
  for (std::size_t k = 0; k < count && t; ++k) t = t->get_as<toml::table>(path[k]);
  return t;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

void require(bool holds, const char* what) {
  if (holds) return;
  std::fprintf(stderr, "bench_file_edit: the edit broke the file: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input = lfi::fuzz::text(data, size);
  const std::size_t firstLineEnd = std::min(input.find('\n'), input.size());
  std::istringstream command{std::string(input.substr(0, firstLineEnd))};
  std::string table, key;
  unsigned n = 0;
  if (!(command >> table >> key)) return 0;
  command >> n;
  const std::string values[] = {"0.4991",
                                "[28, 26.5]",
                                "\"lenslet_array\"",
                                "-1",
                                "[0.5, 0.01, 0.01, -0.5]",
                                lfi::tomlString("a \"b\" c:\\d\te")};
  const std::string& value = values[n % 6];
  const std::string comment = n % 12 >= 6 ? "± 0.0003 mm (calibrated)" : "";
  const std::string before(input.substr(std::min(firstLineEnd + 1, input.size())));
  const auto path =
      lfi::fuzz::writeInput("bench.toml", reinterpret_cast<const std::uint8_t*>(before.data()), before.size());

  std::string after;
  try {
    lfi::BenchFileEdit edit(path);
    edit.set(table, key, value, comment);
    after = edit.text();
    if (value.front() == '"')
      require(edit.string(table, key) == toml::parse("v = " + value)["v"].value<std::string>(),
              "string() does not read back the string set");
  } catch (const lfi::Error&) {
    return 0;
  }

  // The names on the way to the key (the editor took them: bare keys).
  std::vector<std::string> names;
  for (std::size_t start = 0;;) {
    const std::size_t dot = table.find('.', start);
    names.push_back(table.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  toml::table old = toml::parse(before), edited;
  try {
    edited = toml::parse(after);
  } catch (const toml::parse_error&) {
    require(false, "the text is no longer TOML");
  }
  toml::table* target = tableAt(edited, names, names.size());
  require(target && target->get(key) && same(*target->get(key), *toml::parse("v = " + value).get("v")),
          "the key does not hold the value set");

  // Every other key and table as it was: both without the key, and without the tables the edit added for it.
  toml::table* oldTable = tableAt(old, names, names.size());
  const toml::node* oldValue = oldTable ? oldTable->get(key) : nullptr;
  const toml::source_region touched = oldValue ? oldValue->source() : toml::source_region{};
  if (oldTable) oldTable->erase(key);
  target->erase(key);
  for (std::size_t count = names.size(); count > 0; --count) {
    const toml::table* added = tableAt(edited, names, count);
    if (added && added->empty() && !tableAt(old, names, count))
      tableAt(edited, names, count - 1)->erase(names[count - 1]);
  }
  require(same(old, edited), "another key or table changed");

  // Every line the edit did not touch, in order.
  const std::vector<std::string> was = lines(before), is = lines(after);
  std::size_t at = 0;
  for (std::size_t line = 1; line <= was.size(); ++line) {
    if (oldValue && line >= touched.begin.line && line <= touched.end.line) continue;
    while (at < is.size() && is[at] != was[line - 1]) ++at;
    require(at < is.size(), "a line the edit did not touch is lost or out of order");
    ++at;
  }
  return 0;
}
