// SPDX-License-Identifier: Apache-2.0
// What both EXR writers share: existing files kept unless overwriting is allowed, images
// refused before anything is written, and the thread count OpenEXR runs with.

#include "exr_io_fixture.h"

#include "lfi/core/error.h"
#include "lfi_test_support.h"

#include <OpenEXR/ImfThreading.h>

#include <gtest/gtest.h>
#include <sched.h>

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

namespace lfi::exr_test {
namespace {

using lfi::testing_support::throwsError;

TEST_F(ExrIo, ExistingFileIsKeptUnlessOverwriteAllowed) {
  const LightFieldGeometry g = geometry();
  const LightField first(g, randomFloats(g.height(), g.width(), 14));
  const LightField second(g, randomFloats(g.height(), g.width(), 15));
  const fs::path path = file("lf.exr");
  lfi::writeLightFieldExr(path, first);
  EXPECT_TRUE(throwsError([&] { lfi::writeLightFieldExr(path, second); }, Errc::Exists, {path.string()}));
  EXPECT_TRUE(throwsError([&] { lfi::writeLightFieldExr(path, second, lfi::Overwrite::Refuse); }, Errc::Exists,
                          {path.string()}));
  EXPECT_TRUE(bitIdentical(lfi::readLightFieldExr(path).lensletImage(), first.lensletImage()));
  lfi::writeLightFieldExr(path, second, lfi::Overwrite::Allow);
  EXPECT_TRUE(bitIdentical(lfi::readLightFieldExr(path).lensletImage(), second.lensletImage()));
  // Same for radiance images.
  const fs::path r = file("r.exr");
  lfi::writeRadianceExr(r, first.lensletImage(), {});
  EXPECT_TRUE(throwsError([&] { lfi::writeRadianceExr(r, second.lensletImage(), {}); }, Errc::Exists, {r.string()}));
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(r), first.lensletImage()));
  lfi::writeRadianceExr(r, second.lensletImage(), {}, lfi::Overwrite::Allow);
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(r), second.lensletImage()));
  // No temporaries are left behind.
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"lf.exr", "r.exr"}));
}

TEST_F(ExrIo, WritingRejectsWrongImages) {
  EXPECT_TRUE(throwsError([&] { lfi::writeRadianceExr(file("a.exr"), cv::Mat(4, 4, CV_8UC1), {}); },
                          Errc::InvalidArgument, {"a.exr"}));
  EXPECT_TRUE(
      throwsError([&] { lfi::writeRadianceExr(file("b.exr"), cv::Mat(), {}); }, Errc::InvalidArgument, {"b.exr"}));
  EXPECT_FALSE(fs::exists(file("a.exr")));
  EXPECT_FALSE(fs::exists(file("b.exr")));
  // What the reader would refuse is not written, and does not replace a good file.
  const cv::Mat good(4, 4, CV_32FC1, cv::Scalar(1));
  lfi::writeRadianceExr(file("c.exr"), good, {});
  cv::Mat bad = good.clone();
  bad.at<float>(2, 3) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(throwsError([&] { lfi::writeRadianceExr(file("c.exr"), bad, {}, lfi::Overwrite::Allow); },
                          Errc::InvalidArgument, {"c.exr", "(3, 2)", "finite"}));
  EXPECT_TRUE(
      throwsError([&] { lfi::writeRadianceExr(file("c.exr"), good, {.objectPixel_mm = -1}, lfi::Overwrite::Allow); },
                  Errc::InvalidArgument, {"c.exr", "objectPixel_mm"}));
  EXPECT_TRUE(bitIdentical(lfi::readRadianceExr(file("c.exr")), good));
  // A light field whose image was changed through lensletImage() after it was checked.
  const LightFieldGeometry g = geometry();
  LightField lf(g, randomFloats(g.height(), g.width(), 16));
  lf.lensletImage().at<float>(1, 1) = std::numeric_limits<float>::infinity();
  EXPECT_TRUE(
      throwsError([&] { lfi::writeLightFieldExr(file("lf.exr"), lf); }, Errc::InvalidArgument, {"lf.exr", "(1, 1)"}));
  lf.lensletImage() = cv::Mat(3, 3, CV_32FC1, cv::Scalar(0));
  EXPECT_TRUE(
      throwsError([&] { lfi::writeLightFieldExr(file("lf.exr"), lf); }, Errc::InvalidArgument, {"lf.exr", "3x3"}));
  EXPECT_FALSE(fs::exists(file("lf.exr")));
}

// OpenEXR's pool has one thread per CPU the process may run on (a container's
// cpuset narrows it; hardware_concurrency() would not), or the count a
// program's --threads gives; files still round-trip on one thread.
TEST_F(ExrIo, OpenExrThreadsFollowTheProcessCpusOrTheGivenCount) {
  cpu_set_t all;
  ASSERT_EQ(sched_getaffinity(0, sizeof all, &all), 0);
  int first = 0;
  while (!CPU_ISSET(first, &all)) ++first;
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(first, &one);
  ASSERT_EQ(sched_setaffinity(0, sizeof one, &one), 0);
  lfi::setExrThreads(0);
  const int onOneCpu = Imf::globalThreadCount();
  ASSERT_EQ(sched_setaffinity(0, sizeof all, &all), 0);
  EXPECT_EQ(onOneCpu, 1);

  lfi::setExrThreads(3);
  EXPECT_EQ(Imf::globalThreadCount(), 3);
  lfi::setExrThreads(1);
  cv::Mat image(300, 200, CV_32FC1);
  cv::randu(image, 0.0f, 2.0f);
  lfi::writeRadianceExr(file("one-thread.exr"), image, {});
  EXPECT_EQ(cv::norm(lfi::readRadianceExr(file("one-thread.exr")), image, cv::NORM_INF), 0.0);

  lfi::setExrThreads(0);
  EXPECT_EQ(Imf::globalThreadCount(), CPU_COUNT(&all));
  EXPECT_TRUE(throwsError([] { lfi::setExrThreads(-1); }, Errc::InvalidArgument, {"-1"}));
  EXPECT_EQ(Imf::globalThreadCount(), CPU_COUNT(&all));
}

}  // namespace
}  // namespace lfi::exr_test
