// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/coded_capture.h"

#include "lfi/calib/coded_patterns.h"
#include "lfi/calib/coded_reference.h"
#include "lfi/core/error.h"
#include "lfi/core/image.h"
#include "lfi/core/log.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_optics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace lfi {

namespace {

constexpr double kMostSaturated = 0.01;   // of the lit pixels at full scale under the all-white panel
constexpr double kDeflectedShare = 0.01;  // of the decoded pixels beyond two panel pixels' angle: a part
constexpr double kRegionFraction = 0.8;   // of white − black's 99th percentile: a pixel that sees the panel fully

// A frame as the decoder takes it: CV_16UC1, rounded and clamped.
cv::Mat toDecodable(const cv::Mat& frame) {
  cv::Mat out;
  frame.convertTo(out, CV_16U);
  return out;
}

// The optics' pitch in mm: a lens (pinhole) array's, or a lenticular sheet's along a row.
double opticsPitch_mm(const DisplayInfo& d) {
  return fullParallax(d.optics.type) ? d.optics.arrayPitch_mm : d.optics.lensPitch_px * d.pixelPitch_mm;
}

}  // namespace

LightFieldGeometry codedLightFieldGeometry(const DisplayInfo& display, double distance_mm) {
  display.validate();
  const double element = opticsPitch_mm(display);
  LightFieldGeometry g;
  g.angular = std::clamp(static_cast<int>(std::ceil(2 * display.optics.gap_mm / display.pixelPitch_mm)), 1, 1024);
  g.pixelPitch_mm = element / g.angular;
  g.spatialX = std::max(1, static_cast<int>(std::ceil(display.panelWidth_px * display.pixelPitch_mm / element)));
  g.spatialY = std::max(1, static_cast<int>(std::ceil(display.panelHeight_px * display.pixelPitch_mm / element)));
  g.distance_mm = distance_mm;
  return g;
}

CodedCapture::CodedCapture(CodedCaptureSettings s) : settings_(s) {
  const auto check = [](bool ok, const char* key, double value, const char* range) {
    if (!ok) fail(Errc::InvalidArgument, "coded capture: {} = {} is outside {}", key, value, range);
  };
  check(s.targetCv > 0 && s.targetCv < 1, "target_cv", s.targetCv, "(0, 1)");
  check(s.iterations >= 0 && s.iterations <= 100, "iterations", s.iterations, "0 .. 100");
  check(s.targetPercentile > 0 && s.targetPercentile < 1, "target_percentile", s.targetPercentile, "(0, 1)");
  check(s.minDecoded > 0 && s.minDecoded <= 1, "min_decoded", s.minDecoded, "(0, 1]");
  check(s.minConfidence >= 0 && s.minConfidence <= 1, "min_confidence", s.minConfidence, "[0, 1]");
  check(s.rounds >= 1 && s.rounds <= 16, "rounds", s.rounds, "1 .. 16");
  check(s.maxLightLeft >= 0 && s.maxLightLeft < 1, "max_light_left", s.maxLightLeft, "[0, 1)");
  check(s.secondShare >= 0 && s.secondShare < 0.5, "second_share", s.secondShare, "[0, 0.5)");
}

void CodedCapture::setDistance(double distance_mm) {
  if (!(distance_mm >= 0 && distance_mm <= 1e6))
    fail(Errc::InvalidArgument, "coded capture: Δ = {} mm is outside [0, 1e6]", distance_mm);
  distance_mm_ = distance_mm;
}

LightFieldGeometry CodedCapture::geometry() const {
  if (!bench_) {
    LightFieldGeometry g;
    g.distance_mm = distance_mm_;
    return g;
  }
  return codedLightFieldGeometry(bench_->display(), distance_mm_);
}

std::string CodedCapture::description() const {
  std::string text = fmt::format(
      "coded: Gray code patterns through the bench's display and camera (at most {} "
      "rounds to {} % of the light left, then at most {} refinements to cv {})",
      settings_.rounds, 100 * settings_.maxLightLeft, settings_.iterations, settings_.targetCv);
  const CodedCaptureReport& r = report_;
  if (r.patternFrames > 0)
    text += fmt::format(
        "; {} x {} panel: {} pattern frames in {} rounds and {} of the reference panel in {:.1f} s, {} of "
        "{} lit camera pixels decoded in the first round, {:.1f} % of the light left, {} panel "
        "pixels lit, cv {:.3f} → {:.3f}",
        r.panelWidth, r.panelHeight, r.patternFrames, r.rounds, r.refineFrames, r.seconds, r.decoded, r.lit,
        100 * r.lightLeft, r.panelPixelsLit, r.cvFirst, r.cvFinal);
  return text;
}

namespace {

// The light (white − black, DN) that `white` gives the lit camera pixels.
double litLight(const cv::Mat& white, const cv::Mat& black, const cv::Mat& lit) {
  cv::Mat light;
  cv::max(white - black, 0, light);
  return cv::sum(light.setTo(0, ~lit))[0];
}

// Fails unless some decoded ray is deflected: through no part, the telecentric camera sees only the rays along the
// axis.
void requireDeflection(const calib::PanelCorrespondence& c, const DisplayOptics& optics, const std::string& display) {
  const DisplayInfo& info = optics.info();
  const double pixelAngle = info.pixelPitch_mm / info.optics.gap_mm;
  const int centre = info.subpixelsPerPixel() / 2;
  int deflected = 0;
  for (int row = 0; row < c.panel.rows; ++row)
    for (int col = 0; col < c.panel.cols; ++col) {
      const cv::Vec2i p = c.panel.at<cv::Vec2i>(row, col);
      if (p[0] < 0) continue;
      const Vec3 d = optics.rayFromPixel(p[0], p[1], centre).direction;
      if (std::atan2(std::hypot(d.x, d.y), d.z) > 2 * pixelAngle) ++deflected;
    }
  if (deflected <= kDeflectedShare * c.decoded)
    fail(Errc::Device,
         "coded capture: every ray the camera sees leaves display '{}' within two panel pixels' angle "
         "({:.3g} rad) of the axis: nothing deflects them, is the part missing? (allow_undeflected=1 for a part "
         "that deflects no ray)",
         display, 2 * pixelAngle);
}

// The level `fraction` of the way up the levels of the linked camera pixels in `region`.
double linkedPercentile(const cv::Mat& image, const calib::PanelLinks& links, const cv::Mat& region, double fraction) {
  std::vector<float> levels;
  levels.reserve(static_cast<size_t>(links.linkedCameraPixels()));
  for (int row = 0; row < image.rows; ++row)
    for (int col = 0; col < image.cols; ++col)
      if (links.linked(row, col) && region.at<std::uint8_t>(row, col) != 0) levels.push_back(image.at<float>(row, col));
  if (levels.empty()) return 0;
  const auto nth = levels.begin() + static_cast<std::ptrdiff_t>(fraction * static_cast<double>(levels.size() - 1));
  std::nth_element(levels.begin(), nth, levels.end());
  return *nth;
}

// One coded capture through a bench, in its steps: white and black, rounds of
// patterns until the light is found, the reference panel refined.
class CodedRun {
 public:
  CodedRun(BenchProbe& bench, const CodedCaptureSettings& settings, CodedCaptureReport& report,
           const std::function<void(double)>& progress)
      : bench_(bench),
        settings_(settings),
        report_(report),
        progress_(progress),
        display_(bench.display()),
        optics_(display_),
        panelSize_(display_.panelWidth_px, display_.panelHeight_px),
        set_(calib::grayCodePatterns(panelSize_.width, panelSize_.height)),
        // (For the progress: every round and every refinement.)
        mostFrames_(2 + settings.rounds * (set_.layout.patternCount() + 1) + 1 + settings.iterations) {
    report_ = {};
    report_.panelWidth = panelSize_.width;
    report_.panelHeight = panelSize_.height;
  }

  // The reference panel's weights (CV_32FC1, the panel's size).
  cv::Mat measure() {
    whiteAndBlack();
    const calib::PanelLinks links = findLight();
    report_.patternFrames = taken_;
    const cv::Mat best = refine(links);
    report_.refineFrames = taken_ - report_.patternFrames;
    return best;
  }

  const DisplayInfo& display() const { return display_; }
  const DisplayOptics& optics() const { return optics_; }

 private:
  cv::Mat take(const cv::Mat& levels, const char* what) {
    if (progress_) progress_(std::min(1.0, static_cast<double>(taken_) / mostFrames_));
    try {
      cv::Mat image = bench_.take(levels);
      ++taken_;
      return image;
    } catch (const Error& e) {
      fail(e.code(), "coded capture: frame {} ({}) of display '{}': {}", taken_ + 1, what, display_.deviceId, e.what());
    }
  }

  // White and black first: the refusals that need no pattern come before the patterns' time.
  void whiteAndBlack() {
    const double fullScale = bench_.cameraFullScale_dn();
    const double dnPer8Bit = fullScale / 255;
    decode_.secondShare = settings_.secondShare;
    decode_.minLit_dn = std::max(1, static_cast<int>(std::lround(decode_.minLit_dn * dnPer8Bit)));
    decode_.minContrast_dn = std::max(1, static_cast<int>(std::lround(decode_.minContrast_dn * dnPer8Bit)));
    white_ = take(set_.white, "all white");
    black_ = take(set_.black, "all black");
    const cv::Mat range = white_ - black_;
    lit_ = range >= decode_.minLit_dn;
    const int litPixels = cv::countNonZero(lit_);
    if (litPixels == 0)
      fail(Errc::Device,
           "coded capture: the camera sees no change between the all-white and the all-black panel of "
           "display '{}' (none of its {} pixels by {} DN): the display is not in the camera's view, or it is dark "
           "or covered",
           display_.deviceId, lit_.total(), decode_.minLit_dn);
    const int saturated = cv::countNonZero(lit_ & (white_ >= fullScale - 0.5));
    if (saturated > kMostSaturated * litPixels)
      fail(Errc::Device,
           "coded capture: {} of the {} lit camera pixels are at the camera's full scale ({} DN) under "
           "the all-white panel: lower the exposure or the gain",
           saturated, litPixels, fullScale);
    // The region uniformity is measured over: the camera pixels that see the panel fully.
    region_ = lit_ & (range >= kRegionFraction * percentile(range, 0.99));
  }

  // Rounds of patterns, each with the panel pixels found so far left dark, each followed by the all-white panel
  // less what is found (the light left), until little is left.
  calib::PanelLinks findLight() {
    calib::PanelLinks links(white_.size(), panelSize_);
    const cv::Mat black = toDecodable(black_);
    cv::Mat found = cv::Mat::zeros(panelSize_, CV_8UC1);
    cv::Mat roundWhite = white_;
    const double allLight = litLight(white_, black_, lit_);  // (> 0: some pixel is lit)
    for (int round = 0; round < settings_.rounds; ++round) {
      std::vector<cv::Mat> frames;
      frames.reserve(set_.patterns.size());
      for (size_t k = 0; k < set_.patterns.size(); ++k) {
        cv::Mat levels = set_.patterns[k].clone();
        levels.setTo(0, found);
        frames.push_back(toDecodable(take(levels, k % 2 == 0 ? "pattern" : "inverse pattern")));
      }
      const calib::PanelCorrespondence c =
          calib::decodeGrayCode(frames, toDecodable(roundWhite), black, set_.layout, decode_);
      if (round == 0) firstRound(c);
      report_.rounds = round + 1;
      const int added = links.add(c, {}, settings_.minConfidence);
      if (added == 0) break;  // (nothing more to find: the light left is as last measured)
      found = panelWeights(links) > 0;
      cv::Mat levels = set_.white.clone();
      levels.setTo(0, found);
      roundWhite = take(levels, "all white but the panel pixels found");
      report_.lightLeft = litLight(roundWhite, black_, lit_) / allLight;
      spdlog::info("coded capture: round {}: {} of {} lit camera pixels decoded, {:.1f} % of the light left", round + 1,
                   added, c.lit, 100 * report_.lightLeft);
      if (report_.lightLeft <= settings_.maxLightLeft) break;
    }
    return links;
  }

  // The first round's refusals: too few pixels decoded, or nothing deflected.
  void firstRound(const calib::PanelCorrespondence& c) {
    report_.lit = c.lit;
    report_.decoded = c.decoded;
    if (c.decoded < settings_.minDecoded * c.lit)
      fail(Errc::Device,
           "coded capture: {} of the {} camera pixels that see display '{}' decoded to a panel "
           "pixel, fewer than min_decoded = {}: the patterns blur (focus, vibration, a frame rate the panel does "
           "not keep up with) or the camera's pixels each see many panel pixels",
           c.decoded, c.lit, display_.deviceId, settings_.minDecoded);
    if (!settings_.allowUndeflected) requireDeflection(c, optics_, display_.deviceId);
  }

  // The reference panel, then its closed-loop refinement: until the target, the most steps, or a step that does
  // not improve on the best (which is kept).
  cv::Mat refine(const calib::PanelLinks& links) {
    cv::Mat weights = calib::panelWeights(links);
    cv::Mat image = take(weights, "reference panel");
    calib::Uniformity u = calib::uniformity(image, links, region_);
    report_.cvFirst = u.cv;
    report_.target_dn = linkedPercentile(image, links, region_, settings_.targetPercentile);
    spdlog::info("coded capture: reference panel: mean {:.1f} DN, cv {:.4f}; target {:.1f} DN", u.mean_dn, u.cv,
                 report_.target_dn);
    cv::Mat best = weights;
    double bestCv = u.cv;
    for (int step = 0; step < settings_.iterations && bestCv > settings_.targetCv && report_.target_dn > 0; ++step) {
      weights = calib::refinePanelWeights(weights, links, image, region_, report_.target_dn);
      image = take(weights, "refined reference panel");
      u = calib::uniformity(image, links, region_);
      spdlog::info("coded capture: refinement {}: mean {:.1f} DN, cv {:.4f}", step + 1, u.mean_dn, u.cv);
      if (!(u.cv < bestCv)) break;
      best = weights;
      bestCv = u.cv;
    }
    report_.cvFinal = bestCv;
    report_.converged = bestCv <= settings_.targetCv;
    report_.panelPixelsLit = cv::countNonZero(best);
    if (!report_.converged)
      spdlog::warn(
          "coded capture: the intact part's image is uniform to cv {:.4f} after {} refinements, not "
          "the target {}",
          bestCv, taken_ - report_.patternFrames - 1, settings_.targetCv);
    return best;
  }

  BenchProbe& bench_;
  const CodedCaptureSettings& settings_;
  CodedCaptureReport& report_;
  const std::function<void(double)>& progress_;
  const DisplayInfo display_;
  const DisplayOptics optics_;
  const cv::Size panelSize_;
  const calib::CodedPatternSet set_;
  const int mostFrames_;
  int taken_ = 0;
  calib::DecodeSettings decode_;
  cv::Mat white_, black_, lit_, region_;
};

}  // namespace

LightField CodedCapture::capture(const std::function<void(double)>& progress) {
  if (!bench_)
    fail(Errc::InvalidArgument,
         "coded capture: no bench to measure through (a coded: capture runs in a bench's "
         "controller, with its display and camera)");
  const auto start = std::chrono::steady_clock::now();
  CodedRun run(*bench_, settings_, report_, progress);
  panel_ = run.measure();
  LightField lightField = decodePanelImage(panelFromLevels(panel_, run.display()), run.optics(),
                                           codedLightFieldGeometry(run.display(), distance_mm_));
  report_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (progress) progress(1);
  return lightField;
}

namespace {

// The coded: capture's query keys; their defaults are CodedCaptureSettings's.
const CodedCaptureSettings kDefaults;
const UriKey kRounds{.name = "rounds",
                     .value = UriValue::Integer,
                     .lo = 1,
                     .hi = 16,
                     .fallback = kDefaults.rounds,
                     .meaning = "most rounds of patterns"};
const UriKey kMaxLightLeft{.name = "max_light_left",
                           .lo = 0,
                           .hi = 0.999,
                           .fallback = kDefaults.maxLightLeft,
                           .meaning = "stop when at most this share of the lit pixels' light is unfound"};
const UriKey kTargetCv{.name = "target_cv",
                       .lo = 1e-6,
                       .hi = 0.999,
                       .fallback = kDefaults.targetCv,
                       .meaning = "uniformity target (standard deviation / mean)"};
const UriKey kIterations{.name = "iterations",
                         .value = UriValue::Integer,
                         .lo = 0,
                         .hi = 100,
                         .fallback = kDefaults.iterations,
                         .meaning = "most refinement steps"};
const UriKey kTargetPercentile{.name = "target_percentile",
                               .lo = 1e-6,
                               .hi = 0.999999,
                               .fallback = kDefaults.targetPercentile,
                               .meaning = "the target level's percentile"};
const UriKey kMinDecoded{.name = "min_decoded",
                         .lo = 1e-6,
                         .hi = 1,
                         .fallback = kDefaults.minDecoded,
                         .meaning = "fraction of lit camera pixels that must decode (first round)"};
const UriKey kMinConfidence{.name = "min_confidence",
                            .lo = 0,
                            .hi = 1,
                            .fallback = kDefaults.minConfidence,
                            .meaning = "a decoded pixel's panel pixels are lit from this confidence on"};
const UriKey kSecondShare{.name = "second_share",
                          .lo = 0,
                          .hi = 0.499,
                          .fallback = kDefaults.secondShare,
                          .meaning = "a camera pixel decodes to two panel columns (rows) from this share on"};
const UriKey kAllowUndeflected{.name = "allow_undeflected",
                               .value = UriValue::Integer,
                               .lo = 0,
                               .hi = 1,
                               .fallback = kDefaults.allowUndeflected ? 1 : 0,
                               .meaning = "1: accept a part that deflects no ray"};

}  // namespace

void registerControllerBackends() {
  backendRegistry<LightFieldCapture>().addOnce(LightFieldCaptureBackend{
      .scheme = "coded",
      .keys = {kRounds, kMaxLightLeft, kTargetCv, kIterations, kTargetPercentile, kMinDecoded, kMinConfidence,
               kSecondShare, kAllowUndeflected},
      .description = "coded:[?rounds=&max_light_left=&target_cv=&iterations=&target_percentile=&min_decoded=&"
                     "min_confidence=&second_share=&allow_undeflected=]  Gray code patterns through the "
                     "bench's display and camera",
      .factory = [](const DeviceUri& uri) -> std::unique_ptr<LightFieldCapture> {
        if (!uri.path.empty())
          fail(Errc::Config, "light field capture URI '{}': coded: takes no path (its devices are the bench's)",
               uri.text());
        CodedCaptureSettings s;
        s.rounds = *uriNumber<int>(uri, kRounds);
        s.maxLightLeft = *uriNumber(uri, kMaxLightLeft);
        s.targetCv = *uriNumber(uri, kTargetCv);
        s.iterations = *uriNumber<int>(uri, kIterations);
        s.targetPercentile = *uriNumber(uri, kTargetPercentile);
        s.minDecoded = *uriNumber(uri, kMinDecoded);
        s.minConfidence = *uriNumber(uri, kMinConfidence);
        s.secondShare = *uriNumber(uri, kSecondShare);
        s.allowUndeflected = *uriNumber<int>(uri, kAllowUndeflected) == 1;
        return std::make_unique<CodedCapture>(s);
      },
  });
}

}  // namespace lfi
