// SPDX-License-Identifier: Apache-2.0
// The study's report: each scene's camera frame and difference image (EXR,
// PNG), study.json, report.html with its sweep charts, and the verdict table
// for the terminal.

#include "study_internal.h"

#include "lfi/core/exr_io.h"
#include "lfi/core/image.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace lfi::study {

namespace fs = std::filesystem;
using namespace detail;

namespace {

const char* const kColours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

struct ChartLine {
  std::string label;  // in the legend; empty: none (a second line of a colour)
  const char* colour;
  bool dashed;
  std::vector<double> cnr;  // one per x
};

// A CNR-versus-x line chart as inline SVG: log CNR axis (0.1 .. 1000) with the
// detection threshold marked, x linear or logarithmic, xs ascending.
std::string svgCnrChart(const std::vector<double>& xs, const std::vector<ChartLine>& lines, const std::string& xLabel,
                        bool logX, double w) {
  const double h = 260, left = 50, right = 140, top = 20, bottom = 40;
  const double x0 = xs.front(), x1 = xs.back();
  auto fx = [&](double x) {
    const double t = logX ? std::log(x / x0) / std::log(x1 / x0) : (x - x0) / (x1 - x0);
    return left + (x1 == x0 ? 0.5 : t) * (w - left - right);
  };
  auto fy = [&](double cnr) {
    const double t = (std::log10(std::clamp(cnr, 0.1, 1000.0)) + 1) / 4;  // 0.1 .. 1000
    return h - bottom - t * (h - top - bottom);
  };
  std::string svg = fmt::format("<svg width=\"{}\" height=\"{}\" style=\"border:1px solid #ccc;margin:4px\">", w, h);
  svg += fmt::format(
      "<line x1=\"{0}\" x2=\"{1}\" y1=\"{2}\" y2=\"{2}\" stroke=\"#999\" stroke-dasharray=\"2,2\"/>"
      "<text x=\"{3}\" y=\"{4}\" font-size=\"10\" fill=\"#666\">detected (CNR {5})</text>",
      left, w - right, fy(kDetectedCnr), w - right - 100, fy(kDetectedCnr) - 3, kDetectedCnr);
  for (double c : {0.1, 1.0, 10.0, 100.0, 1000.0})
    svg += fmt::format("<text x=\"4\" y=\"{}\" font-size=\"10\">{}</text>", fy(c) + 3, c);
  for (const double x : xs)
    svg += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"10\" text-anchor=\"middle\">{:g}</text>", fx(x),
                       h - bottom + 14, x);
  svg += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\" text-anchor=\"middle\">{}</text>",
                     (left + w - right) / 2, h - 6, xLabel);
  int legend = 0;
  for (const ChartLine& line : lines) {
    std::string pts;
    for (size_t i = 0; i < xs.size(); ++i) pts += fmt::format("{:.1f},{:.1f} ", fx(xs[i]), fy(line.cnr[i]));
    svg += fmt::format("<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\" {} points=\"{}\"/>", line.colour,
                       line.dashed ? "stroke-dasharray=\"5,3\"" : "", pts);
    if (!line.label.empty())
      svg += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"10\" fill=\"{}\">{}</text>", w - right + 6,
                         top + 10 + 12 * legend++, line.colour, line.label);
  }
  return svg + "</svg>";
}

// The sweep's CNR against one parameter: one colour per defect, solid for
// nearest lookup, dashed for interpolated.
std::string svgPlot(const nlohmann::ordered_json& sweep, const std::string& series, const std::string& xLabel,
                    bool logX) {
  std::vector<const nlohmann::ordered_json*> points;
  for (const auto& p : sweep["points"])
    if (p["series"] == series) points.push_back(&p);
  if (points.empty()) return "";
  std::sort(points.begin(), points.end(), [](auto* a, auto* b) {
    return (*a)["value"].template get<double>() < (*b)["value"].template get<double>();
  });
  std::vector<double> xs;
  for (const auto* p : points) xs.push_back(p->at("value").get<double>());
  std::vector<ChartLine> lines;
  for (const auto& [defect, unused] : points.front()->at("cnr").at("nearest").items())
    for (const char* lookup : {"nearest", "interpolated"}) {
      const bool nearest = std::string(lookup) == "nearest";
      ChartLine line{nearest ? defect : "", kColours[(lines.size() / 2) % 10], !nearest, {}};
      for (const auto* p : points) line.cnr.push_back(p->at("cnr").at(lookup).at(defect).get<double>());
      lines.push_back(std::move(line));
    }
  return svgCnrChart(xs, lines, xLabel, logX, 560);
}

std::string sweepHtml(const nlohmann::ordered_json& sweep) {
  std::string h =
      "<h2>How good must the display be?</h2><p>Inverse schlieren setup at the quick camera resolution; "
      "CNR per defect (log scale) against the light field's angular resolution (element size fixed at " +
      fmt::format("{} mm", sweep["reference"]["element_mm"].get<double>()) +
      "), its element size (angular resolution fixed at " +
      fmt::format("{}", sweep["reference"]["angular"].get<int>()) +
      "), and an error in the display's distance &Delta; (light field captured at &Delta;, display moved "
      "away from the lens by the error). Solid: nearest lookup (reference model); dashed: interpolated."
      "</p><div>";
  h += svgPlot(sweep, "angular", "angular elements per side", true);
  h += svgPlot(sweep, "element", "spatial element pitch (mm)", true);
  h += svgPlot(sweep, "delta_error", "display distance error (mm)", false);
  h += "</div><table><tr><th>defect</th><th>lookup</th><th>coarsest element (mm)</th><th>fewest angular elements</th>"
       "<th>&Delta; tolerance (mm)</th></tr>";
  auto cell = [](const nlohmann::ordered_json& v) { return v.is_null() ? std::string("never") : v.dump(); };
  for (const auto& [defect, byLookup] : sweep["answers"].items())
    for (const auto& [lookup, a] : byLookup.items())
      h += "<tr><td>" + defect + "</td><td>" + lookup + "</td><td>" + cell(a["coarsest_element_mm"]) + "</td><td>" +
           cell(a["fewest_angular"]) + "</td><td>" + cell(a["delta_tolerance_mm"]) + "</td></tr>";
  return h + "</table>";
}

// CNR against defect size, one line per setup (log-log).
std::string svgLimitPlot(const std::string& kind, const nlohmann::ordered_json& curves) {
  const auto sizes = curves["sizes"].get<std::vector<double>>();
  if (sizes.size() < 2) return "";
  std::vector<ChartLine> lines;
  for (const auto& [setup, curve] : curves["setups"].items())
    lines.push_back({setup, kColours[lines.size() % 10], false, curve["cnr"].get<std::vector<double>>()});
  return svgCnrChart(sizes, lines, kind + ": " + curves["unit"].get<std::string>(), true, 460);
}

std::string limitsHtml(const nlohmann::ordered_json& limits) {
  const auto& cam = limits["camera"];
  const auto& noise = limits["camera_noise"];
  std::string h = fmt::format(
      "<h2>Detection limits</h2><p>One defect at a ladder of sizes, every setup, the declared criterion; camera "
      "{} &times; {} ({:.3f} mm object pixels), {} samples per pixel, each scene rendered twice (Monte Carlo noise "
      "out of the CNR); camera noise: {:g} e<sup>-</sup> full well, {:g} e<sup>-</sup> read noise, {}-bit, exposure "
      "{:g} of the well, {} frame(s) averaged. Dashed: detected (CNR {}).</p><div>",
      cam["width"].get<int>(), cam["height"].get<int>(), cam["object_pixel_mm"].get<double>(),
      cam["samples_per_pixel"].get<int>(), noise["full_well_e"].get<double>(), noise["read_noise_e"].get<double>(),
      noise["bit_depth"].get<int>(), noise["exposure_fill"].get<double>(), noise["frames_averaged"].get<int>(),
      kDetectedCnr);
  for (const auto& [kind, curves] : limits["kinds"].items()) h += svgLimitPlot(kind, curves);
  h += "</div><table><tr><th>smallest detected</th>";
  const auto& kinds = limits["kinds"];
  if (kinds.empty()) return h + "</tr></table>";
  for (const auto& [setup, unused] : kinds.begin().value()["setups"].items()) h += "<th>" + setup + "</th>";
  h += "</tr>";
  for (const auto& [kind, curves] : kinds.items()) {
    h += "<tr><th>" + kind + ", " + curves["unit"].get<std::string>() + "</th>";
    for (const auto& [setup, curve] : curves["setups"].items())
      h += curve["limit"].is_null() ? std::string("<td class=\"missed\">none</td>")
                                    : fmt::format("<td>{:g}</td>", curve["limit"].get<double>());
    h += "</tr>";
  }
  return h + "</table>";
}

// The display classes at the bench's panel: per class, the intact lens's
// coverage and evenness and each defect's CNR.
std::string displayClassesHtml(const nlohmann::ordered_json& classes) {
  const auto& list = classes["classes"];
  if (list.empty()) return {};
  std::string h = fmt::format(
      "<h2>Display classes</h2><p>The bench's light field shown through each class of display over the bench's "
      "panel (same pitch, gap and lens positions), inverse schlieren at the sweep's camera ({} &times; {}); a "
      "class that passes a share s of the display plane gets 1/s of the samples. CNR per defect.</p><table><tr>"
      "<th>class</th><th>samples</th><th>intact: lit, CV (r &lt; 0.9 R)</th>",
      classes["camera"]["width"].get<int>(), classes["camera"]["height"].get<int>());
  for (const auto& [defect, unused] : list[0]["cnr"].items()) h += "<th>" + defect + "</th>";
  h += "</tr>";
  for (const auto& c : list) {
    h += fmt::format("<tr><th>{}</th><td>{}</td><td>{:.0f} %, {:.2f}</td>", c["class"].get<std::string>(),
                     c["samples_per_pixel"].get<int>(), 100 * c["intact_uniformity"]["lit_share"].get<double>(),
                     c["intact_uniformity"]["cv"].get<double>());
    for (const auto& [defect, cnr] : c["cnr"].items()) {
      h += fmt::format("<td class=\"{}\">{:.1f}</td>", verdictOf(cnr.get<double>()), cnr.get<double>());
    }
    h += "</tr>";
  }
  return h + "</table>";
}

// The blind detector's scores: per scene and setup, hits of the scene's
// defects, false alarms, and each found defect's position error.
std::string blindHtml(const nlohmann::ordered_json& study) {
  const auto& b = study["blind_detector"];
  const auto& s = b["settings"];
  std::string h = fmt::format(
      "<h2>Blind detector</h2><p>lfi::DefectFinder (golden-template comparison, no ground truth) against a golden "
      "model of the intact lens per illumination ({} frames), inside the lens's footprint; settings a = {} DN, "
      "b = {}, smoothing {:.2f} px, closing {} px, minimum area {} px (object pixel {:.4f} mm). Scored against the "
      "ground truth: a hit is a found region whose centroid lies in the defect's mask or within one pixel of its "
      "centre; a false alarm is a region on no defect (secondary: where the defect changed the light). Position "
      "error in object space.</p><table><tr><th>scene</th>",
      b["training_frames"].get<int>(), s["absolute_dn"].get<double>(), s["relative"].get<double>(),
      s["smoothing_px"].get<double>(), s["closing_px"].get<int>(), s["min_area_px"].get<int>(),
      b["object_pixel_mm"].get<double>());
  for (const auto& setup : study["setups"]) h += "<th>" + setup.get<std::string>() + "</th>";
  h += "</tr>";
  for (const auto& [scene, data] : study["scenes"].items()) {
    if (!data.contains("blind")) continue;
    h += "<tr><th>" + scene + "</th>";
    for (const auto& setup : study["setups"]) {
      const auto& r = data["blind"][setup.get<std::string>()];
      h += fmt::format("<td>hits {}/{}<br>", r["hits"].get<int>(), r["hits"].get<int>() + r["misses"].get<int>());
      for (const auto& [defect, d] : r["defects"].items())
        h += d["found"].get<bool>() ? fmt::format("<span class=\"detected\">{}: {:.3f} mm</span><br>", defect,
                                                  d["position_error_mm"].get<double>())
                                    : fmt::format("<span class=\"missed\">{}: missed</span><br>", defect);
      h += fmt::format("false alarms: {} ({} secondary), extra regions: {}</td>", r["false_alarms"].get<int>(),
                       r["secondary_false_alarms"].get<int>(), r["extra_regions"].get<int>());
    }
    h += "</tr>";
  }
  return h + "</table>";
}

std::string htmlReport(const nlohmann::ordered_json& study) {
  std::string h = R"(<!doctype html><html><head><meta charset="utf-8"><title>lfi reference study</title>
<style>body{font-family:sans-serif;margin:1em}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:4px;text-align:center}
img{width:200px;image-rendering:pixelated}.detected{background:#cfc}.weak{background:#ffc}.missed{background:#fcc}</style></head><body>
<h1>Inverse schlieren reference study</h1>
<p>Each defect scene is compared with the intact lens under the same illumination; the criterion is in docs/study.md
and in study.json ("criterion"). Images are camera frames ()" +
                  std::to_string(study["camera"]["bit_depth"].get<int>()) +
                  R"(-bit DN shown linearly); the second row of each cell is the
difference with the intact lens (grey = 0, &plusmn;8&sigma; full scale).</p><table><tr><th>scene</th>)";
  for (const auto& s : study["setups"]) h += "<th>" + s.get<std::string>() + "</th>";
  h += "</tr>";
  for (const auto& [scene, data] : study["scenes"].items()) {
    h += "<tr><th>" + scene + "</th>";
    for (const auto& s : study["setups"]) {
      const std::string stem = "images/" + scene + "_" + s.get<std::string>();
      h += "<td><img src=\"" + stem + ".png\"><br><img src=\"" + stem + "_diff.png\"><br>";
      for (const auto& [defect, bySetup] : data["defects"].items()) {
        const auto& r = bySetup[s.get<std::string>()];
        h += fmt::format("<span class=\"{0}\">{1}: {0} (CNR {2:.1f})</span><br>", r["verdict"].get<std::string>(),
                         defect, r["cnr"].get<double>());
      }
      h += fmt::format("false positives: {}, secondary regions: {}</td>",
                       data["false_positives"][s.get<std::string>()].get<int>(),
                       data["secondary_regions"][s.get<std::string>()].get<int>());
    }
    h += "</tr>";
  }
  if (study.contains("intact_uniformity")) {
    h += "<tr><th>intact lens, r &lt; 0.9 R</th>";
    for (const auto& s : study["setups"]) {
      const auto& u = study["intact_uniformity"][s.get<std::string>()];
      h += fmt::format("<td>lit {:.0f} %, CV {:.2f}</td>", 100 * u["lit_share"].get<double>(), u["cv"].get<double>());
    }
    h += "</tr>";
  }
  h += "</table>";
  if (study.contains("blind_detector")) h += blindHtml(study);
  if (study.contains("detection_limits")) h += limitsHtml(study["detection_limits"]);
  if (study.contains("sweep")) h += sweepHtml(study["sweep"]);
  if (study.contains("display_classes")) h += displayClassesHtml(study["display_classes"]);
  h += "<h2>Noise</h2><pre>" + study["noise"].dump(2) + "</pre></body></html>\n";
  return h;
}

}  // namespace

namespace detail {

void writeSceneImages(const fs::path& imagesDir, const SceneSpec& spec, const Illumination& light,
                      const sim::TelecentricCamera& camera, const sim::CameraSensorModel& sensor, const cv::Mat& frame,
                      const cv::Mat& diff, Overwrite overwrite) {
  const std::string stem = spec.name + "_" + light.setup;
  writeRadianceExr(
      imagesDir / (stem + ".exr"), frame,
      {camera.objectPixel_mm(), fmt::format("camera frame (DN) of scene {} under {}", spec.name, light.setup),
       kCameraDigitalNumbers},
      overwrite);
  cv::Mat png8;
  frame.convertTo(png8, CV_8U, 255.0 / sensor.maxDigitalNumber());
  writePngAtomically(imagesDir / (stem + ".png"), png8, overwrite);
  cv::Mat diff8;
  diff.convertTo(diff8, CV_8U, 127.0 / 8, 128);  // +-8 sigma fills the range
  writePngAtomically(imagesDir / (stem + "_diff.png"), diff8, overwrite);
}

void writeReport(const fs::path& outDir, Overwrite mode, const nlohmann::ordered_json& study) {
  writeFileAtomically(outDir / "report.html", mode, htmlReport(study));
  // (The bench's path need not be UTF-8: replace what is not.)
  writeFileAtomically(outDir / "study.json", mode,
                      study.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n");
}

}  // namespace detail

namespace {

// The blind detector's scores for the terminal: per defect the position error
// of its hit (or "missed"), per scene the false alarms.
std::string blindText(const nlohmann::ordered_json& study) {
  if (!study.contains("blind_detector")) return "";
  std::string out = "\nblind detector (golden model, no ground truth): position error of each hit\n";
  out += fmt::format("{:<14} {:<8}", "scene", "defect");
  for (const auto& s : study["setups"]) out += fmt::format(" {:>22}", s.get<std::string>());
  out += "\n";
  for (const auto& [scene, data] : study["scenes"].items()) {
    if (!data.contains("blind")) continue;
    const auto& bySetup = data["blind"];
    for (const auto& [defect, unused] : bySetup[study["setups"][0].get<std::string>()]["defects"].items()) {
      out += fmt::format("{:<14} {:<8}", scene, defect);
      for (const auto& s : study["setups"]) {
        const auto& d = bySetup[s.get<std::string>()]["defects"][defect];
        out += fmt::format(" {:>22}", d["found"].get<bool>()
                                          ? fmt::format("{:.3f} mm", d["position_error_mm"].get<double>())
                                          : std::string("missed"));
      }
      out += "\n";
    }
    out += fmt::format("{:<14} {:<8}", scene, "false+");
    for (const auto& s : study["setups"]) {
      const auto& r = bySetup[s.get<std::string>()];
      out += fmt::format(" {:>22}", fmt::format("{} ({} secondary)", r["false_alarms"].get<int>(),
                                                r["secondary_false_alarms"].get<int>()));
    }
    out += "\n";
  }
  return out;
}

}  // namespace

std::string verdictTable(const nlohmann::ordered_json& study) {
  std::string sweepText;
  if (study.contains("sweep")) {
    auto cell = [](const nlohmann::ordered_json& v) { return v.is_null() ? std::string("never") : v.dump(); };
    sweepText = fmt::format("\ndisplay sweep (inverse schlieren)\n{:<32} {:>15} {:>10} {:>14}\n", "defect / lookup",
                            "coarsest e (mm)", "fewest n", "Δ tol. (mm)");
    for (const auto& [defect, byLookup] : study["sweep"]["answers"].items())
      for (const auto& [lookup, a] : byLookup.items())
        sweepText +=
            fmt::format("{:<32} {:>15} {:>10} {:>14}\n", defect + " / " + lookup, cell(a["coarsest_element_mm"]),
                        cell(a["fewest_angular"]), cell(a["delta_tolerance_mm"]));
  }
  std::string out = fmt::format("{:<14} {:<8}", "scene", "defect");
  for (const auto& s : study["setups"]) out += fmt::format(" {:>22}", s.get<std::string>());
  out += "\n";
  for (const auto& [scene, data] : study["scenes"].items()) {
    for (const auto& [defect, bySetup] : data["defects"].items()) {
      out += fmt::format("{:<14} {:<8}", scene, defect);
      for (const auto& s : study["setups"]) {
        const auto& r = bySetup[s.get<std::string>()];
        out +=
            fmt::format(" {:>22}", fmt::format("{} ({:.1f})", r["verdict"].get<std::string>(), r["cnr"].get<double>()));
      }
      out += "\n";
    }
    out += fmt::format("{:<14} {:<8}", scene, "false+");
    for (const auto& s : study["setups"]) {
      const std::string setup = s.get<std::string>();
      out += fmt::format(" {:>22}", fmt::format("{} (+{} secondary)", data["false_positives"][setup].get<int>(),
                                                data["secondary_regions"][setup].get<int>()));
    }
    out += "\n";
  }
  std::string limitsText;
  if (study.contains("detection_limits")) {
    limitsText = fmt::format("\nsmallest defect detected\n{:<32}", "defect");
    for (const auto& s : study["setups"]) limitsText += fmt::format(" {:>18}", s.get<std::string>());
    limitsText += "\n";
    for (const auto& [kind, curves] : study["detection_limits"]["kinds"].items()) {
      limitsText += fmt::format("{:<32}", kind + ", " + curves["unit"].get<std::string>());
      for (const auto& [setup, curve] : curves["setups"].items())
        limitsText +=
            fmt::format(" {:>18}", curve["limit"].is_null() ? std::string("none")
                                                            : fmt::format("{:g}", curve["limit"].get<double>()));
      limitsText += "\n";
    }
  }
  return out + blindText(study) + limitsText + sweepText;
}

}  // namespace lfi::study
