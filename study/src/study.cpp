#include "lfi/study/study.h"

#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/image.h"
#include "lfi/sim/render.h"

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <numbers>

namespace lfi::study {

namespace fs = std::filesystem;
using sim::Object;
using sim::Solid;

namespace {

// The declared detection criterion (docs/study.md).
constexpr double kDetectedCnr = 3.0;  // RMS excess signal per defect pixel >= 3 sigma
constexpr double kWeakCnr = 1.5;
constexpr double kFlagSigma = 5.0;    // false-positive flag: |3x3 mean of the difference| > 5 sigma_mean

const std::vector<std::string> kSetups = {"parallel", "area", "inverse_schlieren"};

struct QualitySettings {
  int binning;           // extra binning of the bench camera (fewer, larger pixels)
  int samplesPerPixel;   // camera images
  int captureSamples;    // light field capture, per sensor pixel
};

QualitySettings settingsFor(Quality q) {
  switch (q) {
    case Quality::Quick: return {4, 8, 16};
    case Quality::Default: return {2, 32, 64};
    case Quality::High: return {1, 128, 256};
  }
  return {2, 32, 64};
}

struct Defect {
  std::string name;
  std::shared_ptr<const Solid> marker;  // world frame: pixels whose chief path touches it show the defect
};

struct SceneSpec {
  std::string name;
  double iorFactor = 1;
  double lensShift_mm = 0;  // along z
  std::vector<std::pair<Vec3, double>> cuts;        // centre (lens frame), radius
  std::vector<std::pair<Vec3, double>> inclusions;  // centre (world), radius
  bool bubbles = false;
  std::vector<Defect> defects;
};

// Height of the camera-side (back) surface at radial distance r, lens frame.
double backSurfaceZ(const Bench::Lens& lens, double r) {
  const double R = lens.backRadius_mm, z0 = lens.centreThickness_mm / 2;
  if (R == 0) return z0;
  return z0 + R - (R > 0 ? 1 : -1) * std::sqrt(R * R - r * r);
}

std::vector<SceneSpec> sceneSpecs(const Bench& bench) {
  const auto& d = bench.defects;
  const auto lensSolid = Solid::sphericalLens(bench.lens.frontRadius_mm, bench.lens.backRadius_mm,
                                              bench.lens.centreThickness_mm, bench.lens.diameter_mm);
  std::vector<SceneSpec> specs;
  specs.push_back({.name = "intact"});
  for (bool bubbles : {false, true}) {
    SceneSpec s{.name = bubbles ? "scattering" : "absorbing", .bubbles = bubbles};
    const Vec3 centre(0, 0, 0), rim(d.rimRadial_mm, 0, 0);
    s.inclusions = {{centre, d.inclusionRadius_mm}, {rim, d.inclusionRadius_mm}};
    s.defects = {{"center", Solid::sphere(d.inclusionRadius_mm, Rigid3::translation(centre))},
                 {"rim", Solid::sphere(d.inclusionRadius_mm, Rigid3::translation(rim))}};
    specs.push_back(s);
  }
  for (auto [name, radius, radial] : {std::tuple{"cut_large", d.cutLargeRadius_mm, d.cutLargeRadial_mm},
                                      std::tuple{"cut_subpixel", d.cutSubpixelRadius_mm, d.cutSubpixelRadial_mm}}) {
    const Vec3 c(radial, 0, backSurfaceZ(bench.lens, std::abs(radial)));
    SceneSpec s{.name = name};
    s.cuts = {{c, radius}};
    s.defects = {{"cut", Solid::sphere(radius, Rigid3::translation(c))}};
    specs.push_back(s);
  }
  specs.push_back({.name = "index", .iorFactor = d.indexFactor, .defects = {{"lens", lensSolid}}});
  // Both positions of the lens: where it should be and where it is.
  const auto moved = Solid::combine(Solid::Kind::Union, lensSolid, lensSolid,
                                    Rigid3::translation({0, 0, -d.misalignment_mm}));
  specs.push_back({.name = "misaligned",
                   .lensShift_mm = -d.misalignment_mm,
                   .defects = {{"lens", Solid::combine(Solid::Kind::Union, lensSolid, moved)}}});
  return specs;
}

std::vector<Object> partObjects(const Bench& bench, const SceneSpec& spec) {
  std::shared_ptr<const Solid> lens = Solid::sphericalLens(bench.lens.frontRadius_mm, bench.lens.backRadius_mm,
                                                           bench.lens.centreThickness_mm, bench.lens.diameter_mm);
  for (const auto& [centre, radius] : spec.cuts)
    lens = Solid::combine(Solid::Kind::Difference, lens, Solid::sphere(radius, Rigid3::translation(centre)));
  std::vector<Object> objects;
  objects.push_back({"lens", lens, Rigid3::translation({0, 0, spec.lensShift_mm}),
                     sim::Dielectric{bench.lens.ior * spec.iorFactor, bench.lens.absorption_per_mm}, std::nullopt});
  int k = 0;
  for (const auto& [centre, radius] : spec.inclusions) {
    sim::Material m = spec.bubbles ? sim::Material(sim::Dielectric{1.0, 0}) : sim::Material(sim::Absorber{});
    objects.push_back({fmt::format("inclusion{}", k++), Solid::sphere(radius), Rigid3::translation(centre), m,
                       std::nullopt});
  }
  return objects;
}

Object backlight(const Bench& bench, const std::string& setup, const std::shared_ptr<const LightField>& lightField) {
  if (setup == "parallel")
    return {"parallel backlight", sim::Rectangle{bench.parallel.size_mm, bench.parallel.size_mm},
            Rigid3::translation({0, 0, -bench.parallel.distance_mm}), sim::Absorber{},
            sim::ParallelEmission{1.0, bench.parallel.halfAngle_rad}};
  if (setup == "area")
    return {"area backlight", sim::Rectangle{bench.area.size_mm, bench.area.size_mm},
            Rigid3::translation({0, 0, -bench.area.distance_mm}), sim::Absorber{}, sim::LambertianEmission{1.0}};
  const LightFieldGeometry& g = lightField->geometry();
  return {"light field display", sim::Rectangle{g.extentX_mm(), g.extentY_mm()},
          Rigid3::translation({0, 0, -g.distance_mm}), sim::Absorber{},
          sim::LightFieldEmission{lightField, bench.inverseSchlieren.lookup}};
}

// SPEC §1 step 1: the collimated beam from the camera side through the intact
// lens, recorded by the lensless light field sensor at Δ below the lens.
LightField captureLightField(const Bench& bench, const QualitySettings& q, const StudyOptions& options,
                             const std::function<void(double)>& progress) {
  std::vector<Object> objects = partObjects(bench, SceneSpec{.name = "intact"});
  const double size = 2 * std::max(bench.lightFieldGeometry().extentX_mm(), bench.lens.diameter_mm);
  Rigid3 facingDown = Rigid3::rotation({1, 0, 0}, std::numbers::pi);
  facingDown.t = {0, 0, bench.inverseSchlieren.captureDistance_mm};
  objects.push_back({"collimated capture beam", sim::Rectangle{size, size}, facingDown, sim::Absorber{},
                     sim::ParallelEmission{1.0, bench.inverseSchlieren.captureHalfAngle_rad}});
  sim::Scene scene(std::move(objects));
  sim::LightFieldSensor sensor{bench.lightFieldGeometry(), Rigid3::translation({0, 0, -bench.inverseSchlieren.distance_mm})};
  sim::RenderOptions ro;
  ro.samplesPerPixel = q.captureSamples;
  ro.seed = options.seed ^ 0x4c46ull;
  ro.threads = options.threads;
  ro.progress = progress;
  return LightField(sensor.geometry, sim::render(scene, sensor, ro));
}

cv::Mat defectMask(const sim::Scene& scene, const sim::TelecentricCamera& camera, const Solid& marker) {
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  sim::IntervalList list;
  for (int j = 0; j < camera.height; ++j)
    for (int i = 0; i < camera.width; ++i) {
      const auto path = sim::refractionPath(scene, camera.ray(i, j, {0.5, 0.5}, {0, 0}));
      for (size_t k = 0; k + 1 < path.size() && !mask.at<uchar>(j, i); ++k) {
        const Vec3 seg = path[k + 1] - path[k];
        const double len = seg.length();
        if (len <= 0) continue;
        marker.intervals({path[k], seg / len}, list);
        for (int m = 0; m < list.size(); ++m)
          if (list[m].exit.t > 0 && list[m].enter.t < len) mask.at<uchar>(j, i) = 255;
      }
    }
  return mask;
}

double robustSigma(const cv::Mat& values, const cv::Mat& exclude) {
  std::vector<float> v;
  for (int r = 0; r < values.rows; ++r)
    for (int c = 0; c < values.cols; ++c)
      if (exclude.empty() || !exclude.at<uchar>(r, c)) v.push_back(values.at<float>(r, c));
  if (v.size() < 16) return 0;
  auto median = [](std::vector<float> x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return static_cast<double>(x[x.size() / 2]);
  };
  const double m = median(v);
  for (float& x : v) x = static_cast<float>(std::abs(x - m));
  return 1.4826 * median(v);
}

// Flagged regions (3x3 mean of z above kFlagSigma) away from the defects'
// masks, split by cause. With common random numbers a pixel's rendered
// radiance is bit-identical to the intact lens's unless some light path of it
// touched the defect: a flagged region where nothing changed is a false
// positive (the camera's noise alone); one where the radiance changed is a
// secondary image of the defect (light that met the defect and landed
// elsewhere, e.g. after internal reflection), real but away from it.
struct FlaggedRegions {
  int falsePositives = 0;
  int secondary = 0;
};

FlaggedRegions flaggedRegions(const cv::Mat& z, double sigma, const cv::Mat& defects, const cv::Mat& changed) {
  cv::Mat mean3;
  cv::blur(z, mean3, {3, 3});
  const cv::Mat flagged = cv::abs(mean3) > kFlagSigma * sigma / 3.0;  // sigma of a 3x3 mean of white noise
  cv::Mat labels;
  const int n = cv::connectedComponents(flagged, labels, 8, CV_32S);
  std::vector<char> onDefect(static_cast<size_t>(n), 0), onChange(static_cast<size_t>(n), 0);
  for (int r = 0; r < labels.rows; ++r)
    for (int c = 0; c < labels.cols; ++c) {
      const auto l = static_cast<size_t>(labels.at<int>(r, c));
      onDefect[l] |= defects.at<uchar>(r, c) ? 1 : 0;
      onChange[l] |= changed.at<uchar>(r, c) ? 1 : 0;
    }
  FlaggedRegions out;
  for (size_t l = 1; l < static_cast<size_t>(n); ++l) {
    if (onDefect[l]) continue;
    (onChange[l] ? out.secondary : out.falsePositives) += 1;
  }
  return out;
}

cv::Mat toFloat(const cv::Mat& frame) {
  cv::Mat f;
  frame.convertTo(f, CV_32F);
  return f;
}

void writePng(const fs::path& path, const cv::Mat& image8, Overwrite overwrite) {
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", image8, bytes)) fail(Errc::Io, "cannot encode '{}'", path.string());
  writeFileAtomically(path, overwrite, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

std::string htmlReport(const nlohmann::ordered_json& study);

}  // namespace

Quality parseQuality(const std::string& name) {
  if (name == "quick") return Quality::Quick;
  if (name == "default") return Quality::Default;
  if (name == "high") return Quality::High;
  fail(Errc::InvalidArgument, "unknown quality '{}' (quick, default, high)", name);
}

nlohmann::ordered_json runStudy(const Bench& bench, const fs::path& outDir, const StudyOptions& options) {
  const Overwrite overwrite = options.overwrite ? Overwrite::Allow : Overwrite::Refuse;
  if (!options.overwrite && fs::exists(outDir / "study.json"))
    fail(Errc::Exists, "'{}' already holds a study; use --force to replace it", outDir.string());
  fs::create_directories(outDir / "images");

  const QualitySettings q = settingsFor(options.quality);
  sim::TelecentricCamera camera = bench.telecentricCamera();
  camera.width = std::max(8, camera.width / q.binning);
  camera.height = std::max(8, camera.height / q.binning);
  camera.pixelPitch_mm *= q.binning;
  sim::CameraSensorModel sensor = bench.sensorModel();
  const auto specs = sceneSpecs(bench);

  // Work units for progress: the light field capture counts as 4 renders.
  const double totalUnits = 4.0 + static_cast<double>(kSetups.size() * (specs.size() + 1));
  double unitsDone = 0;
  auto step = [&](const std::string& label) {
    return [&, label](double f) {
      if (options.progress) options.progress(label, (unitsDone + f * (label == "light field capture" ? 4 : 1)) / totalUnits);
    };
  };

  auto lightField = std::make_shared<LightField>(captureLightField(bench, q, options, step("light field capture")));
  unitsDone += 4;
  writeLightFieldExr(outDir / "lightfield.exr", *lightField, overwrite);

  nlohmann::ordered_json study;
  study["setups"] = kSetups;
  study["quality"] = options.quality == Quality::Quick ? "quick" : options.quality == Quality::High ? "high" : "default";
  study["camera"] = {{"width", camera.width}, {"height", camera.height}, {"object_pixel_mm", camera.objectPixel_mm()},
                     {"acceptance_half_angle_rad", camera.acceptanceHalfAngle_rad()},
                     {"samples_per_pixel", q.samplesPerPixel}};
  study["light_field"] = {{"spatial", lightField->geometry().spatialX}, {"angular", lightField->geometry().angular},
                          {"pixel_pitch_mm", lightField->geometry().pixelPitch_mm},
                          {"distance_mm", lightField->geometry().distance_mm},
                          {"capture_samples_per_pixel", q.captureSamples}};
  study["criterion"] = {{"cnr", "sqrt(max(0, mean over the defect mask of z^2 - s^2)) / s; z = (frame - intact frame) "
                                "/ per-pixel sensor noise of that difference; s = robust std of z outside the masks"},
                        {"detected_at_least", kDetectedCnr},
                        {"weak_at_least", kWeakCnr},
                        {"flag_sigma", kFlagSigma},
                        {"false_positives", "flagged regions (3x3 mean of z > flag_sigma s / 3) away from the masks "
                                            "where the rendered radiance equals the intact lens's (common random "
                                            "numbers): the camera's noise alone"},
                        {"secondary_regions", "flagged regions away from the masks where light that touched the "
                                              "defect lands (e.g. after internal reflection)"}};

  sim::RenderOptions ro;
  ro.samplesPerPixel = q.samplesPerPixel;
  ro.threads = options.threads;
  for (size_t si = 0; si < kSetups.size(); ++si) {
    const std::string& setup = kSetups[si];
    auto renderScene = [&](const SceneSpec& spec, std::uint64_t mcSeed, const std::string& label) {
      std::vector<Object> objects = partObjects(bench, spec);
      objects.push_back(backlight(bench, setup, lightField));
      sim::Scene scene(std::move(objects));
      ro.seed = mcSeed;
      ro.progress = step(label);
      cv::Mat radiance = sim::render(scene, camera, ro);
      unitsDone += 1;
      return radiance;
    };
    // Common random numbers: every scene of a setup is rendered with the same
    // seed, so paths that never touch a defect are identical and the Monte
    // Carlo noise of the simulation cancels in every difference; what remains
    // is the camera's own noise, drawn independently for every frame, as on a
    // real bench. The intact reference sets the exposure; the same radiance
    // with a second noise draw is the false-positive control.
    const std::uint64_t mcSeed = options.seed * 1000 + si * 100;
    const cv::Mat intact = renderScene(specs[0], mcSeed, setup + ": intact");
    cv::Mat smooth;
    cv::blur(intact, smooth, {3, 3});
    double brightest = 0;
    cv::minMaxLoc(smooth, nullptr, &brightest);
    sensor.exposeFor(brightest, bench.camera.exposureFill);
    const cv::Mat intactFrame = toFloat(sensor.capture(intact, options.seed * 7919 + si));
    const cv::Mat controlFrame = toFloat(sensor.capture(intact, options.seed * 7919 + si + 5000));

    // Per-pixel noise expected from the sensor model for a difference of two
    // frames; differences are judged in units of it (z).
    const double dnPerUnit = sensor.electronsPerUnit * sensor.gain / sensor.fullWell_e * sensor.maxDigitalNumber();
    auto zScore = [&](const cv::Mat& frame, const cv::Mat& radiance) {
      cv::Mat z(frame.size(), CV_32FC1);
      for (int r = 0; r < z.rows; ++r)
        for (int c = 0; c < z.cols; ++c) {
          const double a = sensor.noiseDn(intact.at<float>(r, c) * dnPerUnit);
          const double b = sensor.noiseDn(radiance.at<float>(r, c) * dnPerUnit);
          z.at<float>(r, c) = static_cast<float>((frame.at<float>(r, c) - intactFrame.at<float>(r, c)) /
                                                 std::sqrt(a * a + b * b));
        }
      return z;
    };
    // How large the Monte Carlo noise of one rendering is against the
    // camera's noise, both in DN, where the intact lens is lit: from a second,
    // independent rendering of the intact lens.
    const cv::Mat independent = renderScene(specs[0], mcSeed + 99, setup + ": intact (independent)");
    const cv::Mat lit = intact > 0.05 * brightest;
    const double mcSigma = robustSigma(cv::Mat((independent - intact) * dnPerUnit), ~lit) / std::sqrt(2.0);
    const double litMean = cv::mean(intact, lit)[0] * dnPerUnit;
    study["noise"][setup] = {{"monte_carlo_dn", mcSigma},
                             {"sensor_dn", sensor.noiseDn(litMean)},
                             {"mean_lit_signal_dn", litMean},
                             {"common_random_numbers", true}};

    for (const SceneSpec& spec : specs) {
      const auto index = static_cast<std::uint64_t>(&spec - specs.data());
      const cv::Mat radiance = spec.name == "intact" ? intact : renderScene(spec, mcSeed, setup + ": " + spec.name);
      const cv::Mat frame =
          spec.name == "intact" ? controlFrame : toFloat(sensor.capture(radiance, options.seed * 7919 + si + 100 * index));
      const cv::Mat diff = zScore(frame, radiance);
      // Ground-truth masks from the geometry (chief rays through this scene).
      std::vector<Object> objects = partObjects(bench, spec);
      objects.push_back(backlight(bench, setup, lightField));
      const sim::Scene scene(std::move(objects));
      cv::Mat allDefects = cv::Mat::zeros(diff.size(), CV_8UC1);
      std::vector<cv::Mat> masks;
      for (const Defect& defect : spec.defects) {
        cv::Mat m = defectMask(scene, camera, *defect.marker);
        if (cv::countNonZero(m) == 0) {
          // Smaller than a pixel: the pixel its centre projects to.
          const sim::Bounds b = defect.marker->bounds();
          const Vec2 p = camera.project((b.lo + b.hi) * 0.5);
          const cv::Point px(static_cast<int>(p.x), static_cast<int>(p.y));
          if (px.inside(cv::Rect(0, 0, m.cols, m.rows))) m.at<uchar>(px) = 255;
        }
        cv::dilate(m, m, cv::Mat::ones(3, 3, CV_8U));  // depth-of-field blur reaches one pixel further
        masks.push_back(m);
        allDefects |= m;
      }
      // z has unit variance where the camera's noise is all there is; a larger
      // spread (residual Monte Carlo noise) raises the bar accordingly.
      const double sigma = std::max(1.0, robustSigma(diff, allDefects));
      for (size_t k = 0; k < spec.defects.size(); ++k) {
        const cv::Mat sq = diff.mul(diff);
        const double meanSq = cv::mean(sq, masks[k])[0];
        const double cnr = sigma > 0 ? std::sqrt(std::max(0.0, meanSq - sigma * sigma)) / sigma : 0.0;
        const char* verdict = cnr >= kDetectedCnr ? "detected" : cnr >= kWeakCnr ? "weak" : "missed";
        study["scenes"][spec.name]["defects"][spec.defects[k].name][setup] = {
            {"verdict", verdict}, {"cnr", cnr}, {"pixels", cv::countNonZero(masks[k])}};
      }
      cv::Mat changed = radiance != intact;
      cv::dilate(changed, changed, cv::Mat::ones(3, 3, CV_8U));
      const FlaggedRegions regions = flaggedRegions(diff, sigma, allDefects, changed);
      study["scenes"][spec.name]["false_positives"][setup] = regions.falsePositives;
      study["scenes"][spec.name]["secondary_regions"][setup] = regions.secondary;
      if (spec.defects.empty()) study["scenes"][spec.name]["defects"] = nlohmann::ordered_json::object();

      const std::string stem = spec.name + "_" + setup;
      writeRadianceExr(outDir / "images" / (stem + ".exr"), frame,
                       {camera.objectPixel_mm(), fmt::format("camera frame (DN) of scene {} under {}", spec.name, setup)},
                       overwrite);
      cv::Mat png8;
      frame.convertTo(png8, CV_8U, 255.0 / sensor.maxDigitalNumber());
      writePng(outDir / "images" / (stem + ".png"), png8, overwrite);
      cv::Mat diff8;
      diff.convertTo(diff8, CV_8U, 127.0 / 8, 128);  // +-8 sigma fills the range
      writePng(outDir / "images" / (stem + "_diff.png"), diff8, overwrite);
    }
  }
  writeFileAtomically(outDir / "report.html", overwrite, htmlReport(study));
  writeFileAtomically(outDir / "study.json", overwrite, study.dump(2) + "\n");
  return study;
}

std::string verdictTable(const nlohmann::ordered_json& study) {
  std::string out = fmt::format("{:<14} {:<8}", "scene", "defect");
  for (const auto& s : study["setups"]) out += fmt::format(" {:>22}", s.get<std::string>());
  out += "\n";
  for (const auto& [scene, data] : study["scenes"].items()) {
    for (const auto& [defect, bySetup] : data["defects"].items()) {
      out += fmt::format("{:<14} {:<8}", scene, defect);
      for (const auto& s : study["setups"]) {
        const auto& r = bySetup[s.get<std::string>()];
        out += fmt::format(" {:>22}", fmt::format("{} ({:.1f})", r["verdict"].get<std::string>(), r["cnr"].get<double>()));
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
  return out;
}

namespace {

std::string htmlReport(const nlohmann::ordered_json& study) {
  std::string h = R"(<!doctype html><html><head><meta charset="utf-8"><title>lfi reference study</title>
<style>body{font-family:sans-serif;margin:1em}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:4px;text-align:center}
img{width:200px;image-rendering:pixelated}.detected{background:#cfc}.weak{background:#ffc}.missed{background:#fcc}</style></head><body>
<h1>Inverse schlieren reference study</h1>
<p>Each defect scene is compared with the intact lens under the same illumination; the criterion is in docs/study.md
and in study.json ("criterion"). Images are camera frames (12-bit DN shown linearly); the second row of each cell is the
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
  h += "</table><h2>Noise</h2><pre>" + study["noise"].dump(2) + "</pre></body></html>\n";
  return h;
}

}  // namespace

}  // namespace lfi::study
