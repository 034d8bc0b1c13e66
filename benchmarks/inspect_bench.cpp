// SPDX-License-Identifier: Apache-2.0
// lfi-inspect-bench: the inspection's latency, frame arrival → verdict
// (DefectFinder::find against a trained golden model), for 5-megapixel Mono8
// and Mono12 frames, next to a bound measured in the same turns.
//
//   once     the DefectFinder's set-up (the smoothed difference's σ per pixel),
//            as an inspection or a run does it before its first part
//   timed    DefectFinder::find on a fresh frame of a good part (clean) and of a part
//            with three dark defects drawn in (defective), the verdict taken
//            from its answer; on OpenCV's thread pool
//   bound    one pass over the frame's bytes: a memcpy of the frame into a
//            touched buffer, plus one cv::absdiff of the frame against the next
//            frame of the same type (what the least golden-template check costs)
//   figures  median and 99th percentile (nearest rank) of each over the turns;
//            ratio: the median of the turns' ratios timed / bound, with their
//            1st-99th percentile (each turn runs its three steps back to back,
//            in an order that rotates from turn to turn)
//   check    every timed answer: a clean frame has no defect; a defective one
//            has exactly the three drawn, each dark with its centroid within
//            1.5 px of the drawn disc's centre. Any miss exits 1: a fast wrong
//            answer does not pass.
//
// Frames: 2448 x 2048 (a Sony IMX264's full frame), Mono8 (CV_8UC1) and Mono12
// (CV_16UC1, 12-bit values). The part: a smooth bright disc (75 % of full scale
// at its centre, 15 % less at its rim, a gentle tilt) of radius 0.46 of the
// frame's height on a dark background (4 %), its mask the disc. Noise: the
// camera's shot noise (full well 10 500 e- at full scale) and read noise (2.5 DN
// at 12 bits), normal, rounded to DN. The golden model is trained from 16 such
// frames with that noise as its floor. Defects: discs of radius 2.5-6 px, 20-50 %
// darker, inside the part, at least 60 px apart. Settings: smoothing 1 px,
// closing 2 px, b = 6, minimum area 4 px². A pool of 8 clean and 8 defective
// frames per format is cycled through (40 MB of Mono8 or 80 MB of Mono12 a
// kind: more than a last-level cache holds, as frames from a camera). The
// part's edge leaves a few off pixels just outside its mask in every frame, so
// clean frames too go through the closing and labelling (and find nothing).
//
// Usage: lfi-inspect-bench [--repeats N] [--quick] [--threads N]
//   --repeats  turns per format (default 200; each turn: clean, defective, bound)
//   --quick    612 x 512 frames, 10 turns (a smoke run of the self-checks)
//   --threads  OpenCV's threads (default: OpenCV's own, the hardware's)

#include "lfi/inspection/defects.h"
#include "lfi/inspection/golden_model.h"

#include "bench_util.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

using namespace lfi;

namespace {

using lfi::bench::percentile;
using lfi::bench::secondsOf;

void keep(const void* p) {
  asm volatile("" : : "r"(p) : "memory");
}

struct Format {
  const char* name;
  int type;
  double fullScale_dn;
};

struct DrawnDefect {
  cv::Point2d centre;
  double radius = 0;
};

struct Frame {
  cv::Mat image;
  std::vector<DrawnDefect> defects;
};

// The part as the camera sees it, in DN, and its mask.
struct Part {
  cv::Mat level;  // CV_32FC1
  cv::Mat sigma;  // CV_32FC1: the camera's noise at each pixel's level
  cv::Mat mask;   // CV_8UC1
  cv::Point2d centre;
  double radius = 0;
  CameraNoise noise;
};

Part makePart(cv::Size size, const Format& format) {
  Part part;
  part.centre = {0.5 * size.width, 0.5 * size.height};
  part.radius = 0.46 * size.height;
  const double fs = format.fullScale_dn;
  part.noise = {.read_dn = 2.5 * fs / 4095, .gain_dnPerElectron = fs / 10500};
  part.level.create(size, CV_32FC1);
  part.sigma.create(size, CV_32FC1);
  part.mask.create(size, CV_8UC1);
  for (int row = 0; row < size.height; ++row) {
    float* level = part.level.ptr<float>(row);
    float* sigma = part.sigma.ptr<float>(row);
    std::uint8_t* mask = part.mask.ptr<std::uint8_t>(row);
    for (int col = 0; col < size.width; ++col) {
      const double rho = std::hypot(col - part.centre.x, row - part.centre.y) / part.radius;
      const bool inside = rho <= 1;
      const double l = inside ? fs * (0.75 * (1 - 0.15 * rho * rho) + 0.03 * col / size.width) : 0.04 * fs;
      level[col] = static_cast<float>(l);
      sigma[col] =
          static_cast<float>(std::sqrt(part.noise.read_dn * part.noise.read_dn + part.noise.gain_dnPerElectron * l));
      mask[col] = inside ? 255 : 0;
    }
  }
  return part;
}

// A frame of the part with `count` dark discs drawn in, noised and rounded to DN.
Frame makeFrame(const Part& part, const Format& format, int count, cv::RNG& rng) {
  Frame frame;
  cv::Mat level = part.level.clone();
  while (static_cast<int>(frame.defects.size()) < count) {
    const double angle = rng.uniform(0.0, 2 * CV_PI), distance = 0.8 * part.radius * std::sqrt(rng.uniform(0.0, 1.0));
    const DrawnDefect d{{part.centre.x + distance * std::cos(angle), part.centre.y + distance * std::sin(angle)},
                        rng.uniform(2.5, 6.0)};
    if (std::any_of(frame.defects.begin(), frame.defects.end(),
                    [&](const DrawnDefect& e) { return cv::norm(e.centre - d.centre) < 60; }))
      continue;
    const auto factor = static_cast<float>(rng.uniform(0.5, 0.8));
    // As findDefects' centroids: pixel (col, row) is the point (col, row).
    for (int row = static_cast<int>(d.centre.y - d.radius - 1); row <= d.centre.y + d.radius + 1; ++row)
      for (int col = static_cast<int>(d.centre.x - d.radius - 1); col <= d.centre.x + d.radius + 1; ++col)
        if (std::hypot(col - d.centre.x, row - d.centre.y) <= d.radius) level.at<float>(row, col) *= factor;
    frame.defects.push_back(d);
  }
  cv::Mat noise(level.size(), CV_32FC1);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
  cv::Mat dn = noise.mul(part.sigma) + level;
  cv::min(dn, format.fullScale_dn, dn);
  dn.convertTo(frame.image, format.type);  // rounded, and clipped at 0
  return frame;
}

// The verdict's check: nothing on a clean frame, exactly the drawn defects on a defective one.
void check(const std::vector<Defect>& found, const Frame& frame, const char* what) {
  if (found.size() != frame.defects.size())
    throw std::runtime_error(
        fmt::format("self-check ({}): {} defects found, {} drawn", what, found.size(), frame.defects.size()));
  for (const DrawnDefect& d : frame.defects) {
    const bool matched = std::any_of(found.begin(), found.end(), [&](const Defect& f) {
      return f.dark && std::hypot(f.centroid_px.x - d.centre.x, f.centroid_px.y - d.centre.y) < 1.5;
    });
    if (!matched)
      throw std::runtime_error(
          fmt::format("self-check ({}): the dark disc of radius {:.1f} px at ({:.1f}, {:.1f}) "
                      "was not found there",
                      what, d.radius, d.centre.x, d.centre.y));
  }
}

void benchFormat(const Format& format, cv::Size size, int turns, const DetectionSettings& settings) {
  constexpr int kTraining = 16, kPool = 8, kDefects = 3;
  cv::RNG rng(format.type == CV_8UC1 ? 8 : 12);
  const Part part = makePart(size, format);
  GoldenModelTrainer trainer;
  for (int i = 0; i < kTraining; ++i) trainer.add(makeFrame(part, format, 0, rng).image);
  const GoldenModel model = trainer.model(part.noise);
  std::optional<DefectFinder> finder;
  const double setUp = secondsOf([&] { finder.emplace(model, part.mask, settings); });
  std::vector<Frame> clean, defective;
  for (int i = 0; i < kPool; ++i) {
    clean.push_back(makeFrame(part, format, 0, rng));
    defective.push_back(makeFrame(part, format, kDefects, rng));
  }

  const size_t bytes = clean[0].image.total() * clean[0].image.elemSize();
  cv::Mat copy(size, format.type, cv::Scalar(1)), difference(size, format.type, cv::Scalar(1));  // touched
  std::vector<double> cleanTime, defectiveTime, boundTime, copyTime, absdiffTime, cleanRatio, defectiveRatio;
  for (int turn = 0; turn < turns; ++turn) {
    const Frame& c = clean[static_cast<size_t>(turn % kPool)];
    const Frame& d = defective[static_cast<size_t>(turn % kPool)];
    const cv::Mat& next = clean[static_cast<size_t>((turn + 1) % kPool)].image;
    double tc = 0, td = 0, tcopy = 0, tabs = 0;
    std::vector<Defect> foundClean, foundDefective;
    const std::function<void()> steps[3] = {[&] { tc = secondsOf([&] { foundClean = finder->find(c.image); }); },
                                            [&] { td = secondsOf([&] { foundDefective = finder->find(d.image); }); },
                                            [&] {
                                              tcopy = secondsOf([&] {
                                                std::memcpy(copy.data, c.image.data, bytes);
                                                keep(copy.data);
                                              });
                                              tabs = secondsOf([&] {
                                                cv::absdiff(c.image, next, difference);
                                                keep(difference.data);
                                              });
                                            }};
    for (int k = 0; k < 3; ++k) steps[(turn + k) % 3]();
    check(foundClean, c, "clean frame");
    check(foundDefective, d, "defective frame");
    cleanTime.push_back(tc), defectiveTime.push_back(td), copyTime.push_back(tcopy), absdiffTime.push_back(tabs);
    boundTime.push_back(tcopy + tabs);
    cleanRatio.push_back(tc / (tcopy + tabs)), defectiveRatio.push_back(td / (tcopy + tabs));
  }

  fmt::print("{} {} x {} ({:.1f} MB a frame), golden model from {} frames, {} turns\n", format.name, size.width,
             size.height, bytes / 1e6, kTraining, turns);
  fmt::print("  DefectFinder set-up, once: {:.1f} ms\n", 1e3 * setUp);
  fmt::print("  {:<32} {:>9} {:>9}   {:>22}\n", "", "median", "p99", "ratio to bound (p1-p99)");
  auto line = [&](const char* label, const std::vector<double>& t, const std::vector<double>* ratio) {
    fmt::print("  {:<32} {:6.2f} ms {:6.2f} ms", label, 1e3 * percentile(t, 0.5), 1e3 * percentile(t, 0.99));
    if (ratio)
      fmt::print("   {:6.2f} ({:.2f}-{:.2f})", percentile(*ratio, 0.5), percentile(*ratio, 0.01),
                 percentile(*ratio, 0.99));
    fmt::print("\n");
  };
  line("find, clean frame", cleanTime, &cleanRatio);
  line(fmt::format("find, {} defects", kDefects).c_str(), defectiveTime, &defectiveRatio);
  line("bound: memcpy + absdiff", boundTime, nullptr);
  line("  memcpy of the frame", copyTime, nullptr);
  line("  cv::absdiff of two frames", absdiffTime, nullptr);
}

int run(int argc, char** argv) {
  int repeats = 200, threads = 0;
  bool quick = false;
  CLI::App app("lfi-inspect-bench: DefectFinder::find on 5 MP Mono8 and Mono12 frames against memcpy + absdiff");
  app.add_option("--repeats", repeats, "Turns per format; the figures are their median and 99th percentile")
      ->check(CLI::Range(1, 100000));
  app.add_flag("--quick", quick, "612 x 512 frames and 10 turns (a smoke run of the self-checks)");
  app.add_option("--threads", threads, "OpenCV's threads (default: its own)")->check(CLI::Range(1, 256));
  CLI11_PARSE(app, argc, argv);
  if (quick && app.count("--repeats") == 0) repeats = 10;
  if (threads > 0) cv::setNumThreads(threads);

  const cv::Size size = quick ? cv::Size(612, 512) : cv::Size(2448, 2048);
  const DetectionSettings settings{.relative = 6, .smoothing_px = 1, .closing_px = 2, .minArea_px = 4};
  fmt::print("lfi-inspect-bench: {} OpenCV threads; smoothing {} px, closing {} px, b = {}, minimum area {} px^2\n",
             cv::getNumThreads(), settings.smoothing_px, settings.closing_px, settings.relative, settings.minArea_px);
  for (const Format& format : {Format{"Mono8", CV_8UC1, 255}, Format{"Mono12", CV_16UC1, 4095}})
    benchFormat(format, size, repeats, settings);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return lfi::bench::runGuarded("lfi-inspect-bench", [&] { return run(argc, argv); });
}
