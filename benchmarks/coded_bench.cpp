// SPDX-License-Identifier: Apache-2.0
// lfi-coded-bench: decoding a full Gray code pattern set (calib::decodeGrayCode)
// for a 5-megapixel camera, Mono8 and Mono12, next to a bound measured in the
// same turns.
//
//   once     the pattern set of the reference bench's 3840 x 2160 panel
//            (OpenCV's GrayCodePattern: 12 + 12 bits, 48 patterns, white and
//            black: 50 frames), and the camera's frames of it
//   timed    decodeGrayCode over the 48 pattern frames, white and black, on
//            OpenCV's thread pool; again with two sources per axis
//            (secondShare 0.1, as the coded: capture decodes)
//   bound    one read of every byte of the same 50 frames: a sum over them in
//            row bands on the same thread pool (what the least decoder must
//            read, and reads once)
//   figures  median and 99th percentile (nearest rank) of each over the turns;
//            ratio: the median of the turns' ratios timed / bound, with their
//            1st-99th percentile (each turn runs the three back to back, in an
//            order that rotates from turn to turn)
//   check    every timed answer: each camera pixel that sees the panel decodes
//            to exactly the panel pixel it sees, every other one is undecoded,
//            and the counts agree. Any miss exits 1: a fast wrong answer does
//            not pass.
//
// Camera: 2448 x 2048 (a Sony IMX264's full frame), Mono8 (CV_8UC1) and Mono12
// (CV_16UC1, 12-bit values). It sees the panel through the part, a disc of
// radius 0.46 of the frame's height: inside it camera pixel (u, v) sees panel
// pixel ⌊A (u + ½, v + ½) + t⌋, 1.1 panel pixels a camera pixel, turned by
// 0.4°, centre on centre, at 75 % of full scale at the disc's centre and 15 %
// less at its rim when lit; everything else sees 4 % of full scale in every
// frame (no panel). Noise: the camera's shot noise (full well 10 500 e- at full
// scale) and read noise (2.5 DN at 12 bits), normal, rounded to DN. Settings:
// minLit 16 DN (Mono8) or 256 DN (Mono12), minContrast 4 or 64 DN, fraction 0.2.
// The frames (250 MB of Mono8, 500 MB of Mono12) are far more than a
// last-level cache holds, as frames from a camera.
//
// Usage: lfi-coded-bench [--repeats N] [--quick] [--threads N]
//   --repeats  turns per format (default 30; each turn: decode, bound)
//   --quick    a 960 x 540 panel (42 frames), 612 x 512 frames, 5 turns (a smoke run of the self-checks)
//   --threads  OpenCV's threads (default: OpenCV's own, the hardware's)

#include "lfi/calib/coded_patterns.h"

#include "bench_util.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <vector>

using namespace lfi;
using namespace lfi::calib;

namespace {

using lfi::bench::percentile;
using lfi::bench::secondsOf;

struct Format {
  const char* name;
  int type;
  double fullScale_dn;
};

// What each camera pixel sees: the offset y·W + x of its panel pixel (-1: none), and its lit level in DN.
struct View {
  cv::Mat panelOffset;  // CV_32SC1
  cv::Mat lit;          // CV_32FC1
  int seeing = 0;       // camera pixels that see the panel
};

View makeView(cv::Size camera, const GrayCodeLayout& panel, const Format& format) {
  View view;
  view.panelOffset.create(camera, CV_32SC1);
  view.lit.create(camera, CV_32FC1);
  const double scale = 1.1, angle = 0.4 * CV_PI / 180, c = scale * std::cos(angle), s = scale * std::sin(angle);
  const cv::Point2d cameraCentre(0.5 * camera.width, 0.5 * camera.height),
      panelCentre(0.5 * panel.panelWidth, 0.5 * panel.panelHeight);
  const double radius = 0.46 * camera.height;
  for (int v = 0; v < camera.height; ++v)
    for (int u = 0; u < camera.width; ++u) {
      const double du = u + 0.5 - cameraCentre.x, dv = v + 0.5 - cameraCentre.y, rho = std::hypot(du, dv) / radius;
      const int x = static_cast<int>(std::floor(panelCentre.x + c * du - s * dv));
      const int y = static_cast<int>(std::floor(panelCentre.y + s * du + c * dv));
      const bool sees = rho <= 1 && x >= 0 && x < panel.panelWidth && y >= 0 && y < panel.panelHeight;
      view.panelOffset.at<int>(v, u) = sees ? y * panel.panelWidth + x : -1;
      view.lit.at<float>(v, u) = static_cast<float>(format.fullScale_dn * 0.75 * (1 - 0.15 * rho * rho));
      view.seeing += sees;
    }
  return view;
}

// The camera's frame of one panel image, noised and rounded to DN.
cv::Mat capture(const cv::Mat& panelImage, const View& view, const Format& format, cv::RNG& rng) {
  const double fs = format.fullScale_dn, dark = 0.04 * fs, read = 2.5 * fs / 4095, gain = fs / 10500;
  cv::Mat level(view.lit.size(), CV_32FC1), noise(view.lit.size(), CV_32FC1), out;
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
  cv::parallel_for_(cv::Range(0, level.rows), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const int* offset = view.panelOffset.ptr<int>(v);
      const float* lit = view.lit.ptr<float>(v);
      const float* n = noise.ptr<float>(v);
      float* l = level.ptr<float>(v);
      for (int u = 0; u < level.cols; ++u) {
        const double mean = offset[u] >= 0 && panelImage.data[offset[u]] ? lit[u] : dark;
        l[u] = static_cast<float>(std::min(fs, mean + n[u] * std::sqrt(read * read + gain * mean)));
      }
    }
  });
  level.convertTo(out, format.type);  // rounded, clipped at 0
  return out;
}

// Exactly the panel pixels the camera sees, and nothing elsewhere.
void check(const PanelCorrespondence& c, const View& view, const GrayCodeLayout& panel) {
  if (c.decoded != view.seeing || c.lit != view.seeing)
    throw std::runtime_error(
        fmt::format("self-check: {} pixels lit and {} decoded, {} see the panel", c.lit, c.decoded, view.seeing));
  for (int v = 0; v < view.panelOffset.rows; ++v)
    for (int u = 0; u < view.panelOffset.cols; ++u) {
      const int offset = view.panelOffset.at<int>(v, u);
      const cv::Vec2i expected =
          offset < 0 ? cv::Vec2i(-1, -1) : cv::Vec2i(offset % panel.panelWidth, offset / panel.panelWidth);
      if (c.panel.at<cv::Vec2i>(v, u) != expected)
        throw std::runtime_error(fmt::format("self-check: camera pixel ({}, {}) decoded to ({}, {}), sees ({}, {})", u,
                                             v, c.panel.at<cv::Vec2i>(v, u)[0], c.panel.at<cv::Vec2i>(v, u)[1],
                                             expected[0], expected[1]));
    }
}

// The bound: every byte of every frame read once, in row bands on OpenCV's threads.
template <typename T>
std::uint64_t sumOf(const std::vector<const cv::Mat*>& frames) {
  std::atomic<std::uint64_t> total{0};
  const int rows = frames.front()->rows, cols = frames.front()->cols;
  cv::parallel_for_(
      cv::Range(0, rows),
      [&](const cv::Range& band) {
        std::uint64_t sum = 0;
        for (const cv::Mat* frame : frames)
          for (int v = band.start; v < band.end; ++v) {
            const T* p = frame->ptr<T>(v);
            std::uint32_t row = 0;
            for (int u = 0; u < cols; ++u) row += p[u];
            sum += row;
          }
        total += sum;
      },
      rows / 8.0);
  return total;
}

void benchFormat(const Format& format, cv::Size size, const CodedPatternSet& set, int turns) {
  cv::RNG rng(format.type == CV_8UC1 ? 8 : 12);
  const View view = makeView(size, set.layout, format);
  std::vector<cv::Mat> patterns;
  cv::Mat white, black;
  const double made = secondsOf([&] {
    for (const cv::Mat& p : set.patterns) patterns.push_back(capture(p, view, format, rng));
    white = capture(set.white, view, format, rng);
    black = capture(set.black, view, format, rng);
  });
  std::vector<const cv::Mat*> all{&white, &black};
  for (const cv::Mat& p : patterns) all.push_back(&p);
  const double scale = format.fullScale_dn / 255;
  const DecodeSettings settings{.minLit_dn = static_cast<int>(16 * std::round(scale)),
                                .minContrast_dn = static_cast<int>(4 * std::round(scale)),
                                .minContrastFraction = 0.2};

  DecodeSettings twoSources = settings;
  twoSources.secondShare = 0.1;  // as the coded: capture decodes

  std::vector<double> decodeTime, twoTime, boundTime, ratio, twoRatio;
  volatile std::uint64_t sink = 0;
  for (int turn = 0; turn < turns; ++turn) {
    PanelCorrespondence c, c2;
    double td = 0, t2 = 0, tb = 0;
    const std::function<void()> steps[3] = {
        [&] { td = secondsOf([&] { c = decodeGrayCode(patterns, white, black, set, settings); }); },
        [&] { t2 = secondsOf([&] { c2 = decodeGrayCode(patterns, white, black, set, twoSources); }); },
        [&] {
          tb = secondsOf([&] { sink = format.type == CV_8UC1 ? sumOf<std::uint8_t>(all) : sumOf<std::uint16_t>(all); });
        }};
    for (int k = 0; k < 3; ++k) steps[(turn + k) % 3]();
    check(c, view, set.layout);
    check(c2, view, set.layout);
    if (cv::countNonZero(c2.second.reshape(1) != -1) != 0)  // (each camera pixel sees one panel pixel)
      throw std::runtime_error("self-check: a second source where every camera pixel sees one panel pixel");
    decodeTime.push_back(td), twoTime.push_back(t2), boundTime.push_back(tb);
    ratio.push_back(td / tb), twoRatio.push_back(t2 / tb);
  }
  (void)sink;

  const double bytes = static_cast<double>(all.size() * white.total() * white.elemSize());
  fmt::print("{} {} x {}, {} frames ({:.0f} MB), made in {:.1f} s; {} turns; {:.2f} of {:.2f} Mpx see the panel\n",
             format.name, size.width, size.height, all.size(), bytes / 1e6, made, turns, view.seeing / 1e6,
             size.area() / 1e6);
  fmt::print("  {:<34} {:>9} {:>9}   {:>22}\n", "", "median", "p99", "ratio to bound (p1-p99)");
  fmt::print("  {:<34} {:6.1f} ms {:6.1f} ms   {:6.2f} ({:.2f}-{:.2f})\n", "decodeGrayCode",
             1e3 * percentile(decodeTime, 0.5), 1e3 * percentile(decodeTime, 0.99), percentile(ratio, 0.5),
             percentile(ratio, 0.01), percentile(ratio, 0.99));
  fmt::print("  {:<34} {:6.1f} ms {:6.1f} ms   {:6.2f} ({:.2f}-{:.2f})\n", "decodeGrayCode, two sources",
             1e3 * percentile(twoTime, 0.5), 1e3 * percentile(twoTime, 0.99), percentile(twoRatio, 0.5),
             percentile(twoRatio, 0.01), percentile(twoRatio, 0.99));
  fmt::print("  {:<34} {:6.1f} ms {:6.1f} ms   ({:.1f} GB/s)\n", "bound: one read of every frame",
             1e3 * percentile(boundTime, 0.5), 1e3 * percentile(boundTime, 0.99),
             bytes / percentile(boundTime, 0.5) / 1e9);
}

int run(int argc, char** argv) {
  int repeats = 30, threads = 0;
  bool quick = false;
  CLI::App app(
      "lfi-coded-bench: decodeGrayCode of a 3840 x 2160 panel's Gray code set on 5 MP Mono8 and Mono12 "
      "frames against one read of the frames");
  app.add_option("--repeats", repeats, "Turns per format; the figures are their median and 99th percentile")
      ->check(CLI::Range(1, 100000));
  app.add_flag("--quick", quick, "A 960 x 540 panel, 612 x 512 frames and 5 turns (a smoke run of the self-checks)");
  app.add_option("--threads", threads, "OpenCV's threads (default: its own)")->check(CLI::Range(1, 256));
  CLI11_PARSE(app, argc, argv);
  if (quick && app.count("--repeats") == 0) repeats = 5;
  if (threads > 0) cv::setNumThreads(threads);

  const cv::Size panel = quick ? cv::Size(960, 540) : cv::Size(3840, 2160);
  const cv::Size camera = quick ? cv::Size(612, 512) : cv::Size(2448, 2048);
  CodedPatternSet set;
  const double made = secondsOf([&] { set = grayCodePatterns(panel.width, panel.height); });
  fmt::print("lfi-coded-bench: {} OpenCV threads; panel {} x {}: {} + {} bits, {} frames (made in {:.1f} s)\n",
             cv::getNumThreads(), panel.width, panel.height, set.layout.columnBits, set.layout.rowBits,
             set.layout.frameCount(), made);
  for (const Format& format : {Format{"Mono8", CV_8UC1, 255}, Format{"Mono12", CV_16UC1, 4095}})
    benchFormat(format, camera, set, repeats);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return lfi::bench::runGuarded("lfi-coded-bench", [&] { return run(argc, argv); });
}
