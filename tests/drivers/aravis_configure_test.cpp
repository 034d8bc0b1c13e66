// SPDX-License-Identifier: Apache-2.0
// The Aravis backend's configuration (aravis_camera_fixture.h): the state machine,
// settings applied and read back or refused, devices whose GenICam description
// lacks or bounds features, and generic feature access.

#include "aravis_camera_fixture.h"

#include <arv.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <string>

namespace lfi {
namespace {

// The fake device's own GenICam description.
std::string fakeGenicam() {
  ArvFakeCamera* fake = arv_fake_camera_new("genicam");
  std::size_t size = 0;
  const char* xml = arv_fake_camera_get_genicam_xml(fake, &size);
  std::string text(xml, size);
  g_object_unref(fake);
  return text;
}

// Replaces the one occurrence of `from` in a GenICam description (a failure
// when it is not there exactly once: the fake device's description changed).
void replaceOnce(std::string& text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from << " is not in the fake device's description";
  ASSERT_EQ(text.find(from, at + 1), std::string::npos) << from << " is in the fake device's description twice";
  text.replace(at, from.size(), to);
}

// Writes a GenICam description for FakeGvCamera::start, with `extra` nodes before its end.
std::filesystem::path writeGenicam(std::string text, const std::filesystem::path& file, const std::string& extra) {
  const std::size_t end = text.rfind("</RegisterDescription>");
  EXPECT_NE(end, std::string::npos);
  if (end != std::string::npos) text.insert(end, extra);
  std::FILE* out = std::fopen(file.c_str(), "wb");
  EXPECT_NE(out, nullptr) << file;
  if (out != nullptr) {
    std::fwrite(text.data(), 1, text.size(), out);
    std::fclose(out);
  }
  return file;
}

// The fake device's description with every node named after `feature`
// renamed, so that the device no longer has that feature but keeps its
// registers.
std::filesystem::path genicamWithout(std::initializer_list<std::string> features, const std::filesystem::path& file,
                                     const std::string& extra = {}) {
  std::string text = fakeGenicam();
  for (const std::string& feature : features) {
    std::size_t replaced = 0;
    for (std::size_t at = 0; (at = text.find(feature, at)) != std::string::npos; at += feature.size() + 6, ++replaced)
      text.insert(at, "Hidden");
    EXPECT_GT(replaced, 0u) << feature << " is not in the fake device's description";
  }
  return writeGenicam(text, file, extra);
}

// SFNC only recommends SensorWidth and SensorHeight: a device without them
// opens, and its sensor is the largest image it gives.
TEST_F(AravisCameraTest, ADeviceWithoutSensorSizeFeaturesOpensWithItsLargestImage) {
  const std::filesystem::path xml =
      genicamWithout({"SensorWidth", "SensorHeight"},
                     std::filesystem::temp_directory_path() / ("lfi-genicam-" + fake_->serial() + ".xml"));
  auto camera = openFakeWith("LFIG", xml);
  EXPECT_TRUE(throwsError([&] { camera->getIntegerFeature("SensorWidth"); }, Errc::NotFound, {"SensorWidth"}));
  EXPECT_EQ(camera->getIntegerFeature("Width"), 512);  // the fake device's start-up image, smaller than its sensor
  const CameraInfo info = camera->info();
  EXPECT_EQ(info.sensorWidth_px, 2048);
  EXPECT_EQ(info.sensorHeight_px, 2048);
  // The full image is that size: a whole-sensor region is accepted.
  CameraSettings s;
  s.exposure_us = 1000;
  camera->configure(s);
  EXPECT_EQ(camera->getIntegerFeature("Width"), 2048);
  camera.reset();

  // With WidthMax and HeightMax (SFNC: the largest image at the binning in force), those.
  genicamWithout({"SensorWidth", "SensorHeight"}, xml,
                 "<Integer Name=\"WidthMax\" NameSpace=\"Standard\"><Value>1000</Value></Integer>\n"
                 "<Integer Name=\"HeightMax\" NameSpace=\"Standard\"><Value>700</Value></Integer>\n");
  camera = openFakeWith("LFIH", xml);
  EXPECT_EQ(camera->info().sensorWidth_px, 1000);
  EXPECT_EQ(camera->info().sensorHeight_px, 700);
  camera.reset();
  std::filesystem::remove(xml);
}

// SFNC leaves open how ExposureTime and AcquisitionFrameRate bound each other.
// Many devices keep the exposure within the frame period and the frame rate
// under 1 / exposure: going to a long exposure at a low rate then needs the
// rate first, and back to a short exposure at a high rate the exposure first.
// A fake device with both bounds (its description edited) takes both ways.
TEST_F(AravisCameraTest, AnExposureAndAFrameRateThatBoundEachOtherAreSetInAnOrderThatWorks) {
  std::string text = fakeGenicam();
  replaceOnce(text, "<Max>10000000.0</Max>", "<pMax>ExposureTimeAbsMax</pMax>");   // ExposureTimeAbs's, in us
  replaceOnce(text, "<Min>1000</Min>", "<pMin>AcquisitionFramePeriodMin</pMin>");  // AcquisitionFramePeriod's, in us
  if (HasFatalFailure()) return;  // (the fake device's description changed)
  const std::filesystem::path xml =
      writeGenicam(text, std::filesystem::temp_directory_path() / ("lfi-genicam-bounds-" + fake_->serial() + ".xml"),
                   "<SwissKnife Name=\"ExposureTimeAbsMax\" NameSpace=\"Custom\">\n"
                   "  <pVariable Name=\"PERIOD\">AcquisitionFramePeriod</pVariable><Formula>PERIOD</Formula>\n"
                   "</SwissKnife>\n"
                   "<IntSwissKnife Name=\"AcquisitionFramePeriodMin\" NameSpace=\"Custom\">\n"
                   "  <pVariable Name=\"EXPOSURE\">ExposureTimeAbsRegister</pVariable>\n"
                   "  <Formula>(EXPOSURE &gt; 1000) ? EXPOSURE : 1000</Formula>\n"
                   "</IntSwissKnife>\n");
  auto camera = openFakeWith("LFIB", xml);
  const CameraSettings fast = smallSettings();  // 1 ms at 200 Hz
  CameraSettings slow = fast;
  slow.exposure_us = 50'000;  // 50 ms at 10 Hz: past the 5 ms period of 200 Hz
  slow.frameRate_hz = 10;
  for (const CameraSettings& s : {fast, slow, fast}) {
    ASSERT_NO_THROW(camera->configure(s)) << s.exposure_us << " us at " << s.frameRate_hz << " Hz";
    const CameraSettings got = camera->settings();
    EXPECT_NEAR(got.exposure_us, s.exposure_us, 1e-6);
    EXPECT_NEAR(got.frameRate_hz, s.frameRate_hz, 1e-6);
  }
  // A pair no order allows is refused by its field and the bound in force.
  CameraSettings impossible = fast;
  impossible.exposure_us = 50'000;
  impossible.frameRate_hz = 100;
  EXPECT_TRUE(throwsError([&] { camera->configure(impossible); }, Errc::InvalidArgument,
                          {"exposure_us 50000", "10..10000 us", "100 Hz"}));
  camera.reset();
  std::filesystem::remove(xml);
}

// A frame-rate cap (SFNC's AcquisitionFrameRateEnable) left on by a
// free-running set-up bounds the exposure by that rate's period; in a
// triggered mode the triggers set the pace, so a long triggered exposure
// after a fast free run is taken. A fake device with the cap (its
// description edited: the exposure's maximum is the frame period while the
// cap is on) goes fast free run -> long software-triggered exposure -> fast.
TEST_F(AravisCameraTest, ATriggeredExposureIsNotBoundByAnEarlierFreeRunsFrameRate) {
  std::string text = fakeGenicam();
  replaceOnce(text, "<Max>10000000.0</Max>", "<pMax>ExposureTimeAbsMax</pMax>");  // ExposureTimeAbs's, in us
  if (HasFatalFailure()) return;  // (the fake device's description changed)
  const std::filesystem::path xml =
      writeGenicam(text, std::filesystem::temp_directory_path() / ("lfi-genicam-cap-" + fake_->serial() + ".xml"),
                   "<Boolean Name=\"AcquisitionFrameRateEnable\" NameSpace=\"Standard\">\n"
                   "  <pValue>AcquisitionFrameRateEnableValue</pValue><OnValue>1</OnValue><OffValue>0</OffValue>\n"
                   "</Boolean>\n"
                   "<Integer Name=\"AcquisitionFrameRateEnableValue\" NameSpace=\"Custom\"><Value>1</Value></Integer>\n"
                   "<SwissKnife Name=\"ExposureTimeAbsMax\" NameSpace=\"Custom\">\n"
                   "  <pVariable Name=\"PERIOD\">AcquisitionFramePeriod</pVariable>\n"
                   "  <pVariable Name=\"CAPPED\">AcquisitionFrameRateEnableValue</pVariable>\n"
                   "  <Formula>CAPPED ? PERIOD : 10000000</Formula>\n"
                   "</SwissKnife>\n");
  auto camera = openFakeWith("LFIC", xml);
  const CameraSettings fast = smallSettings();  // 1 ms at 200 Hz: a 5 ms period
  CameraSettings triggered = fast;
  triggered.trigger = TriggerMode::Software;
  triggered.frameRate_hz = 0;
  triggered.exposure_us = 50'000;
  for (const CameraSettings& s : {fast, triggered, fast}) {
    ASSERT_NO_THROW(camera->configure(s)) << toString(s.trigger) << ", " << s.exposure_us << " us";
    EXPECT_NEAR(camera->settings().exposure_us, s.exposure_us, 1e-6);
  }
  EXPECT_NEAR(camera->settings().frameRate_hz, 200, 1e-6);
  // The free run has its cap again: 50 ms do not fit its 5 ms period.
  CameraSettings tooLong = fast;
  tooLong.exposure_us = 50'000;
  EXPECT_TRUE(throwsError([&] { camera->configure(tooLong); }, Errc::InvalidArgument,
                          {"exposure_us 50000", "10..5000 us", "200 Hz"}));
  camera.reset();
  std::filesystem::remove(xml);
}

TEST_F(AravisCameraTest, StateMachine) {
  auto camera = openFake();
  using S = Camera::State;
  EXPECT_TRUE(throwsError([&] { camera->grab(10ms); }, Errc::InvalidArgument, {"grab()", "state Open", "Streaming"}));
  EXPECT_TRUE(throwsError([&] { camera->start(4); }, Errc::InvalidArgument, {"start()", "state Open"}));
  EXPECT_TRUE(throwsError([&] { camera->stop(); }, Errc::InvalidArgument, {"stop()", "state Open"}));
  EXPECT_TRUE(throwsError([&] { camera->settings(); }, Errc::InvalidArgument, {"settings()", "state Open"}));
  EXPECT_TRUE(throwsError([&] { camera->statistics(); }, Errc::InvalidArgument, {"statistics()", "state Open"}));
  EXPECT_TRUE(throwsError([&] { camera->open(); }, Errc::InvalidArgument, {"open()", "state Open", "Closed"}));

  camera->configure(smallSettings());
  EXPECT_EQ(camera->state(), S::Configured);
  camera->configure(smallSettings());  // reconfiguring is allowed
  EXPECT_TRUE(
      throwsError([&] { camera->softwareTrigger(); }, Errc::InvalidArgument, {"softwareTrigger()", "Configured"}));
  EXPECT_TRUE(throwsError([&] { camera->start(0); }, Errc::InvalidArgument, {"bufferCount = 0"}));

  camera->start(4);
  EXPECT_EQ(camera->state(), S::Streaming);
  EXPECT_TRUE(throwsError([&] { camera->configure(smallSettings()); }, Errc::InvalidArgument,
                          {"configure()", "state Streaming"}));
  EXPECT_TRUE(throwsError([&] { camera->start(4); }, Errc::InvalidArgument, {"start()", "state Streaming"}));
  EXPECT_TRUE(
      throwsError([&] { camera->softwareTrigger(); }, Errc::InvalidArgument, {"TriggerMode::Software", "FreeRun"}));
  EXPECT_EQ(grabComplete(*camera).status, FrameStatus::Complete);

  camera->stop();
  EXPECT_EQ(camera->state(), S::Configured);
  camera->start(2);  // and again
  EXPECT_EQ(grabComplete(*camera).status, FrameStatus::Complete);

  camera->close();
  EXPECT_EQ(camera->state(), S::Closed);
  EXPECT_TRUE(throwsError([&] { camera->info(); }, Errc::InvalidArgument, {"info()", "state Closed"}));
  EXPECT_TRUE(throwsError([&] { camera->getFeature("Width"); }, Errc::InvalidArgument, {"getFeature()", "Closed"}));
  camera->close();  // idempotent

  camera->open();
  EXPECT_EQ(camera->state(), S::Open);
  EXPECT_EQ(camera->info().serial, fake_->serial());

  // A failed configure leaves the camera Open, not half Configured.
  CameraSettings bad = smallSettings();
  bad.exposure_us = -1;
  EXPECT_TRUE(throwsError([&] { camera->configure(bad); }, Errc::InvalidArgument, {"exposure_us -1"}));
  EXPECT_EQ(camera->state(), S::Open);
}

TEST_F(AravisCameraTest, ConfigureAppliesAndReadsBackSettings) {
  auto camera = openFake();
  CameraSettings s;
  s.exposure_us = 2500;
  s.gain = 2;
  s.roiX_px = 64;
  s.roiY_px = 32;
  s.roiWidth_px = 320;
  s.roiHeight_px = 200;
  s.frameRate_hz = 50;
  camera->configure(s);
  const CameraSettings applied = camera->settings();
  EXPECT_NEAR(applied.exposure_us, 2500, 1);
  EXPECT_NEAR(applied.gain, 2, 1e-6);
  EXPECT_EQ(applied.roiX_px, 64);
  EXPECT_EQ(applied.roiY_px, 32);
  EXPECT_EQ(applied.roiWidth_px, 320);
  EXPECT_EQ(applied.roiHeight_px, 200);
  EXPECT_NEAR(applied.frameRate_hz, 50, 0.5);
  EXPECT_EQ(camera->getFeature("PixelFormat"), "Mono8");
  EXPECT_EQ(camera->getIntegerFeature("Width"), 320);

  camera->start(3);
  Frame frame = grabComplete(*camera);
  ASSERT_EQ(frame.status, FrameStatus::Complete);
  EXPECT_EQ(frame.image.type(), CV_8UC1);
  EXPECT_EQ(frame.image.cols, 320);
  EXPECT_EQ(frame.image.rows, 200);
  camera->stop();

  // Binning and Mono16. (The fake camera's Width range does not shrink with binning, so the ROI is explicit.)
  s.roiX_px = 0;
  s.roiY_px = 0;
  s.roiWidth_px = 512;
  s.roiHeight_px = 256;
  s.binning = 2;
  s.pixelFormat = PixelFormat::Mono16;
  camera->configure(s);
  EXPECT_EQ(camera->settings().binning, 2);
  EXPECT_EQ(camera->getFeature("PixelFormat"), "Mono16");
  camera->start(2);
  frame = grabComplete(*camera);
  ASSERT_EQ(frame.status, FrameStatus::Complete);
  EXPECT_EQ(frame.image.type(), CV_16UC1);
  EXPECT_EQ(frame.image.cols, 512);
  EXPECT_EQ(frame.image.rows, 256);
  camera->stop();

  // Width 0 means "to the edge of the device's width range".
  s.binning = 1;
  s.roiX_px = 48;
  s.roiWidth_px = 0;
  camera->configure(s);
  EXPECT_EQ(camera->settings().roiWidth_px, 2048 - 48);
}

TEST_F(AravisCameraTest, RefusedSettingsNameTheFieldAndTheLimits) {
  auto camera = openFake();
  CameraSettings s = smallSettings();
  s.pixelFormat = PixelFormat::Mono12;  // the fake camera offers Mono8 and Mono16 only
  EXPECT_TRUE(throwsError([&] { camera->configure(s); }, Errc::InvalidArgument, {"Mono12", "Mono12p", "Mono8, "}));
  s = smallSettings();
  s.exposure_us = 1e9;
  EXPECT_TRUE(throwsError([&] { camera->configure(s); }, Errc::InvalidArgument, {"exposure_us", "outside"}));
  s = smallSettings();
  s.roiX_px = 2000;
  EXPECT_TRUE(throwsError([&] { camera->configure(s); }, Errc::InvalidArgument, {"ROI", "does not fit"}));
  s.roiX_px = 5000;  // the offset itself past the sensor: named as such, whatever the width
  EXPECT_TRUE(throwsError([&] { camera->configure(s); }, Errc::InvalidArgument,
                          {"ROI offset (5000, 0) lies outside the 2048 x 2048"}));
  s = smallSettings();
  s.gain = 1000;
  EXPECT_TRUE(throwsError([&] { camera->configure(s); }, Errc::InvalidArgument, {"gain 1000", "outside"}));
}

TEST_F(AravisCameraTest, GenericFeatureAccess) {
  auto camera = openFake();
  EXPECT_EQ(camera->getFeature("DeviceVendorName"), "Aravis");
  camera->setIntegerFeature("Width", 128);
  EXPECT_EQ(camera->getIntegerFeature("Width"), 128);
  EXPECT_EQ(camera->getFeature("Width"), "128");
  camera->setFeature("PixelFormat", "Mono16");
  EXPECT_EQ(camera->getFeature("PixelFormat"), "Mono16");
  // The fake camera names its features the GigE Vision 1.x way (GainRaw, ExposureTimeAbs).
  camera->setIntegerFeature("GainRaw", 3);
  EXPECT_EQ(camera->getIntegerFeature("GainRaw"), 3);
  camera->setFloatFeature("ExposureTimeAbs", 3000.0);
  EXPECT_NEAR(camera->getFloatFeature("ExposureTimeAbs"), 3000.0, 1e-6);
  camera->executeCommand("TriggerSoftware");  // accepted outside acquisition, does nothing
  EXPECT_TRUE(
      throwsError([&] { camera->getFeature("NoSuchFeature"); }, Errc::NotFound, {"NoSuchFeature", fake_->id()}));
  EXPECT_TRUE(
      throwsError([&] { camera->setFeature("PixelFormat", "Mono99"); }, Errc::NotFound, {"PixelFormat", "Mono99"}));
  EXPECT_TRUE(throwsError([&] { camera->setIntegerFeature("Width", 1 << 20); }, Errc::InvalidArgument,
                          {fake_->id(), "'Width' to 1048576"}));
}

}  // namespace
}  // namespace lfi
