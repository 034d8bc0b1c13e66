// SPDX-License-Identifier: Apache-2.0
// Gray code patterns and their decoding: OpenCV's patterns as documented,
// exact decoding of the patterns themselves, a synthetic camera that sees the
// panel through a known map with blur and noise, OpenCV's own decoder on the
// same frames, thresholds at their boundaries, and the refusals.

#include "lfi/calib/coded_patterns.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>
#include <opencv2/structured_light.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace {

using namespace lfi;
using namespace lfi::calib;
using lfi::testing_support::throwsError;

double normalCdf(double z) {
  return 0.5 * std::erfc(-z / std::sqrt(2.0));
}

// z with normalCdf(z) = p, for p in (0, 1), by bisection.
double normalQuantile(double p) {
  double lo = -40, hi = 40;
  for (int i = 0; i < 200; ++i) (normalCdf(0.5 * (lo + hi)) < p ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}

unsigned gray(unsigned x) {
  return x ^ (x >> 1);
}

TEST(GrayCodePatterns, CountsFollowThePanelSize) {
  struct Case {
    int width, height, columnBits, rowBits, frames;
  };
  for (const Case& c : {Case{800, 800, 10, 10, 42}, Case{1, 1, 0, 0, 2}, Case{1000, 3, 10, 2, 26},
                        Case{1024, 768, 10, 10, 42}, Case{1025, 2, 11, 1, 26}}) {
    const CodedPatternSet set = grayCodePatterns(c.width, c.height);
    EXPECT_EQ(set.layout.columnBits, c.columnBits) << c.width << " x " << c.height;
    EXPECT_EQ(set.layout.rowBits, c.rowBits) << c.width << " x " << c.height;
    EXPECT_EQ(set.layout.frameCount(), c.frames) << c.width << " x " << c.height;
    EXPECT_EQ(static_cast<int>(set.patterns.size()) + 2, c.frames) << c.width << " x " << c.height;
  }
  // The reference bench's 3840 x 2160 panel, from the layout alone (its images take 415 MB).
  const GrayCodeLayout panel = GrayCodeLayout::forPanel(3840, 2160);
  EXPECT_EQ(panel.columnBits, 12);
  EXPECT_EQ(panel.rowBits, 12);
  EXPECT_EQ(panel.frameCount(), 50);
}

TEST(GrayCodePatterns, LayoutAgreesWithOpenCVsCountForEverySide) {
  // OpenCV counts bits as ceil(log(n) / log(2)) in floating point; the layout counts them exactly.
  for (int n = 1; n <= GrayCodeLayout::kMaxPanelSide; ++n) {
    const auto opencv = cv::structured_light::GrayCodePattern::create(n, 1);
    ASSERT_EQ(static_cast<int>(opencv->getNumberOfPatternImages()), GrayCodeLayout::forPanel(n, 1).patternCount())
        << "side " << n;
  }
}

TEST(GrayCodePatterns, ImagesAreBinaryComplementaryAndInTheDocumentedOrder) {
  for (const cv::Size panel : {cv::Size(37, 23), cv::Size(64, 5), cv::Size(3, 130), cv::Size(1, 1)}) {
    const CodedPatternSet set = grayCodePatterns(panel.width, panel.height);
    const GrayCodeLayout& layout = set.layout;
    ASSERT_EQ(static_cast<int>(set.patterns.size()), layout.patternCount());
    EXPECT_EQ(cv::countNonZero(set.white != 255), 0);
    EXPECT_EQ(cv::countNonZero(set.black != 0), 0);
    for (const cv::Mat& image : {set.white, set.black}) {
      EXPECT_EQ(image.type(), CV_8UC1);
      EXPECT_EQ(image.size(), panel);
    }
    for (int i = 0; i < layout.patternCount(); ++i) {
      const cv::Mat& p = set.patterns[static_cast<size_t>(i)];
      ASSERT_EQ(p.type(), CV_8UC1);
      ASSERT_EQ(p.size(), panel);
      EXPECT_EQ(cv::countNonZero((p != 0) & (p != 255)), 0) << "pattern " << i << " is not 0/255";
      if (i % 2 == 1) {
        cv::Mat sum;
        cv::add(set.patterns[static_cast<size_t>(i - 1)], p, sum, cv::noArray(), CV_16U);
        EXPECT_EQ(cv::countNonZero(sum != 255), 0) << "pattern " << i << " is not the inverse of " << i - 1;
      }
    }
    // Column bit k (most significant first) at 2k, row bit k at 2·columnBits + 2k: lit where the Gray code has it.
    for (int y = 0; y < panel.height; ++y)
      for (int x = 0; x < panel.width; ++x) {
        for (int k = 0; k < layout.columnBits; ++k) {
          const bool lit = (gray(static_cast<unsigned>(x)) >> (layout.columnBits - 1 - k)) & 1u;
          ASSERT_EQ(set.patterns[static_cast<size_t>(layout.columnPattern(k))].at<std::uint8_t>(y, x), lit ? 255 : 0)
              << "column bit " << k << " at (" << x << ", " << y << ")";
        }
        for (int k = 0; k < layout.rowBits; ++k) {
          const bool lit = (gray(static_cast<unsigned>(y)) >> (layout.rowBits - 1 - k)) & 1u;
          ASSERT_EQ(set.patterns[static_cast<size_t>(layout.rowPattern(k))].at<std::uint8_t>(y, x), lit ? 255 : 0)
              << "row bit " << k << " at (" << x << ", " << y << ")";
        }
      }
  }
}

TEST(DecodeGrayCode, ThePatternsThemselvesGiveEveryPanelPixelBack) {
  for (const cv::Size panel : {cv::Size(800, 800), cv::Size(1, 1), cv::Size(1000, 3), cv::Size(37, 23)}) {
    const CodedPatternSet set = grayCodePatterns(panel.width, panel.height);
    const PanelCorrespondence c = decodeGrayCode(set.patterns, set.white, set.black, set);
    ASSERT_EQ(c.panel.type(), CV_32SC2);
    ASSERT_EQ(c.confidence.type(), CV_32FC1);
    ASSERT_EQ(c.panel.size(), panel);
    EXPECT_EQ(c.lit, panel.area());
    EXPECT_EQ(c.decoded, panel.area()) << panel;
    int wrong = 0;
    for (int y = 0; y < panel.height; ++y)
      for (int x = 0; x < panel.width; ++x)
        wrong += c.panel.at<cv::Vec2i>(y, x) != cv::Vec2i(x, y) || c.confidence.at<float>(y, x) != 1.f;
    EXPECT_EQ(wrong, 0) << panel;
  }
}

// A camera that sees the panel through camera pixel (u, v) → panel point q = A (u + ½, v + ½) + t (panel pixel
// (x, y) covering [x, x + 1) × [y, y + 1)), with a Gaussian blur of σ_b panel pixels, black level `black_dn` plus
// `span_dn` for a fully lit view, and Gaussian noise of σ_n DN, rounded and clipped to the frame's type.
struct SyntheticCamera {
  cv::Size size;
  cv::Matx22d a;
  cv::Vec2d t;
  double blur_px, black_dn, span_dn, noise_dn, fullScale_dn;
  int type;

  cv::Vec2d panelPoint(int u, int v) const { return a * cv::Vec2d(u + 0.5, v + 0.5) + t; }

  // The noise-free level of one pixel seeing `image` (CV_8UC1, 0 or 255).
  double level(const cv::Mat& image, int u, int v) const {
    const cv::Vec2d q = panelPoint(u, v);
    const int x0 = static_cast<int>(std::floor(q[0])), y0 = static_cast<int>(std::floor(q[1]));
    double sum = 0;
    for (int y = std::max(y0 - 2, 0); y <= std::min(y0 + 2, image.rows - 1); ++y) {
      const double wy = normalCdf((y + 1 - q[1]) / blur_px) - normalCdf((y - q[1]) / blur_px);
      for (int x = std::max(x0 - 2, 0); x <= std::min(x0 + 2, image.cols - 1); ++x)
        if (image.at<std::uint8_t>(y, x))
          sum += wy * (normalCdf((x + 1 - q[0]) / blur_px) - normalCdf((x - q[0]) / blur_px));
    }
    return black_dn + span_dn * sum;
  }

  cv::Mat frame(const cv::Mat& image, cv::RNG& rng) const {
    cv::Mat level_dn(size, CV_64FC1), noise(size, CV_64FC1), out;
    for (int v = 0; v < size.height; ++v)
      for (int u = 0; u < size.width; ++u) level_dn.at<double>(v, u) = level(image, u, v);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, noise_dn);
    cv::min(level_dn + noise, fullScale_dn, level_dn);
    level_dn.convertTo(out, type);  // rounded, clipped at 0
    return out;
  }
};

struct CameraFrames {
  std::vector<cv::Mat> patterns;
  cv::Mat white, black;
};

CameraFrames capture(const SyntheticCamera& camera, const CodedPatternSet& set, cv::RNG& rng) {
  CameraFrames f;
  for (const cv::Mat& p : set.patterns) f.patterns.push_back(camera.frame(p, rng));
  f.white = camera.frame(set.white, rng);
  f.black = camera.frame(set.black, rng);
  return f;
}

SyntheticCamera slightlyRotatedView(cv::Size size, double scale, double angle, cv::Vec2d t, double blur_px) {
  const double c = std::cos(angle), s = std::sin(angle);
  return SyntheticCamera{.size = size,
                         .a = cv::Matx22d(scale * c, -scale * s, scale * s, scale * c),
                         .t = t,
                         .blur_px = blur_px,
                         .black_dn = 60,
                         .span_dn = 3000,
                         .noise_dn = 6,
                         .fullScale_dn = 4095,
                         .type = CV_16UC1};
}

TEST(DecodeGrayCode, ASyntheticCameraDecodesToItsMapExceptAtPanelPixelEdges) {
  // A 200 x 150 panel (8 + 8 bits) seen by a 240 x 180 Mono12 camera, 0.9 panel px per camera px, turned by
  // 0.05 rad; the view overhangs the panel on every side, so a margin of the camera sees no panel at all.
  const CodedPatternSet set = grayCodePatterns(200, 150);
  const SyntheticCamera camera = slightlyRotatedView({240, 180}, 0.9, 0.05, {-6, -12}, 0.15);
  cv::RNG rng(27);
  const CameraFrames f = capture(camera, set, rng);
  const DecodeSettings s{.minLit_dn = 200, .minContrast_dn = 60, .minContrastFraction = 0.2};
  const PanelCorrespondence c = decodeGrayCode(f.patterns, f.white, f.black, set, s);

  // Noise margin m: 6 σ of a difference of two frames. Where the view is a distance d from the nearest edge
  // between two panel pixels, the one bit that flips there (neighbouring Gray codes differ in one bit) keeps
  // the fraction 2Φ(d/σ_b) − 1 of the pixel's span r; the other bits' own edges are at least 1 − d away. So a
  // pixel decodes surely when r − m ≥ minLit and r (2Φ(d/σ_b) − 1) − m ≥ max(minContrast, f (r + m)), i.e. d ≥
  // δ(r), and fails surely when r (2Φ(d/σ_b) − 1) + m < max(minContrast, f (r − m)), d < δ_low(r). Between the
  // two the noise decides; nowhere can it decode a wrong pixel (that takes a wrong bit above minContrast = 7 σ).
  const double m = 6 * std::sqrt(2.0) * camera.noise_dn;
  auto distanceFor = [&](double fraction) {
    return fraction >= 1   ? std::numeric_limits<double>::infinity()
           : fraction <= 0 ? 0
                           : camera.blur_px * normalQuantile(0.5 * (1 + fraction));
  };
  const int w = set.layout.panelWidth, h = set.layout.panelHeight;
  int sureLit = 0, sureUnlit = 0, mustDecode = 0, mustFail = 0, interior = 0;
  int wrong = 0, missed = 0, unexpected = 0, litUnlit = 0, badConfidence = 0;
  double worstConfidence = 0;
  for (int v = 0; v < camera.size.height; ++v)
    for (int u = 0; u < camera.size.width; ++u) {
      const cv::Vec2d q = camera.panelPoint(u, v);
      const auto inside = [&](double p, int n) {
        return normalCdf((n - p) / camera.blur_px) - normalCdf(-p / camera.blur_px);
      };
      const double r = camera.span_dn * inside(q[0], w) * inside(q[1], h);
      const auto edgeDistance = [](double p, int n) {
        const double nearest = std::clamp(std::round(p), 1.0, n - 1.0);
        return n == 1 ? std::numeric_limits<double>::infinity() : std::abs(p - nearest);
      };
      const double d = std::min(edgeDistance(q[0], w), edgeDistance(q[1], h));
      const cv::Vec2i truth(std::clamp(static_cast<int>(std::floor(q[0])), 0, w - 1),
                            std::clamp(static_cast<int>(std::floor(q[1])), 0, h - 1));
      const cv::Vec2i got = c.panel.at<cv::Vec2i>(v, u);
      const float confidence = c.confidence.at<float>(v, u);
      const bool decoded = got != cv::Vec2i(-1, -1);
      wrong += decoded && got != truth;
      if (r + m < s.minLit_dn) {
        ++sureUnlit;
        litUnlit += decoded || confidence != 0;
        continue;
      }
      if (r - m < s.minLit_dn) continue;
      ++sureLit;
      const double thresholdHigh = std::max<double>(s.minContrast_dn, s.minContrastFraction * (r + m));
      const double thresholdLow = std::max<double>(s.minContrast_dn, s.minContrastFraction * (r - m));
      if (d >= distanceFor((thresholdHigh + m) / r)) {
        ++mustDecode;
        missed += !decoded;
      } else if (d < distanceFor((thresholdLow - m) / r)) {
        ++mustFail;
        unexpected += decoded;
      }
      // Well inside the panel the confidence is the flipping bit's share, 2Φ(d/σ_b) − 1, up to the noise and
      // the far edges' tails (the nearest other edge ≥ 0.5 px away: 2Φ(−0.5/σ_b) < 1e-3).
      if (decoded && q[0] > 1 && q[0] < w - 1 && q[1] > 1 && q[1] < h - 1) {
        ++interior;
        const double expected = 2 * normalCdf(d / camera.blur_px) - 1;
        const double tolerance = 2 * m / (r - m) + 1e-3;
        worstConfidence = std::max(worstConfidence, std::abs(confidence - expected));
        badConfidence += std::abs(confidence - expected) > tolerance;
      }
    }
  EXPECT_EQ(wrong, 0) << "decoded pixels whose panel pixel is not the one their view lands on";
  EXPECT_EQ(missed, 0) << "of " << mustDecode << " pixels clear of every edge, undecoded";
  EXPECT_EQ(unexpected, 0) << "of " << mustFail << " pixels on an edge (contrast below the threshold), decoded";
  EXPECT_EQ(litUnlit, 0) << "of " << sureUnlit << " pixels the panel does not reach, decoded";
  EXPECT_EQ(badConfidence, 0) << "worst confidence error " << worstConfidence << " of " << interior;
  EXPECT_GE(c.lit, sureLit);
  EXPECT_LE(c.lit, camera.size.area() - sureUnlit);
  // The case exercises every class: a margin without panel, pixels on edges, most pixels clear.
  EXPECT_GT(sureUnlit, 1000);
  EXPECT_GT(mustFail, 100);
  EXPECT_GT(mustDecode, 0.8 * sureLit);
  // The map lands uniformly within panel pixels, so the edge band d < δ(S) holds about 1 − (1 − 2δ)² of the
  // pixels; the undecoded share of the lit pixels well inside the panel stays within it.
  const double band = distanceFor(
      (std::max<double>(s.minContrast_dn, s.minContrastFraction * (camera.span_dn + m)) + m) / camera.span_dn);
  const double bandFraction = 1 - (1 - 2 * band) * (1 - 2 * band);
  EXPECT_LT(band, 0.1);
  EXPECT_LE(1.0 - static_cast<double>(c.decoded) / c.lit, bandFraction + 0.02)
      << "band " << band << " px, " << c.decoded << " of " << c.lit << " lit pixels decoded";
}

TEST(DecodeGrayCode, AgreesWithOpenCVsGetProjPixel) {
  // Mono8 (OpenCV's decoder reads 8-bit frames), a blur of a quarter panel pixel so that many views fall on
  // edges; OpenCV's white threshold is the contrast floor, with no fraction.
  const CodedPatternSet set = grayCodePatterns(40, 30);
  SyntheticCamera camera = slightlyRotatedView({64, 48}, 0.7, -0.08, {-2, 2}, 0.25);
  camera.black_dn = 10, camera.span_dn = 200, camera.noise_dn = 2, camera.fullScale_dn = 255, camera.type = CV_8UC1;
  cv::RNG rng(4);
  const CameraFrames f = capture(camera, set, rng);
  const DecodeSettings s{.minLit_dn = 40, .minContrast_dn = 12, .minContrastFraction = 0};
  const PanelCorrespondence c = decodeGrayCode(f.patterns, f.white, f.black, set, s);
  const auto opencv = cv::structured_light::GrayCodePattern::create(40, 30);
  opencv->setWhiteThreshold(static_cast<size_t>(s.minContrast_dn));
  int compared = 0, bothDecoded = 0, disagree = 0;
  for (int v = 0; v < camera.size.height; ++v)
    for (int u = 0; u < camera.size.width; ++u) {
      if (f.white.at<std::uint8_t>(v, u) - f.black.at<std::uint8_t>(v, u) < s.minLit_dn) continue;
      cv::Point theirs;
      const bool theirError = opencv->getProjPixel(f.patterns, u, v, theirs);
      const cv::Vec2i ours = c.panel.at<cv::Vec2i>(v, u);
      ++compared;
      if (theirError != (ours == cv::Vec2i(-1, -1)) || (!theirError && cv::Vec2i(theirs.x, theirs.y) != ours)) {
        ++disagree;
        ADD_FAILURE() << "camera pixel (" << u << ", " << v << "): OpenCV "
                      << (theirError ? std::string("none") : cv::format("(%d, %d)", theirs.x, theirs.y)) << ", ours "
                      << ours;
      }
      bothDecoded += !theirError && ours != cv::Vec2i(-1, -1);
    }
  EXPECT_EQ(disagree, 0);
  EXPECT_GT(bothDecoded, compared / 2);
  EXPECT_LT(bothDecoded, compared) << "no view on an edge: the comparison covers no undecoded pixel";
}

TEST(DecodeGrayCode, PixelsThePanelDoesNotReachAreUndecoded) {
  const CodedPatternSet set = grayCodePatterns(37, 23);
  std::vector<cv::Mat> frames;
  for (const cv::Mat& p : set.patterns) frames.push_back(p.clone());
  cv::Mat white = set.white.clone(), black = set.black.clone();
  const cv::Rect shadow(5, 4, 10, 7);
  for (cv::Mat* frame : {&white, &black}) (*frame)(shadow).setTo(0);
  for (cv::Mat& frame : frames) frame(shadow).setTo(0);
  const PanelCorrespondence c = decodeGrayCode(frames, white, black, set);
  EXPECT_EQ(c.lit, 37 * 23 - shadow.area());
  EXPECT_EQ(c.decoded, c.lit);
  for (int y = 0; y < 23; ++y)
    for (int x = 0; x < 37; ++x) {
      const bool inShadow = shadow.contains({x, y});
      EXPECT_EQ(c.panel.at<cv::Vec2i>(y, x), inShadow ? cv::Vec2i(-1, -1) : cv::Vec2i(x, y)) << x << ", " << y;
      EXPECT_EQ(c.confidence.at<float>(y, x), inShadow ? 0.f : 1.f) << x << ", " << y;
    }
}

// One camera pixel of a 4 x 1 panel (two column bits, no row bits) whose frames are given in DN: white − black
// = span, and column bit k's pattern − inverse = contrast[k] (pattern brighter when positive).
PanelCorrespondence decodeOnePixel(int span, std::vector<int> contrast, const DecodeSettings& s, int panelWidth = 4) {
  const GrayCodeLayout layout = GrayCodeLayout::forPanel(panelWidth, 1);
  const int base = 2000;
  std::vector<cv::Mat> frames;
  for (int k : contrast) {
    frames.emplace_back(1, 1, CV_16UC1, cv::Scalar(base + std::max(k, 0)));
    frames.emplace_back(1, 1, CV_16UC1, cv::Scalar(base + std::max(-k, 0)));
  }
  return decodeGrayCode(frames, cv::Mat(1, 1, CV_16UC1, cv::Scalar(base + span)),
                        cv::Mat(1, 1, CV_16UC1, cv::Scalar(base)), layout, s);
}

TEST(DecodeGrayCode, APixelThatSeesTwoColumnsDecodesToBothWithTheirShares) {
  // An 8-column panel (Gray codes 000 001 011 010 110 111 101 100, most significant bit first); a camera pixel's
  // bit k has pattern − inverse = (share of its light from columns with bit k set − the rest) · span.
  const DecodeSettings s{.minLit_dn = 500, .minContrast_dn = 100, .minContrastFraction = 0.2, .secondShare = 0.1};
  const auto decodes = [&](std::vector<int> contrast, int first, int second, float share, float confidence) {
    const PanelCorrespondence c = decodeOnePixel(1000, contrast, s, 8);
    ASSERT_EQ(c.decoded, 1);
    EXPECT_EQ(c.panel.at<cv::Vec2i>(0, 0), cv::Vec2i(first, 0));
    EXPECT_EQ(c.second.at<cv::Vec2i>(0, 0), cv::Vec2i(second, -1));
    EXPECT_FLOAT_EQ(c.share.at<cv::Vec2f>(0, 0)[0], share);
    EXPECT_FLOAT_EQ(c.share.at<cv::Vec2f>(0, 0)[1], 1.f) << "one row";
    EXPECT_FLOAT_EQ(c.confidence.at<float>(0, 0), confidence);
  };
  // Columns 2 (011, 70 %) and 3 (010, 30 %): the last bit splits at 0.7 − 0.3; the other bits are whole.
  decodes({-1000, 1000, 400}, 2, 3, 0.7f, 1.f);
  // Columns 0 (000, 70 %) and 2 (011, 30 %): two bits split alike; their signs name the brighter.
  decodes({-1000, -400, -400}, 0, 2, 0.7f, 1.f);
  // A 50/50 split of one bit: either code is the first, the pair is the same.
  const PanelCorrespondence even = decodeOnePixel(1000, {-1000, 1000, 0}, s, 8);
  ASSERT_EQ(even.decoded, 1);
  const cv::Vec2i a = even.panel.at<cv::Vec2i>(0, 0), b = even.second.at<cv::Vec2i>(0, 0);
  EXPECT_EQ(std::minmax(a[0], b[0]), std::minmax(2, 3));
  EXPECT_FLOAT_EQ(even.share.at<cv::Vec2f>(0, 0)[0], 0.5f);
  // Columns 0 (60 %), 2 (25 %) and 1 (001, 15 %): the split bits disagree (−0.5, −0.2), more than two sources;
  // each readable (0.2 · span), so the brightest alone, as with one source.
  // The confidence is then the weakest bit's, as with one source.
  decodes({-1000, -500, -200}, 0, -1, 1.f, 0.2f);
  // ... and one not readable: no sign to trust, undecoded.
  EXPECT_EQ(decodeOnePixel(1000, {-1000, -500, -199}, s, 8).decoded, 0);
  // Without secondShare the same pixel of two sources decodes to the brighter one alone, or not at all.
  const DecodeSettings one{.minLit_dn = 500, .minContrast_dn = 100, .minContrastFraction = 0.2};
  PanelCorrespondence c = decodeOnePixel(1000, {-1000, 1000, 400}, one, 8);
  EXPECT_EQ(c.panel.at<cv::Vec2i>(0, 0), cv::Vec2i(2, 0));
  EXPECT_TRUE(c.second.empty() && c.share.empty());
  EXPECT_EQ(decodeOnePixel(1000, {-1000, 1000, 100}, one, 8).decoded, 0);
  EXPECT_TRUE(throwsError(
      [&] {
        decodeOnePixel(1000, {0, 0, 0}, {.secondShare = 0.5}, 8);
      },
      Errc::InvalidArgument, {"secondShare"}));
}

TEST(DecodeGrayCode, ThresholdsHoldAtTheirBoundaries) {
  // Gray 11 is column 2; the weaker bit sets the confidence.
  const DecodeSettings absolute{.minLit_dn = 500, .minContrast_dn = 100, .minContrastFraction = 0};
  PanelCorrespondence c = decodeOnePixel(1000, {800, 100}, absolute);
  EXPECT_EQ(c.decoded, 1);
  EXPECT_EQ(c.panel.at<cv::Vec2i>(0, 0), cv::Vec2i(2, 0));
  EXPECT_FLOAT_EQ(c.confidence.at<float>(0, 0), 0.1f);
  c = decodeOnePixel(1000, {800, 99}, absolute);
  EXPECT_EQ(c.lit, 1);
  EXPECT_EQ(c.decoded, 0);
  EXPECT_EQ(c.panel.at<cv::Vec2i>(0, 0), cv::Vec2i(-1, -1));
  EXPECT_EQ(c.confidence.at<float>(0, 0), 0.f);
  EXPECT_EQ(decodeOnePixel(1000, {-800, -99}, absolute).decoded, 0) << "the contrast's sign does not matter";
  // A fraction of white − black above the floor: 0.25 · 1000.
  const DecodeSettings relative{.minLit_dn = 500, .minContrast_dn = 100, .minContrastFraction = 0.25};
  EXPECT_EQ(decodeOnePixel(1000, {-250, 800}, relative).panel.at<cv::Vec2i>(0, 0), cv::Vec2i(1, 0));
  EXPECT_EQ(decodeOnePixel(1000, {-249, 800}, relative).decoded, 0);
  // Lit from minLit_dn on.
  c = decodeOnePixel(500, {-400, -400}, absolute);
  EXPECT_EQ(c.lit, 1);
  EXPECT_EQ(c.panel.at<cv::Vec2i>(0, 0), cv::Vec2i(0, 0));
  c = decodeOnePixel(499, {-400, -400}, absolute);
  EXPECT_EQ(c.lit, 0);
  EXPECT_EQ(c.decoded, 0);
  // A code past the panel's last column: on a 3-column panel Gray 10 (column 3) is no panel pixel.
  EXPECT_EQ(decodeOnePixel(1000, {800, -800}, absolute, 4).panel.at<cv::Vec2i>(0, 0), cv::Vec2i(3, 0));
  c = decodeOnePixel(1000, {800, -800}, absolute, 3);
  EXPECT_EQ(c.lit, 1);
  EXPECT_EQ(c.decoded, 0);
}

TEST(DecodeGrayCode, RefusesMismatchedInputsAndSettings) {
  const CodedPatternSet set = grayCodePatterns(8, 4);  // 3 + 2 bits: 10 patterns
  const std::vector<cv::Mat>& frames = set.patterns;
  const cv::Mat &white = set.white, &black = set.black;
  auto refuses = [&](const std::function<void()>& f, const std::vector<std::string>& fragments) {
    return throwsError(f, Errc::InvalidArgument, fragments);
  };
  std::vector<cv::Mat> fewer(frames.begin(), frames.end() - 1);
  EXPECT_TRUE(refuses([&] { decodeGrayCode(fewer, white, black, set); }, {"9 pattern frames", "8 x 4", "10 patterns"}));
  std::vector<cv::Mat> withWhite = frames;
  withWhite.push_back(white);
  withWhite.push_back(black);
  EXPECT_TRUE(refuses([&] { decodeGrayCode(withWhite, white, black, set); }, {"12 pattern frames", "white and black"}));
  std::vector<cv::Mat> resized = frames;
  resized[3] = cv::Mat(5, 8, CV_8UC1, cv::Scalar(0));
  EXPECT_TRUE(refuses([&] { decodeGrayCode(resized, white, black, set); }, {"pattern frame 3", "8 x 5", "8 x 4"}));
  std::vector<cv::Mat> retyped = frames;
  frames[6].convertTo(retyped[6], CV_16U);
  EXPECT_TRUE(refuses([&] { decodeGrayCode(retyped, white, black, set); }, {"pattern frame 6", "CV_16UC1"}));
  cv::Mat black16;
  black.convertTo(black16, CV_16U);
  EXPECT_TRUE(refuses([&] { decodeGrayCode(frames, white, black16, set); }, {"black frame", "CV_16UC1"}));
  cv::Mat white32;
  white.convertTo(white32, CV_32F);
  EXPECT_TRUE(refuses([&] { decodeGrayCode(frames, white32, black, set); }, {"white frame", "CV_32FC1"}));
  EXPECT_TRUE(refuses([&] { decodeGrayCode(frames, cv::Mat(), black, set); }, {"white frame is empty"}));
  cv::Mat colour;
  cv::merge(std::vector<cv::Mat>{white, white, white}, colour);
  EXPECT_TRUE(refuses([&] { decodeGrayCode(frames, colour, black, set); }, {"CV_8UC3"}));

  auto withSettings = [&](DecodeSettings s) { decodeGrayCode(frames, white, black, set, s); };
  EXPECT_TRUE(refuses([&] { withSettings({.minLit_dn = 0}); }, {"minLit_dn = 0"}));
  EXPECT_TRUE(refuses([&] { withSettings({.minLit_dn = 65536}); }, {"minLit_dn = 65536"}));
  EXPECT_TRUE(refuses([&] { withSettings({.minContrast_dn = 0}); }, {"minContrast_dn = 0"}));
  EXPECT_TRUE(refuses([&] { withSettings({.minContrastFraction = 1.5}); }, {"minContrastFraction = 1.5"}));
  EXPECT_TRUE(refuses([&] { withSettings({.minContrastFraction = -0.1}); }, {"minContrastFraction = -0.1"}));
  EXPECT_TRUE(refuses([&] { withSettings({.minContrastFraction = std::nan("")}); }, {"minContrastFraction = nan"}));

  GrayCodeLayout wrongBits = set.layout;
  wrongBits.columnBits = 4;
  EXPECT_TRUE(refuses([&] { decodeGrayCode(frames, white, black, wrongBits); }, {"4 column", "8 x 4", "takes 3"}));
  EXPECT_TRUE(refuses([&] { grayCodePatterns(0, 4); }, {"width 0"}));
  EXPECT_TRUE(refuses([&] { grayCodePatterns(8, 65537); }, {"height 65537", "1 .. 65536"}));
  EXPECT_TRUE(refuses([&] { GrayCodeLayout::forPanel(-3, 4); }, {"width -3"}));
}

}  // namespace
