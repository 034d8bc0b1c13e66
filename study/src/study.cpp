#include "lfi/study/study.h"

#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/image.h"
#include "lfi/sim/render.h"

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
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
    // Centred on the camera-side (back) surface.
    const Vec3 c(radial, 0, sim::sphericalFaceZ(bench.lens.backRadius_mm, bench.lens.centreThickness_mm / 2,
                                                std::abs(radial)));
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

// One illumination of the part: which back light, and for the light field
// display, which light field, lookup and where the display actually sits.
struct Illumination {
  std::string setup;
  std::shared_ptr<const LightField> lightField;
  LightFieldLookup lookup = LightFieldLookup::Nearest;
  double displayError_mm = 0;  // display plane moved away from the lens (Δ error)
};

Object backlight(const Bench& bench, const Illumination& light) {
  if (light.setup == "parallel")
    return {"parallel backlight", sim::Rectangle{bench.parallel.size_mm, bench.parallel.size_mm},
            Rigid3::translation({0, 0, -bench.parallel.distance_mm}), sim::Absorber{},
            sim::ParallelEmission{1.0, bench.parallel.halfAngle_rad}};
  if (light.setup == "area")
    return {"area backlight", sim::Rectangle{bench.area.size_mm, bench.area.size_mm},
            Rigid3::translation({0, 0, -bench.area.distance_mm}), sim::Absorber{}, sim::LambertianEmission{1.0}};
  const LightFieldGeometry& g = light.lightField->geometry();
  return {"light field display", sim::Rectangle{g.extentX_mm(), g.extentY_mm()},
          Rigid3::translation({0, 0, -g.distance_mm - light.displayError_mm}), sim::Absorber{},
          sim::LightFieldEmission{light.lightField, light.lookup}};
}

// SPEC §1 step 1: the collimated beam from the camera side through the intact
// lens, recorded by the lensless light field sensor at Δ below the lens.
LightField captureLightField(const Bench& bench, const LightFieldGeometry& geometry, int samples, std::uint64_t seed,
                             int threads, const std::function<void(double)>& progress) {
  std::vector<Object> objects = partObjects(bench, SceneSpec{.name = "intact"});
  const double size = 2 * std::max(geometry.extentX_mm(), bench.lens.diameter_mm);
  Rigid3 facingDown = Rigid3::rotation({1, 0, 0}, std::numbers::pi);
  facingDown.t = {0, 0, bench.inverseSchlieren.captureDistance_mm};
  objects.push_back({"collimated capture beam", sim::Rectangle{size, size}, facingDown, sim::Absorber{},
                     sim::ParallelEmission{1.0, bench.inverseSchlieren.captureHalfAngle_rad}});
  sim::Scene scene(std::move(objects));
  sim::LightFieldSensor sensor{geometry, Rigid3::translation({0, 0, -geometry.distance_mm})};
  sim::RenderOptions ro;
  ro.samplesPerPixel = samples;
  ro.seed = seed ^ 0x4c46ull;
  ro.threads = threads;
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
        // A path that ends on the defect (an absorber) or turns on its surface
        // (total internal reflection off a bubble) touches it only at a
        // segment's end, where rounding decides: a touch within the tracer's
        // own step off a surface counts.
        constexpr double kTouch = sim::Scene::kTMin;
        for (int m = 0; m < list.size(); ++m)
          if (list[m].exit.t > -kTouch && list[m].enter.t < len + kTouch) mask.at<uchar>(j, i) = 255;
      }
    }
  return mask;
}

// Ground truth from the geometry, per scene: each defect's pixels (chief rays
// followed through the part by refraction touch it; a defect smaller than a
// pixel gets the pixel its centre projects to; dilated by one pixel for the
// depth-of-field blur), and the intact lens's pixels. It depends on the part
// and the camera only, not on the illumination, so it is traced once per camera.
struct GroundTruth {
  std::vector<std::vector<cv::Mat>> masks;  // [scene][defect]
  std::vector<cv::Mat> allDefects;          // [scene]
  cv::Mat lens;                             // the intact lens
};

GroundTruth traceGroundTruth(const Bench& bench, const std::vector<SceneSpec>& specs,
                             const sim::TelecentricCamera& camera) {
  GroundTruth truth;
  for (const SceneSpec& spec : specs) {
    const std::vector<Object> part = partObjects(bench, spec);
    if (spec.name == "intact")
      truth.lens = defectMask(sim::Scene(part), camera, *std::get<std::shared_ptr<const Solid>>(part[0].shape));
    const sim::Scene scene(part);
    cv::Mat all = cv::Mat::zeros(camera.height, camera.width, CV_8UC1);
    std::vector<cv::Mat> masks;
    for (const Defect& defect : spec.defects) {
      cv::Mat m = defectMask(scene, camera, *defect.marker);
      if (cv::countNonZero(m) == 0) {
        const sim::Bounds b = defect.marker->bounds();
        const Vec2 p = camera.project((b.lo + b.hi) * 0.5);
        const cv::Point px(static_cast<int>(p.x), static_cast<int>(p.y));
        if (px.inside(cv::Rect(0, 0, m.cols, m.rows))) m.at<uchar>(px) = 255;
      }
      cv::dilate(m, m, cv::Mat::ones(3, 3, CV_8U));
      masks.push_back(m);
      all |= m;
    }
    truth.masks.push_back(std::move(masks));
    truth.allDefects.push_back(all);
  }
  return truth;
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

// Flagged regions (3x3 mean of z above kFlagSigma of its own spread) away from the defects'
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
  // The mean over the 3x3 neighbours inside the frame (9, 6 at an edge, 4 in a
  // corner): its sigma is sigma / sqrt(n). A reflected border would count
  // pixels twice and raise the spread of edge means above the threshold's
  // assumption (many more false positives along the frame's edge).
  cv::Mat sum3, count3;
  cv::boxFilter(z, sum3, CV_32F, {3, 3}, {-1, -1}, false, cv::BORDER_CONSTANT);
  cv::boxFilter(cv::Mat::ones(z.size(), CV_32F), count3, CV_32F, {3, 3}, {-1, -1}, false, cv::BORDER_CONSTANT);
  cv::Mat standardised;
  cv::sqrt(count3, count3);
  cv::divide(sum3, count3, standardised);  // (n mean) / sqrt(n) = mean / (1 / sqrt(n)), unit variance
  const cv::Mat flagged = cv::abs(standardised) > kFlagSigma * sigma;
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

std::string htmlReport(const nlohmann::ordered_json& study);

}  // namespace

Quality parseQuality(const std::string& name) {
  if (name == "quick") return Quality::Quick;
  if (name == "default") return Quality::Default;
  if (name == "high") return Quality::High;
  fail(Errc::InvalidArgument, "unknown quality '{}' (quick, default, high)", name);
}

namespace {

// Overall progress of a study made of weighted steps.
class Progress {
public:
  Progress(const StudyOptions& options, double totalUnits) : options_(options), total_(totalUnits) {}
  std::function<void(double)> step(const std::string& label, double units) {
    const double start = done_;
    done_ += units;
    return [this, label, start, units](double f) {
      if (options_.progress) options_.progress(label, std::min(1.0, (start + f * units) / total_));
    };
  }

private:
  const StudyOptions& options_;
  double total_;
  double done_ = 0;
};

struct Evaluation {
  // scene -> {defects: {defect: {verdict, cnr, pixels}}, false_positives, secondary_regions}
  nlohmann::ordered_json scenes;
  nlohmann::ordered_json noise;
  double intactLitFraction = 0;   // lens pixels of the intact frame above a quarter of the brightest
};

// Renders every scene under one illumination, passes each through the camera,
// and judges it against the intact lens by the declared criterion. Writes the
// frames and difference images to imagesDir when it is given.
Evaluation evaluate(const Bench& bench, const Illumination& light, const std::vector<SceneSpec>& specs,
                    const GroundTruth& truth, const sim::TelecentricCamera& camera, sim::CameraSensorModel sensor,
                    sim::RenderOptions ro, std::uint64_t seed, Progress& progress, double renderUnits,
                    const fs::path* imagesDir, Overwrite overwrite) {
  auto renderScene = [&](const SceneSpec& spec, std::uint64_t mcSeed, const std::string& label) {
    std::vector<Object> objects = partObjects(bench, spec);
    objects.push_back(backlight(bench, light));
    const sim::Scene scene(std::move(objects));
    ro.seed = mcSeed;
    ro.progress = progress.step(light.setup + ": " + label, renderUnits);
    return sim::render(scene, camera, ro);
  };
  // Common random numbers: every scene of an illumination is rendered with the
  // same seed, so paths that never touch a defect are identical and the Monte
  // Carlo noise of the simulation cancels in every difference; what remains
  // is the camera's own noise, drawn independently for every frame, as on a
  // real bench. The intact reference sets the exposure; the same radiance
  // with a second noise draw is the false-positive control.
  const cv::Mat intact = renderScene(specs[0], seed, "intact");
  cv::Mat smooth;
  cv::blur(intact, smooth, {3, 3});
  double brightest = 0;
  cv::minMaxLoc(smooth, nullptr, &brightest);
  sensor.exposeFor(brightest, bench.camera.exposureFill);
  const cv::Mat intactFrame = toFloat(sensor.capture(intact, seed * 7919 + 1, ro.threads));
  const cv::Mat controlFrame = toFloat(sensor.capture(intact, seed * 7919 + 2, ro.threads));

  // Per-pixel noise expected from the sensor model for a difference of two
  // frames; differences are judged in units of it (z).
  const double dnPerUnit = sensor.electronsPerUnit * sensor.gain / sensor.fullWell_e * sensor.maxDigitalNumber();
  auto zScore = [&](const cv::Mat& frame, const cv::Mat& radiance) {
    cv::Mat z(frame.size(), CV_32FC1);
    for (int r = 0; r < z.rows; ++r)
      for (int c = 0; c < z.cols; ++c) {
        const double a = sensor.noiseDn(intact.at<float>(r, c) * dnPerUnit);
        const double b = sensor.noiseDn(radiance.at<float>(r, c) * dnPerUnit);
        z.at<float>(r, c) =
            static_cast<float>((frame.at<float>(r, c) - intactFrame.at<float>(r, c)) / std::sqrt(a * a + b * b));
      }
    return z;
  };
  Evaluation out;
  {
    const cv::Mat bright = smooth > 0.25 * brightest;
    out.intactLitFraction =
        static_cast<double>(cv::countNonZero(bright & truth.lens)) / std::max(1, cv::countNonZero(truth.lens));
  }
  if (imagesDir) {
    // How large the Monte Carlo noise of one rendering is against the camera's
    // noise, both in DN, where the intact lens is lit: from a second,
    // independent rendering of the intact lens.
    const cv::Mat independent = renderScene(specs[0], seed + 99, "intact (independent)");
    const cv::Mat lit = intact > 0.05 * brightest;
    const double mcSigma = robustSigma(cv::Mat((independent - intact) * dnPerUnit), ~lit) / std::sqrt(2.0);
    const double litMean = cv::mean(intact, lit)[0] * dnPerUnit;
    out.noise = {{"monte_carlo_dn", mcSigma},
                 {"sensor_dn", sensor.noiseDn(litMean)},
                 {"mean_lit_signal_dn", litMean},
                 {"common_random_numbers", true}};
  }

  for (const SceneSpec& spec : specs) {
    const bool isIntact = spec.name == "intact";
    const cv::Mat radiance = isIntact ? intact : renderScene(spec, seed, spec.name);
    const auto index = static_cast<std::uint64_t>(&spec - specs.data());
    const cv::Mat frame =
        isIntact ? controlFrame : toFloat(sensor.capture(radiance, seed * 7919 + 100 * (index + 1), ro.threads));
    const cv::Mat diff = zScore(frame, radiance);
    const std::vector<cv::Mat>& masks = truth.masks[index];
    const cv::Mat& allDefects = truth.allDefects[index];
    // z has unit variance where the camera's noise is all there is; a larger
    // spread raises the bar accordingly.
    const double sigma = std::max(1.0, robustSigma(diff, allDefects));
    auto& sceneOut = out.scenes[spec.name];
    sceneOut["defects"] = nlohmann::ordered_json::object();
    for (size_t k = 0; k < spec.defects.size(); ++k) {
      const double meanSq = cv::mean(diff.mul(diff), masks[k])[0];
      const double cnr = std::sqrt(std::max(0.0, meanSq - sigma * sigma)) / sigma;
      const char* verdict = cnr >= kDetectedCnr ? "detected" : cnr >= kWeakCnr ? "weak" : "missed";
      sceneOut["defects"][spec.defects[k].name] = {
          {"verdict", verdict}, {"cnr", cnr}, {"pixels", cv::countNonZero(masks[k])}};
    }
    cv::Mat changed = radiance != intact;
    cv::dilate(changed, changed, cv::Mat::ones(3, 3, CV_8U));
    const FlaggedRegions regions = flaggedRegions(diff, sigma, allDefects, changed);
    sceneOut["false_positives"] = regions.falsePositives;
    sceneOut["secondary_regions"] = regions.secondary;

    if (imagesDir) {
      const std::string stem = spec.name + "_" + light.setup;
      writeRadianceExr(*imagesDir / (stem + ".exr"), frame,
                       {camera.objectPixel_mm(),
                        fmt::format("camera frame (DN) of scene {} under {}", spec.name, light.setup),
                        kCameraDigitalNumbers},
                       overwrite);
      cv::Mat png8;
      frame.convertTo(png8, CV_8U, 255.0 / sensor.maxDigitalNumber());
      writePngAtomically(*imagesDir / (stem + ".png"), png8, overwrite);
      cv::Mat diff8;
      diff.convertTo(diff8, CV_8U, 127.0 / 8, 128);  // +-8 sigma fills the range
      writePngAtomically(*imagesDir / (stem + "_diff.png"), diff8, overwrite);
    }
  }
  return out;
}

// Paraxial focal length of the bench lens (thick-lens lensmaker equation).
double lensFocalLength(const Bench::Lens& lens) {
  const double c1 = lens.frontRadius_mm == 0 ? 0 : 1 / lens.frontRadius_mm;
  const double c2 = lens.backRadius_mm == 0 ? 0 : 1 / lens.backRadius_mm;
  const double n = lens.ior, t = lens.centreThickness_mm;
  return 1 / ((n - 1) * (c1 - c2 + (n - 1) * t * c1 * c2 / n));
}

struct SweepVariant {
  SweepPoint point;
  LightFieldGeometry geometry;
  double displayError_mm = 0;
};

// The sweep's light field variants, each captured only as large as the
// lens's footprint on the display plane needs. Every point is checked before
// the study starts: a known series, a light field that can be made, a display
// that stays below the lens.
std::vector<SweepVariant> sweepVariants(const Bench& bench, const std::vector<SweepPoint>& sweep) {
  const LightFieldGeometry reference = bench.lightFieldGeometry();
  const double delta = reference.distance_mm, shift = std::abs(bench.defects.misalignment_mm);
  const double footprint = 0.5 * bench.lens.diameter_mm * std::abs(1 - delta / lensFocalLength(bench.lens)) +
                           (delta + 2 * shift) * std::tan(bench.camera.objectNa) + shift + 2.0;
  const double lowest = bench.lensSpan(true).low;
  std::vector<SweepVariant> variants;
  for (const SweepPoint& point : sweep) {
    SweepVariant v{point, reference};
    LightFieldGeometry& g = v.geometry;
    auto refuse = [&](const std::string& why) {
      fail(Errc::InvalidArgument, "sweep point {} = {}: {}", point.series, point.value, why);
    };
    if (!std::isfinite(point.value)) refuse("not a number");
    if (point.series == "angular") {
      if (point.value < 1 || point.value > 256 || point.value != std::floor(point.value))
        refuse("the angular elements per side must be a whole number in [1, 256]");
      g.angular = static_cast<int>(point.value);
      g.pixelPitch_mm = reference.elementPitch_mm() / g.angular;
    } else if (point.series == "element") {
      if (!(point.value > 0)) refuse("the element pitch must be > 0 mm");
      g.pixelPitch_mm = point.value / g.angular;
    } else if (point.series == "delta_error") {
      v.displayError_mm = point.value;
      if (-(delta + point.value) >= lowest)
        refuse(fmt::format("the display plane at z = {} would be inside or above the lens, which reaches down to "
                           "z = {:.4g} (with the bench's misalignment_mm); choose a larger [inverse_schlieren] "
                           "distance_mm, or leave the sweep out (--no-sweep)",
                           -(delta + point.value), lowest));
    } else {
      refuse("unknown series (angular, element, delta_error)");
    }
    // (In double first: a tiny element would make a count past int, and LightFieldGeometry refuses past 2^15.)
    const double elements = std::ceil(2 * footprint / g.elementPitch_mm());
    if (!(elements <= 1 << 15))
      refuse(fmt::format("the lens's {:.4g} mm footprint needs {:g} elements a side, more than 32768",
                         2 * footprint, elements));
    g.spatialX = g.spatialY = std::max(2, static_cast<int>(elements));
    try {
      g.validate();
    } catch (const Error& e) {
      refuse(e.what());
    }
    variants.push_back(std::move(v));
  }
  return variants;
}

}  // namespace

std::vector<SweepPoint> defaultSweep() {
  std::vector<SweepPoint> points;
  for (int n : {4, 8, 16, 32}) points.push_back({"angular", static_cast<double>(n)});
  for (double e : {0.2, 0.4, 0.8, 1.6, 3.2, 6.4}) points.push_back({"element", e});
  for (double d : {-8.0, -4.0, -2.0, -1.0, 0.0, 1.0, 2.0, 4.0, 8.0}) points.push_back({"delta_error", d});
  return points;
}

// Runs one step of the study; an lfi::Error from it says which step (a setup,
// a sweep point) and keeps its code.
template <typename Step>
auto namingTheStep(const std::string& step, Step run) {
  try {
    return run();
  } catch (const Error& e) {
    throw Error(e.code(), fmt::format("study, {}: {}", step, e.what()));
  }
}

nlohmann::ordered_json runStudy(const Bench& bench, const fs::path& outDir, const StudyOptions& options) {
  const Overwrite overwrite = options.overwrite ? Overwrite::Allow : Overwrite::Refuse;
  const std::vector<SweepVariant> sweep = sweepVariants(
      bench,
      options.sweep ? *options.sweep : (options.quality == Quality::Quick ? std::vector<SweepPoint>{} : defaultSweep()));
  // Any of the study's files (an interrupted run leaves some without study.json) stops it before the work.
  if (!options.overwrite)
    for (const fs::path& file : {outDir / "study.json", outDir / "report.html", outDir / "lightfield.exr"}) {
      std::error_code ec;
      if (fs::exists(file, ec))
        fail(Errc::Exists, "'{}' already holds a study ('{}' is there); use --force to replace it", outDir.string(),
             file.filename().string());
      if (ec) fail(Errc::Io, "study: cannot look for '{}' in the output folder: {}", file.string(), ec.message());
    }
  if (std::error_code ec; !options.overwrite && fs::is_directory(outDir / "images", ec) &&
                          !fs::is_empty(outDir / "images", ec))
    fail(Errc::Exists, "'{}' already holds a study's images; use --force to replace them", outDir.string());
  if (std::error_code ec; !fs::create_directories(outDir / "images", ec) && ec)
    fail(Errc::Io, "study: cannot make the folder '{}' for its results: {}", (outDir / "images").string(),
         ec.message());
  // Both folders must take files before the work, not after it (they may have been there, read-only).
  for (const fs::path& folder : {outDir, outDir / "images"})
    if (::access(folder.c_str(), W_OK | X_OK) != 0)
      fail(Errc::Io, "study: cannot write into '{}' for its results: {}", folder.string(), std::strerror(errno));
  // Replacing an earlier study: its results go first, so that a run that fails
  // leaves no study.json of other inputs beside this run's files.
  if (options.overwrite)
    for (const fs::path& file : {outDir / "study.json", outDir / "report.html"})
      if (std::error_code ec; !fs::remove(resolvedTarget(file), ec) && ec)
        fail(Errc::Io, "cannot remove the earlier study's '{}': {}", file.string(), ec.message());

  const QualitySettings q = settingsFor(options.quality);
  auto binned = [&](int binning) {
    sim::TelecentricCamera c = bench.telecentricCamera();
    c.width = std::max(8, c.width / binning);
    c.height = std::max(8, c.height / binning);
    c.pixelPitch_mm *= binning;
    return c;
  };
  const sim::TelecentricCamera camera = binned(q.binning);
  const auto specs = sceneSpecs(bench);

  // The sweep runs the inverse schlieren setup only, at the quick camera
  // resolution, so that its many variants fit the time budget; its light
  // fields are captured at the study's own quality (noise in a captured light
  // field decides which lens regions its display lights).
  const QualitySettings sweepQuality = [&] {
    QualitySettings s = settingsFor(Quality::Quick);
    s.captureSamples = q.captureSamples;
    return s;
  }();
  const double rendersPerSetup = static_cast<double>(specs.size());
  // Progress units: one full-quality render each; the sweep's renders are
  // smaller (quick camera) and count a tenth.
  constexpr double kSweepRender = 0.1;
  Progress progress(options, 4 + kSetups.size() * (rendersPerSetup + 1) +
                                 static_cast<double>(sweep.size()) * (0.25 + 2 * rendersPerSetup * kSweepRender));

  auto lightField = std::make_shared<LightField>(captureLightField(
      bench, bench.lightFieldGeometry(), q.captureSamples, options.seed, options.threads,
      progress.step("light field capture", 4)));
  writeLightFieldExr(outDir / "lightfield.exr", *lightField, overwrite);

  nlohmann::ordered_json study;
  study["format"] = "lfi-study";
  study["version"] = 1;
  study["units"] = "lengths mm, angles rad; images and noise in the camera's digital numbers (DN)";
  study["setups"] = kSetups;
  study["quality"] = options.quality == Quality::Quick  ? "quick"
                     : options.quality == Quality::High ? "high"
                                                        : "default";
  study["provenance"] = {{"bench", bench.source}, {"seed", options.seed}};  // (results do not depend on threads)
  study["camera"] = {{"width", camera.width}, {"height", camera.height}, {"object_pixel_mm", camera.objectPixel_mm()},
                     {"acceptance_half_angle_rad", camera.acceptanceHalfAngle_rad()},
                     {"samples_per_pixel", q.samplesPerPixel}, {"bit_depth", bench.sensorModel().bitDepth}};
  study["light_field"] = {{"spatial", lightField->geometry().spatialX}, {"angular", lightField->geometry().angular},
                          {"pixel_pitch_mm", lightField->geometry().pixelPitch_mm},
                          {"distance_mm", lightField->geometry().distance_mm},
                          {"capture_samples_per_pixel", q.captureSamples}};
  study["criterion"] = {{"cnr", "sqrt(max(0, mean over the defect mask of z^2 - s^2)) / s; z = (frame - intact frame) "
                                "/ per-pixel sensor noise of that difference; s = robust std of z outside the masks, "
                                "at least 1"},
                        {"detected_at_least", kDetectedCnr},
                        {"weak_at_least", kWeakCnr},
                        {"flag_sigma", kFlagSigma},
                        {"false_positives", "flagged regions (mean of z over the n <= 9 pixels of the 3x3 "
                                            "neighbourhood inside the frame > flag_sigma s / sqrt(n)) away from "
                                            "the masks where the rendered radiance equals the intact lens's "
                                            "(common random numbers): the camera's noise alone"},
                        {"secondary_regions", "flagged regions away from the masks where light that touched the "
                                              "defect lands (e.g. after internal reflection)"}};

  sim::RenderOptions ro;
  ro.samplesPerPixel = q.samplesPerPixel;
  ro.threads = options.threads;
  const fs::path imagesDir = outDir / "images";
  const GroundTruth truth = traceGroundTruth(bench, specs, camera);
  for (size_t si = 0; si < kSetups.size(); ++si) {
    const Illumination light{kSetups[si], lightField, bench.inverseSchlieren.lookup, 0};
    const Evaluation e = namingTheStep(fmt::format("setup '{}' of '{}'", kSetups[si], bench.source), [&] {
      return evaluate(bench, light, specs, truth, camera, bench.sensorModel(), ro, options.seed * 1000 + si * 100,
                      progress, 1.0, &imagesDir, overwrite);
    });
    study["noise"][kSetups[si]] = e.noise;
    for (const auto& [scene, result] : e.scenes.items()) {
      auto& out = study["scenes"][scene];
      if (!out.contains("defects")) out["defects"] = nlohmann::ordered_json::object();
      for (const auto& [defect, cell] : result["defects"].items()) out["defects"][defect][kSetups[si]] = cell;
      out["false_positives"][kSetups[si]] = result["false_positives"];
      out["secondary_regions"][kSetups[si]] = result["secondary_regions"];
    }
  }

  // The setups' results are kept before the sweep's long run (written again with it); "complete" says which.
  auto writeResults = [&](Overwrite mode, bool complete) {
    study["complete"] = complete;
    writeFileAtomically(outDir / "report.html", mode, htmlReport(study));
    // (The bench's path need not be UTF-8: replace what is not.)
    writeFileAtomically(outDir / "study.json", mode,
                        study.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n");
  };
  writeResults(overwrite, sweep.empty());
  if (!sweep.empty()) {
    // How good must the display be? Each variant captures its own light field
    // (only as large as the lens's footprint on the display plane needs) and
    // renders the inverse schlieren setup with both lookups.
    const sim::TelecentricCamera sweepCamera = binned(sweepQuality.binning);
    // The quick quality's camera is the sweep's: its ground truth is traced already.
    const GroundTruth sweepTruth =
        sweepQuality.binning == q.binning ? truth : traceGroundTruth(bench, specs, sweepCamera);
    sim::RenderOptions sro;
    sro.samplesPerPixel = sweepQuality.samplesPerPixel;
    sro.threads = options.threads;
    const LightFieldGeometry reference = bench.lightFieldGeometry();
    auto& out = study["sweep"];
    out["setup"] = "inverse_schlieren";
    out["camera"] = {{"width", sweepCamera.width}, {"height", sweepCamera.height},
                     {"samples_per_pixel", sro.samplesPerPixel}};
    out["capture_samples_per_pixel"] = sweepQuality.captureSamples;
    out["reference"] = {{"angular", reference.angular}, {"element_mm", reference.elementPitch_mm()},
                        {"distance_mm", reference.distance_mm}};
    for (const auto& [point, g, displayError] : sweep) {
      const std::string label = fmt::format("sweep {}={}", point.series, point.value);
      auto lf = std::make_shared<LightField>(
          captureLightField(bench, g, sweepQuality.captureSamples, options.seed, options.threads,
                            progress.step(label + ": capture", 0.25)));
      nlohmann::ordered_json entry = {{"series", point.series}, {"value", point.value},
                                      {"angular", g.angular}, {"element_mm", g.elementPitch_mm()},
                                      {"spatial", g.spatialX}, {"display_error_mm", displayError}};
      const std::vector<std::pair<std::string, LightFieldLookup>> lookups = {
          {"nearest", LightFieldLookup::Nearest}, {"interpolated", LightFieldLookup::Interpolated}};
      for (const auto& [name, lookup] : lookups) {
        const Evaluation e = namingTheStep(fmt::format("{}, {} lookup", label, name), [&] {
          return evaluate(bench, Illumination{"inverse_schlieren", lf, lookup, displayError}, specs, sweepTruth,
                          sweepCamera, bench.sensorModel(), sro, options.seed * 1000 + 777, progress, kSweepRender,
                          nullptr, overwrite);
        });
        for (const auto& [scene, result] : e.scenes.items())
          for (const auto& [defect, cell] : result["defects"].items())
            entry["cnr"][name][scene + "/" + defect] = cell["cnr"];
        entry["false_positives"][name] = e.scenes["intact"]["false_positives"];
        entry["intact_lit_fraction"][name] = e.intactLitFraction;
      }
      out["points"].push_back(entry);
    }
    study["sweep"]["answers"] = sweepAnswers(study["sweep"]);
    writeResults(Overwrite::Allow, true);  // (this run's own, written above)
  }
  return study;
}

nlohmann::ordered_json sweepAnswers(const nlohmann::ordered_json& sweep) {
  // For each defect and lookup: the coarsest light field that still detects
  // it (largest element, fewest angular elements) and the largest display
  // position error up to which it stays detected (on both sides).
  nlohmann::ordered_json answers;
  for (const char* lookup : {"nearest", "interpolated"}) {
    std::map<std::string, double> coarsestElement, fewestAngular, deltaTolerance;
    std::vector<nlohmann::ordered_json> deltaPoints;
    // Per defect, series and setting: whether every point there detects it.
    std::map<std::string, std::map<double, bool>> byElement, byAngular;
    auto note = [](std::map<double, bool>& at, double value, bool detected) {
      auto [it, fresh] = at.try_emplace(value, true);
      it->second = it->second && detected;
    };
    for (const auto& p : sweep["points"]) {
      for (const auto& [defect, cnr] : p["cnr"][lookup].items()) {
        const bool detected = cnr.get<double>() >= kDetectedCnr;
        const double value = p["value"].get<double>();
        if (p["series"] == "element") note(byElement[defect], value, detected);
        if (p["series"] == "angular") note(byAngular[defect], value, detected);
      }
      if (p["series"] == "delta_error") deltaPoints.push_back(p);
    }
    // From the finest setting towards coarser ones, up to the first that misses
    // the defect: a coarse setting that detects it beyond one that does not
    // (capture noise) is no answer.
    for (const auto& [defect, at] : byElement)
      for (const auto& [element, detected] : at) {  // ascending element size
        if (!detected) break;
        coarsestElement[defect] = element;
      }
    for (const auto& [defect, at] : byAngular)
      for (auto it = at.rbegin(); it != at.rend() && it->second; ++it) fewestAngular[defect] = it->first;
    // Per defect: for each |error|, whether every point at that |error| detects.
    std::map<std::string, std::map<double, bool>> detectedAt;
    for (const auto& p : deltaPoints)
      for (const auto& [defect, cnr] : p["cnr"][lookup].items()) {
        note(detectedAt[defect], std::abs(p["value"].get<double>()), cnr.get<double>() >= kDetectedCnr);
      }
    for (const auto& [defect, levels] : detectedAt)
      for (const auto& [level, detected] : levels) {  // ascending |error|
        if (!detected) break;
        deltaTolerance[defect] = level;
      }
    for (const auto& [defect, unused] : sweep["points"][0]["cnr"][lookup].items()) {
      auto& a = answers[defect][lookup];
      a["coarsest_element_mm"] =
          coarsestElement.count(defect) ? nlohmann::ordered_json(coarsestElement[defect]) : nullptr;
      a["fewest_angular"] = fewestAngular.count(defect) ? nlohmann::ordered_json(fewestAngular[defect]) : nullptr;
      a["delta_tolerance_mm"] = deltaTolerance.count(defect) ? nlohmann::ordered_json(deltaTolerance[defect]) : nullptr;
    }
  }
  return answers;
}

std::string verdictTable(const nlohmann::ordered_json& study) {
  std::string sweepText;
  if (study.contains("sweep")) {
    auto cell = [](const nlohmann::ordered_json& v) { return v.is_null() ? std::string("never") : v.dump(); };
    sweepText = fmt::format("\ndisplay sweep (inverse schlieren)\n{:<32} {:>15} {:>10} {:>14}\n", "defect / lookup",
                            "coarsest e (mm)", "fewest n", "Δ tol. (mm)");
    for (const auto& [defect, byLookup] : study["sweep"]["answers"].items())
      for (const auto& [lookup, a] : byLookup.items())
        sweepText += fmt::format("{:<32} {:>15} {:>10} {:>14}\n", defect + " / " + lookup,
                                 cell(a["coarsest_element_mm"]), cell(a["fewest_angular"]),
                                 cell(a["delta_tolerance_mm"]));
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
  return out + sweepText;
}

namespace {

// A CNR-versus-parameter line chart as inline SVG: one colour per defect,
// solid for nearest lookup, dashed for interpolated; log CNR axis with the
// detection threshold marked.
std::string svgPlot(const nlohmann::ordered_json& sweep, const std::string& series, const std::string& xLabel,
                    bool logX) {
  std::vector<const nlohmann::ordered_json*> points;
  for (const auto& p : sweep["points"])
    if (p["series"] == series) points.push_back(&p);
  if (points.empty()) return "";
  std::sort(points.begin(), points.end(), [](auto* a, auto* b) {
    return (*a)["value"].template get<double>() < (*b)["value"].template get<double>();
  });
  const double w = 560, h = 260, left = 50, right = 140, top = 20, bottom = 40;
  const double x0 = points.front()->at("value").get<double>(), x1 = points.back()->at("value").get<double>();
  auto fx = [&](double x) {
    const double t = logX ? std::log(x / x0) / std::log(x1 / x0) : (x - x0) / (x1 - x0);
    return left + (x1 == x0 ? 0.5 : t) * (w - left - right);
  };
  auto fy = [&](double cnr) {
    const double t = (std::log10(std::clamp(cnr, 0.1, 1000.0)) + 1) / 4;  // 0.1 .. 1000
    return h - bottom - t * (h - top - bottom);
  };
  static const char* colours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                  "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  std::string svg = fmt::format("<svg width=\"{}\" height=\"{}\" style=\"border:1px solid #ccc;margin:4px\">", w, h);
  svg += fmt::format("<line x1=\"{0}\" x2=\"{1}\" y1=\"{2}\" y2=\"{2}\" stroke=\"#999\" stroke-dasharray=\"2,2\"/>"
                     "<text x=\"{3}\" y=\"{4}\" font-size=\"10\" fill=\"#666\">detected (CNR {5})</text>",
                     left, w - right, fy(kDetectedCnr), w - right - 100, fy(kDetectedCnr) - 3, kDetectedCnr);
  for (double c : {0.1, 1.0, 10.0, 100.0, 1000.0})
    svg += fmt::format("<text x=\"4\" y=\"{}\" font-size=\"10\">{}</text>", fy(c) + 3, c);
  for (const auto* p : points)
    svg += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"10\" text-anchor=\"middle\">{}</text>",
                       fx(p->at("value").get<double>()), h - bottom + 14, p->at("value").get<double>());
  svg += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\" text-anchor=\"middle\">{}</text>", (left + w) / 2,
                     h - 6, xLabel);
  int k = 0;
  for (const auto& [defect, unused] : points.front()->at("cnr").at("nearest").items()) {
    const char* colour = colours[k % 10];
    for (const char* lookup : {"nearest", "interpolated"}) {
      std::string pts;
      for (const auto* p : points)
        pts += fmt::format("{:.1f},{:.1f} ", fx(p->at("value").get<double>()),
                           fy(p->at("cnr").at(lookup).at(defect).get<double>()));
      svg += fmt::format("<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\" {} points=\"{}\"/>", colour,
                         std::string(lookup) == "nearest" ? "" : "stroke-dasharray=\"5,3\"", pts);
    }
    svg += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"10\" fill=\"{}\">{}</text>", w - right + 6,
                       top + 10 + 12 * k, colour, defect);
    ++k;
  }
  return svg + "</svg>";
}

std::string sweepHtml(const nlohmann::ordered_json& sweep) {
  std::string h = "<h2>How good must the display be?</h2><p>Inverse schlieren setup at the quick camera resolution; "
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
  h += "</table>";
  if (study.contains("sweep")) h += sweepHtml(study["sweep"]);
  h += "<h2>Noise</h2><pre>" + study["noise"].dump(2) + "</pre></body></html>\n";
  return h;
}

}  // namespace

}  // namespace lfi::study
