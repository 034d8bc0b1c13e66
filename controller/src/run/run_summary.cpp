// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/run_summary.h"

#include "lfi/controller/inspection_record.h"
#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/core/log.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace lfi {

namespace {

std::string escape(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

// The defects' positions binned on a square grid around the part's origin, as SVG.
std::string heatMap(const std::vector<RecordSummary>& records) {
  std::vector<Vec2> points;
  double extent = 1;
  for (const RecordSummary& r : records)
    for (const Vec2& p : r.defects_mm) {
      points.push_back(p);
      extent = std::max({extent, std::abs(p.x), std::abs(p.y)});
    }
  constexpr int kBins = 32, kSize = 320;
  extent = std::ceil(extent);
  std::vector<int> bins(kBins * kBins, 0);
  for (const Vec2& p : points) {
    // As fractions of the extent, each within [-1, 1]: p + extent overflows near the largest double.
    const int i = std::clamp(static_cast<int>((p.x / extent + 1) / 2 * kBins), 0, kBins - 1);
    const int j = std::clamp(static_cast<int>((1 - p.y / extent) / 2 * kBins), 0, kBins - 1);
    ++bins[static_cast<size_t>(j * kBins + i)];
  }
  const int most = std::max(1, *std::max_element(bins.begin(), bins.end()));
  std::string svg = fmt::format(
      R"svg(<svg width="{0}" height="{0}" viewBox="0 0 {0} {0}"><rect width="{0}" height="{0}" fill="#eee"/>)svg",
      kSize);
  const double cell = static_cast<double>(kSize) / kBins;
  for (int j = 0; j < kBins; ++j)
    for (int i = 0; i < kBins; ++i)
      if (const int n = bins[static_cast<size_t>(j * kBins + i)])
        svg += fmt::format(
            R"svg(<rect x="{:.1f}" y="{:.1f}" width="{:.1f}" height="{:.1f}" fill="rgb(200,0,0)" fill-opacity="{:.2f}"><title>{} defects</title></rect>)svg",
            i * cell, j * cell, cell, cell, 0.15 + 0.85 * n / most, n);
  svg += fmt::format(
      R"svg(<line x1="{0}" y1="0" x2="{0}" y2="{1}" stroke="#999"/><line x1="0" y1="{0}" x2="{1}" y2="{0}" stroke="#999"/></svg>)svg",
      kSize / 2, kSize);
  return svg + fmt::format("<p>{} defects; the square spans ±{} mm around the part's origin (x right, y up).</p>",
                           points.size(), extent);
}

}  // namespace

RunCounts writeRunSummary(const fs::path& recordsFile, const fs::path& page, bool live) {
  std::ifstream in(recordsFile);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::vector<RecordSummary> records;
  bool torn = false;
  for (size_t n = 0; n < lines.size(); ++n) {
    if (lines[n].empty()) continue;
    const nlohmann::json j = nlohmann::json::parse(lines[n], nullptr, false);
    const std::string where = fmt::format("{}:{}", recordsFile.string(), n + 1);
    if (j.is_discarded()) {
      if (n + 1 < lines.size()) fail(Errc::InvalidFile, "{}: not a JSON record", where);
      torn = true;  // the last line: cut short by a crash while it was written
      continue;
    }
    records.push_back(readRecordSummary(j, where));
  }
  if (torn)
    spdlog::warn("{}: the last record is cut short (a crash while it was written); left out", recordsFile.string());
  RunCounts c;
  for (const RecordSummary& r : records) {
    ++c.parts;
    if (r.status != "inspected")
      ++c.errors;
    else if (r.verdict == "pass")
      ++c.passed;
    else
      ++c.failed;
  }
  const long judged = c.passed + c.failed;
  std::string html = "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>lfi run</title>";
  if (live) html += "<meta http-equiv=\"refresh\" content=\"3\">";
  html +=
      "<style>body{font-family:sans-serif}td,th{padding:2px "
      "8px;text-align:right}.fail{color:#c00}</style></head><body>";
  html += fmt::format("<h1>lfi run{}</h1><p>Records: {}</p>", live ? " (running)" : "", escape(recordsFile.string()));
  html += fmt::format(
      "<table><tr><th>parts</th><th>passed</th><th>failed</th><th>not inspected</th><th>yield</th></tr>"
      "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr></table>",
      c.parts, c.passed, c.failed, c.errors, judged > 0 ? fmt::format("{:.1f} %", 100.0 * c.passed / judged) : "-");
  html += "<h2>Defect positions</h2>" + heatMap(records);
  html += "<h2>Latest parts</h2><table><tr><th>part</th><th>time (UTC)</th><th>verdict</th><th>defects</th></tr>";
  const size_t first = records.size() > 50 ? records.size() - 50 : 0;
  for (size_t i = records.size(); i-- > first;) {
    const RecordSummary& r = records[i];
    const std::string verdict = r.status == "inspected" ? r.verdict : "not inspected";
    html += fmt::format("<tr><td>{}</td><td>{}</td><td class=\"{}\">{}</td><td>{}</td></tr>", r.part,
                        escape(r.time_utc), verdict == "pass" ? "" : "fail", escape(verdict), r.defects_mm.size());
  }
  html += "</table></body></html>\n";
  writeFileAtomically(page, Overwrite::Allow, html);
  return c;
}

}  // namespace lfi
