// SPDX-License-Identifier: Apache-2.0
#include "lfi/study/sweep_file.h"

#include "lfi/core/error.h"

#include "study_internal.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace lfi::study {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMostPoints = 100'000;  // (each point's bench is checked when the file is read)
const std::vector<std::string> kSweepSetups = {"inverse_schlieren", "display"};

std::uint64_t fnv1a(const std::string& bytes, std::uint64_t hash = 1469598103934665603ULL) {
  for (const unsigned char c : bytes) hash = (hash ^ c) * 1099511628211ULL;
  return hash;
}

SweepAxis readAxis(ConfigTable t, std::size_t n) {
  t.requireKnownKeys({"key", "values", "from", "to", "steps"});
  SweepAxis axis;
  axis.key = t.string("key");
  if (axis.key.empty()) fail(Errc::Config, "{} is empty", t.where("key"));
  const bool list = t.has("values"), range = t.has("from") || t.has("to") || t.has("steps");
  if (list == range)
    fail(Errc::Config, "{}: axis {} ('{}') needs either values = [...] or from, to and steps", t.file(), n + 1,
         axis.key);
  if (list) {
    axis.values = t.numbers("values", 1, kMostPoints, std::nullopt, -1e300, 1e300);
  } else {
    const double from = t.number("from"), to = t.number("to");
    const int steps = t.integer("steps", std::nullopt, 2, 1'000'000);
    for (int i = 0; i < steps; ++i) axis.values.push_back(from + (to - from) * i / (steps - 1));
  }
  std::vector<double> sorted = axis.values;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
    fail(Errc::Config, "{}: axis {} ('{}') repeats a value", t.file(), n + 1, axis.key);
  t.finish();
  return axis;
}

}  // namespace

namespace detail {

std::string fileBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(Errc::NotFound, "cannot read '{}'", file.string());
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace detail

std::size_t SweepFile::pointCount() const {
  std::size_t count = 1;
  for (const SweepAxis& a : axes) count *= a.values.size();
  return count;
}

std::vector<ConfigTable::Override> SweepFile::point(std::size_t index) const {
  if (index >= pointCount())
    fail(Errc::InvalidArgument, "{}: point {} of a sweep of {}", file.string(), index, pointCount());
  std::vector<ConfigTable::Override> values(axes.size());
  for (std::size_t a = axes.size(); a-- > 0;) {
    values[a] = {axes[a].key, axes[a].values[index % axes[a].values.size()]};
    index /= axes[a].values.size();
  }
  return values;
}

Bench sweepBench(const SweepFile& sweep, std::size_t index) {
  const std::vector<ConfigTable::Override> values = sweep.point(index);
  std::string what = fmt::format("the sweep '{}' at point {} (", sweep.file.string(), index);
  for (std::size_t a = 0; a < values.size(); ++a)
    what += fmt::format("{}{} = {}", a ? ", " : "", values[a].key, values[a].value);
  try {
    return Bench::load(sweep.bench, values);
  } catch (const Error& e) {
    throw Error(e.code(), fmt::format("{}): {}", what, e.what()));
  }
}

SweepFile readSweepFile(const fs::path& file) {
  ConfigTable root = ConfigTable::parseFile(file);
  root.requireKnownKeys({"format", "version", "bench", "quality", "seed", "setups", "axis"});
  root.string("format", std::nullopt, {"lfi-sweep"});
  root.integer("version", std::nullopt, 1, 1);
  SweepFile s;
  s.file = file;
  const fs::path bench = root.string("bench");
  s.bench = (bench.is_absolute() ? bench : root.directory() / bench).lexically_normal();
  const std::string quality = root.string("quality", "quick", {"quick", "default", "high"});
  s.quality = parseQuality(quality);
  s.seed = static_cast<std::uint64_t>(root.integer64("seed", 1, 0, std::int64_t{1} << 53));
  s.setups = root.strings("setups", kSweepSetups, kSweepSetups);
  std::vector<ConfigTable> axes = root.tables("axis");
  if (axes.empty()) fail(Errc::Config, "{}: no [[axis]]: a sweep needs at least one", file.string());
  for (std::size_t a = 0; a < axes.size(); ++a) {
    s.axes.push_back(readAxis(std::move(axes[a]), a));
    for (std::size_t b = 0; b < a; ++b)
      if (s.axes[b].key == s.axes[a].key)
        fail(Errc::Config, "{}: axes {} and {} both sweep '{}'", file.string(), b + 1, a + 1, s.axes[a].key);
  }
  double points = 1;
  for (const SweepAxis& a : s.axes) points *= static_cast<double>(a.values.size());
  if (points > static_cast<double>(kMostPoints))
    fail(Errc::Config, "{}: {:g} points; a sweep has at most {}", file.string(), points, kMostPoints);
  root.finish();

  // Every point's bench, checked now rather than hours into the sweep.
  for (std::size_t k = 0; k < s.pointCount(); ++k) sweepBench(s, k);

  std::string identity =
      fmt::format("lfi-sweep 1\nquality {}\nseed {}\nsetups {}\n", quality, s.seed, fmt::join(s.setups, " "));
  for (const SweepAxis& a : s.axes) identity += fmt::format("axis {} {:.17g}\n", a.key, fmt::join(a.values, " "));
  s.identity = fmt::format("{:016x}", fnv1a(detail::fileBytes(s.bench), fnv1a(identity)));
  return s;
}

}  // namespace lfi::study
