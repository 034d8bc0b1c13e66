// SPDX-License-Identifier: Apache-2.0
// render() as a caller sees it: a bit-identical image for any thread count and
// tile size, cancellation, progress reports, and the options it refuses.
#include "lfi/core/error.h"
#include "lfi/sim/render.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include "lfi_test_support.h"
#include "render_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

namespace {

using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::cameraAbove;
using lfi::testing_support::emitterBelow;
using lfi::testing_support::throwsError;

// ---- Determinism, cancellation, progress ----------------------------------

struct SmallLensScene {
  Scene scene;
  TelecentricCamera cam;
  SmallLensScene()
      : scene([] {
          std::vector<Object> objects;
          objects.push_back(emitterBelow(-60, ParallelEmission{1.0, 0.02}));
          objects.push_back({.name = "lens",
                             .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(100, -100, 7, 12)),
                             .material = Dielectric{1.5, 0.01}});
          return objects;
        }()),
        cam(cameraAbove(0, 32, 10, 0.01)) {}
};

TEST(Render, BitIdenticalForAnyThreadCountAndTileSize) {
  SmallLensScene s;
  RenderOptions a;
  a.samplesPerPixel = 4;
  a.splitDepth = 0;  // pure sampling: every random choice shows in the image
  a.seed = 7;
  a.threads = 1;
  a.tileSize = 16;
  RenderOptions b = a;
  b.threads = 2;
  b.tileSize = 5;
  const cv::Mat ia = render(s.scene, s.cam, a), ib = render(s.scene, s.cam, b);
  ASSERT_EQ(ia.size(), ib.size());
  ASSERT_EQ(ia.type(), ib.type());
  ASSERT_TRUE(ia.isContinuous() && ib.isContinuous());
  EXPECT_EQ(std::memcmp(ia.data, ib.data, ia.total() * ia.elemSize()), 0);
  EXPECT_GT(cv::norm(ia, cv::NORM_L1), 10);  // not trivially black

  RenderOptions c = b;
  c.seed = 8;
  const cv::Mat ic = render(s.scene, s.cam, c);
  EXPECT_NE(std::memcmp(ia.data, ic.data, ia.total() * ia.elemSize()), 0);
  EXPECT_GT(cv::norm(ia, ic, cv::NORM_L1), 1);

  // With Fresnel splitting each sample is a tree of branches, and samples of
  // different pixels share packets differently for each tile size: still the
  // same bits.
  RenderOptions split = a;
  split.splitDepth = 3;
  split.samplesPerPixel = 5;  // not a square: some samples outside the strata
  const cv::Mat reference = render(s.scene, s.cam, split);
  for (const auto& [threads, tile] : {std::pair{2, 1}, std::pair{2, 3}, std::pair{1, 64}}) {
    RenderOptions o = split;
    o.threads = threads;
    o.tileSize = tile;
    const cv::Mat other = render(s.scene, s.cam, o);
    EXPECT_EQ(std::memcmp(reference.data, other.data, reference.total() * reference.elemSize()), 0)
        << threads << " threads, tile " << tile;
  }
  EXPECT_GT(cv::norm(reference, cv::NORM_L1), 10);  // not trivially black
  // Splitting is in effect: the same samples without it give another image.
  RenderOptions sampled = split;
  sampled.splitDepth = 0;
  EXPECT_GT(cv::norm(reference, render(s.scene, s.cam, sampled), cv::NORM_L1), 1);
}

TEST(Render, CancelFlagSetBeforehandThrowsCancelled) {
  SmallLensScene s;
  std::atomic<bool> cancel{true};
  RenderOptions opt;
  opt.samplesPerPixel = 1;
  opt.threads = 2;
  opt.cancel = &cancel;
  try {
    render(s.scene, s.cam, opt);
    FAIL() << "render did not throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::Cancelled);
  }
  // Not set: renders normally.
  cancel = false;
  EXPECT_NO_THROW(render(s.scene, s.cam, opt));
}

TEST(Render, ProgressEndsAtOne) {
  SmallLensScene s;
  const int tileSize = 8, tiles = (32 / tileSize) * (32 / tileSize);
  for (int threads : {1, 2}) {
    std::mutex m;
    std::vector<double> calls;
    RenderOptions opt;
    opt.samplesPerPixel = 1;
    opt.threads = threads;
    opt.tileSize = tileSize;
    opt.progress = [&](double x) {
      std::lock_guard lock(m);
      calls.push_back(x);
    };
    render(s.scene, s.cam, opt);
    ASSERT_EQ(static_cast<int>(calls.size()), tiles) << "threads=" << threads;
    for (double x : calls) {
      EXPECT_GT(x, 0);
      EXPECT_LE(x, 1);
    }
    // Every fraction k / tiles is reported once; 1.0 is among them. With one
    // thread the calls come in order, so 1.0 is the last one.
    std::vector<double> sorted = calls;
    std::sort(sorted.begin(), sorted.end());
    for (int k = 0; k < tiles; ++k) EXPECT_DOUBLE_EQ(sorted[k], (k + 1.0) / tiles);
    if (threads == 1) {
      EXPECT_EQ(calls.back(), 1.0);
    }
  }
}

TEST(Render, RejectsInvalidOptions) {
  SmallLensScene s;
  RenderOptions opt;
  opt.samplesPerPixel = 0;
  EXPECT_TRUE(throwsError([&] { render(s.scene, s.cam, opt); }, Errc::InvalidArgument, {"samplesPerPixel"}));
  opt.samplesPerPixel = 1;
  opt.splitDepth = 13;
  EXPECT_TRUE(throwsError([&] { render(s.scene, s.cam, opt); }, Errc::InvalidArgument, {"splitDepth = 13", "[0, 12]"}));
  opt.splitDepth = 12;  // the largest taken
  EXPECT_NO_THROW(render(s.scene, s.cam, opt));
}

}  // namespace
