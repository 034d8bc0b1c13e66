// SPDX-License-Identifier: Apache-2.0
// A sweep's documents and files (sweep_results.h), its report, and the merge
// of its shards (grid_sweep.h).

#include "sweep_results.h"

#include "study_internal.h"

#include "lfi/core/error.h"
#include "lfi/core/output_folder.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <map>
#include <set>

namespace lfi::study {

namespace fs = std::filesystem;
using namespace detail;

namespace {

std::string htmlEscape(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// A table: a row per point (its values), a column per setup and defect (its verdict and CNR).
std::string sweepReport(const nlohmann::ordered_json& results) {
  std::string html =
      "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>lfi sweep</title><style>"
      "body{font-family:sans-serif}table{border-collapse:collapse}td,th{border:1px solid #ccc;"
      "padding:2px 6px;text-align:right}.detected{background:#c8e6c9}.weak{background:#fff9c4}"
      ".missed{background:#ffcdd2}</style></head><body>\n";
  html += fmt::format("<h1>Sweep {}</h1>\n<p>{} points over {}; bench {}; quality {}; seed {}.</p>\n",
                      htmlEscape(results.at("provenance").at("sweep").get<std::string>()), results.at("points").size(),
                      results.at("axes").size() == 1 ? "one axis" : fmt::format("{} axes", results.at("axes").size()),
                      htmlEscape(results.at("provenance").at("bench").get<std::string>()),
                      htmlEscape(results.at("quality").get<std::string>()),
                      results.at("provenance").at("seed").get<std::uint64_t>());
  html += "<table><tr><th>point</th>";
  for (const auto& axis : results.at("axes")) html += "<th>" + htmlEscape(axis.at("key").get<std::string>()) + "</th>";
  const auto& first = results.at("points").at(0).at("setups");
  for (const auto& [setup, cells] : first.items())
    for (const auto& [defect, cnr] : cells.at("cnr").items())
      html += "<th>" + htmlEscape(setup + " " + defect) + "</th>";
  html += "</tr>\n";
  for (const auto& p : results.at("points")) {
    html += fmt::format("<tr><td>{}</td>", p.at("index").get<std::size_t>());
    for (const auto& axis : results.at("axes"))
      html += fmt::format("<td>{:g}</td>", p.at("values").at(axis.at("key").get<std::string>()).get<double>());
    for (const auto& [setup, cells] : p.at("setups").items())
      for (const auto& [defect, cnr] : cells.at("cnr").items()) {
        const std::string verdict = htmlEscape(cells.at("verdicts").at(defect).get<std::string>());
        html += fmt::format("<td class=\"{}\">{}</td>", verdict,
                            cnr.is_number() ? fmt::format("{:.1f}", cnr.get<double>()) : std::string("-"));
      }
    html += "</tr>\n";
  }
  return html +
         "</table>\n<p>Cells: the defect's CNR; green detected (CNR >= 3), yellow weak, red missed "
         "(docs/study.md).</p>\n</body></html>\n";
}

struct ShardFolder {
  fs::path folder;
  nlohmann::ordered_json record;
  SweepShard shard;
};

ShardFolder readShardFolder(const fs::path& folder) {
  const fs::path file = folder / "shard.json";
  if (!fs::is_regular_file(file))
    fail(Errc::InvalidFile, "merge: '{}' holds no shard.json: not a sweep's shard (or its task has not finished)",
         folder.string());
  ShardFolder s{folder, {}, {}};
  try {
    s.record = nlohmann::ordered_json::parse(fileBytes(file));
    if (s.record.at("format") != "lfi-sweep-shard" || s.record.at("version") != 1)
      fail(Errc::InvalidFile, "merge: '{}' is not an lfi-sweep-shard file of version 1", file.string());
    s.shard = {s.record.at("shard").at("index").get<int>(), s.record.at("shard").at("count").get<int>()};
    if (s.shard.count < 1 || s.shard.count > 100000 || s.shard.index < 1 || s.shard.index > s.shard.count)
      fail(Errc::InvalidFile, "merge: '{}' says it is shard {}/{}", file.string(), s.shard.index, s.shard.count);
    (void)s.record.at("identity").get<std::string>();
    (void)s.record.at("lfi_version").get<std::string>();
    (void)s.record.at("point_count").get<std::size_t>();
    (void)s.record.at("header").at("format");
    if (!s.record.at("points").is_array()) fail(Errc::InvalidFile, "merge: '{}': points is no array", file.string());
  } catch (const nlohmann::json::exception& e) {
    fail(Errc::InvalidFile, "merge: '{}' cannot be read: {}", file.string(), e.what());
  }
  return s;
}

}  // namespace

namespace detail {

std::string pointFolder(std::size_t index) {
  return fmt::format("point-{:06d}", index);
}

nlohmann::ordered_json sweepHeader(const SweepFile& sweep) {
  nlohmann::ordered_json h;
  h["format"] = "lfi-sweep-results";
  h["version"] = 1;
  h["units"] = "lengths mm, angles rad, as the bench file's; images in the camera's digital numbers (DN)";
  h["quality"] = sweep.quality == Quality::Quick ? "quick" : sweep.quality == Quality::High ? "high" : "default";
  h["provenance"] = {{"sweep", sweep.file.string()},
                     {"bench", sweep.bench.string()},
                     {"seed", sweep.seed},
                     {"identity", sweep.identity}};
  h["setups"] = sweep.setups;
  h["criterion"] = criterionJson();
  for (const SweepAxis& a : sweep.axes) h["axes"].push_back({{"key", a.key}, {"values", a.values}});
  return h;
}

nlohmann::ordered_json sweepResults(const nlohmann::ordered_json& header, const nlohmann::ordered_json& points) {
  nlohmann::ordered_json r = header;
  r["points"] = points;
  // Per setup and defect: the points that detect it.
  nlohmann::ordered_json answers = nlohmann::ordered_json::object();
  for (const auto& p : points)
    for (const auto& [setup, cells] : p.at("setups").items())
      for (const auto& [defect, verdict] : cells.at("verdicts").items()) {
        auto& list = answers[setup][defect];
        if (list.is_null()) list = nlohmann::ordered_json::array();
        if (verdict == "detected") list.push_back(p.at("index"));
      }
  r["answers"] = {{"detected_at", answers}};
  r["complete"] = true;
  return r;
}

void writeSweepResults(const fs::path& out, Overwrite overwrite, const nlohmann::ordered_json& results) {
  writeFileAtomically(out / "report.html", overwrite, sweepReport(results));
  writeFileAtomically(out / "study.json", overwrite,
                      results.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n");
}

nlohmann::ordered_json shardRecord(const nlohmann::ordered_json& header, const SweepShard& shard,
                                   std::size_t pointCount, const nlohmann::ordered_json& points) {
  return {{"format", "lfi-sweep-shard"},
          {"version", 1},
          {"lfi_version", lfiVersion()},
          {"identity", header["provenance"]["identity"]},
          {"shard", {{"index", shard.index}, {"count", shard.count}}},
          {"point_count", pointCount},
          {"header", header},
          {"points", points}};
}

void writeShardRecord(const fs::path& out, Overwrite overwrite, const nlohmann::ordered_json& record) {
  writeFileAtomically(out / "shard.json", overwrite,
                      record.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n");
}

}  // namespace detail

nlohmann::ordered_json mergeSweepShards(const fs::path& out, const std::vector<fs::path>& folders, bool overwrite) {
  if (folders.empty()) fail(Errc::InvalidArgument, "merge: no shard folders");
  std::vector<ShardFolder> shards;
  for (const fs::path& folder : folders) shards.push_back(readShardFolder(folder));
  const ShardFolder& first = shards.front();
  const int count = first.shard.count;
  std::map<int, const ShardFolder*> byIndex;
  for (const ShardFolder& s : shards) {
    if (s.record["lfi_version"] != lfiVersion())
      fail(Errc::InvalidFile, "merge: '{}' was written by lfi {}, this is lfi {}: run its shards again",
           s.folder.string(), s.record["lfi_version"].get<std::string>(), lfiVersion());
    if (s.record["identity"] != first.record["identity"] || s.record["header"] != first.record["header"])
      fail(Errc::InvalidFile, "merge: '{}' and '{}' are shards of different sweeps (identities {} and {})",
           first.folder.string(), s.folder.string(), first.record["identity"].get<std::string>(),
           s.record["identity"].get<std::string>());
    if (s.shard.count != count || s.record["point_count"] != first.record["point_count"])
      fail(Errc::InvalidFile, "merge: '{}' is shard {}/{}, '{}' one of {}", s.folder.string(), s.shard.index,
           s.shard.count, first.folder.string(), count);
    if (const auto [at, fresh] = byIndex.emplace(s.shard.index, &s); !fresh)
      fail(Errc::InvalidArgument, "merge: shard {}/{} is given twice: '{}' and '{}'", s.shard.index, count,
           at->second->folder.string(), s.folder.string());
  }
  std::vector<std::string> missing;
  for (int i = 1; i <= count; ++i)
    if (!byIndex.count(i)) missing.push_back(fmt::format("{}/{}", i, count));
  if (!missing.empty())
    fail(Errc::InvalidArgument, "merge: shard{} {} of the sweep {} missing", missing.size() > 1 ? "s" : "",
         fmt::join(missing, ", "), missing.size() > 1 ? "are" : "is");
  // Each shard holds exactly its points, each with its images: together every point once. Its points are
  // k = i - 1 + j N, j = 0, 1, ...: checked without making a list, whatever point_count says.
  const std::size_t pointCount = first.record["point_count"];
  for (const auto& [index, s] : byIndex) {
    const auto& held = s->record["points"];
    const std::size_t start = static_cast<std::size_t>(index - 1), step = static_cast<std::size_t>(count);
    bool own = (pointCount > start ? (pointCount - start + step - 1) / step : 0) == held.size();
    for (std::size_t j = 0; own && j < held.size(); ++j)
      own = held[j].contains("index") && held[j]["index"].is_number_unsigned() &&
            held[j]["index"].get<std::size_t>() == start + j * step &&
            fs::is_directory(s->folder / "images" / pointFolder(start + j * step));
    if (!own)
      fail(Errc::InvalidFile,
           "merge: '{}' holds other points than those of shard {}/{}, or not their images (its task did not "
           "finish?)",
           s->folder.string(), index, count);
  }
  std::size_t held = 0;
  for (const auto& [index, s] : byIndex) held += s->record["points"].size();
  if (held != pointCount)
    fail(Errc::InvalidFile, "merge: the shards hold {} points, and say the sweep has {}", held, pointCount);
  // (in order: point k is shard (k mod N) + 1's (k div N)-th)
  nlohmann::ordered_json points = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < pointCount; ++k)
    points.push_back(byIndex.at(static_cast<int>(k % static_cast<std::size_t>(count)) + 1)
                         ->record["points"][k / static_cast<std::size_t>(count)]);
  // The results and their report made before anything is written: a shard record that is JSON but not a
  // sweep's refuses the merge whole.
  nlohmann::ordered_json results;
  try {
    results = sweepResults(first.record["header"], points);
    (void)sweepReport(results);
  } catch (const nlohmann::json::exception& e) {
    fail(Errc::InvalidFile, "merge: the shards' records ('{}', ...) are not a sweep's results: {}",
         (first.folder / "shard.json").string(), e.what());
  }

  const Overwrite mode = overwrite ? Overwrite::Allow : Overwrite::Refuse;
  refuseExisting({out / "study.json", out / "report.html"}, mode, "merge");
  if (std::error_code ec; !overwrite && fs::is_directory(out / "images", ec) && !fs::is_empty(out / "images", ec))
    fail(Errc::Exists, "'{}' already holds a sweep's images; use --force to replace them", out.string());
  for (const auto& [index, s] : byIndex)
    for (const auto& p : s->record["points"]) {
      const std::string point = pointFolder(p["index"].get<std::size_t>());
      requireOutputFolder(out / "images" / point, "merge", "the points' images");
      for (const auto& file : fs::directory_iterator(s->folder / "images" / point))
        if (file.is_regular_file())
          writeFileAtomically(out / "images" / point / file.path().filename(), mode, fileBytes(file.path()));
    }
  writeSweepResults(out, mode, results);
  return results;
}

}  // namespace lfi::study
