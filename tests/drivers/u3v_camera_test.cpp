// SPDX-License-Identifier: Apache-2.0
// The emulated USB3 Vision camera behind Aravis's own USB3 Vision code (its
// libusb enumeration, GenCP bootstrap, GenICam features and stream) and lfi's
// aravis: backend: every frame delivered is the frame the device made for it.

#include "lfi/core/error.h"
#include "lfi/drivers/camera_registry.h"

#include "lfi_test_support.h"
#include "run_command.h"
#include "u3v_camera_fixture.h"

#include <arv.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

namespace lfi {
namespace {

using namespace std::chrono_literals;
using testing_support::throwsError;
using testing_support::U3vCameraTest;

// Aravis finds the device by its USB descriptors (class 0xEF/0x02/0x01, the
// USB3 Vision interfaces, the GUID string the device info descriptor names),
// bootstraps it over GenCP (ABRM, SBRM, SIRM, the manifest, the XML) and reads
// and writes its features.
TEST_F(U3vCameraTest, AravisListsTheDeviceAndReadsAndWritesItsFeatures) {
  arv_update_device_list();
  int index = -1;
  for (unsigned i = 0; i < arv_get_n_devices(); ++i)
    if (device_->deviceId() == arv_get_device_id(i)) index = static_cast<int>(i);
  ASSERT_GE(index, 0) << device_->deviceId() << " not listed";
  EXPECT_STREQ(arv_get_device_protocol(static_cast<unsigned>(index)), "USB3Vision");
  EXPECT_EQ(arv_get_device_serial_nbr(static_cast<unsigned>(index)), config_.serial);
  EXPECT_EQ(arv_get_device_vendor(static_cast<unsigned>(index)), config_.vendor);

  GError* error = nullptr;
  ArvCamera* camera = arv_camera_new(device_->deviceId().c_str(), &error);
  ASSERT_NE(camera, nullptr) << (error ? error->message : "");
  EXPECT_TRUE(arv_camera_is_uv_device(camera));
  EXPECT_EQ(std::string(arv_camera_get_vendor_name(camera, nullptr)), config_.vendor);
  EXPECT_EQ(std::string(arv_camera_get_model_name(camera, nullptr)), config_.model);
  EXPECT_EQ(std::string(arv_camera_get_device_serial_number(camera, nullptr)), config_.serial);
  gint width = 0, height = 0;
  arv_camera_get_sensor_size(camera, &width, &height, nullptr);
  EXPECT_EQ(width, 320);
  EXPECT_EQ(height, 240);
  // PayloadSize follows the region and the format: 2 bytes a pixel at Mono16, 1.5 at Mono12p.
  arv_camera_set_region(camera, 10, 20, 100, 50, &error);
  ASSERT_EQ(error, nullptr) << error->message;
  arv_camera_set_pixel_format(camera, ARV_PIXEL_FORMAT_MONO_16, &error);
  ASSERT_EQ(error, nullptr) << error->message;
  EXPECT_EQ(arv_camera_get_payload(camera, nullptr), 100u * 50 * 2);
  arv_camera_set_pixel_format_from_string(camera, "Mono12p", &error);
  ASSERT_EQ(error, nullptr) << error->message;
  EXPECT_EQ(arv_camera_get_payload(camera, nullptr), 100u * 50 * 3 / 2);
  arv_camera_set_exposure_time(camera, 1234.5, &error);
  ASSERT_EQ(error, nullptr) << error->message;
  EXPECT_DOUBLE_EQ(arv_camera_get_exposure_time(camera, nullptr), 1234.5);
  // A value past the device's range: the device refuses it (GenCP INVALID_PARAMETER),
  // whatever the client checked, and the register keeps its value.
  arv_device_set_float_feature_value(arv_camera_get_device(camera), "Gain", 40.0, &error);
  EXPECT_NE(error, nullptr);
  g_clear_error(&error);
  EXPECT_DOUBLE_EQ(arv_camera_get_gain(camera, nullptr), 0.0);
  g_object_unref(camera);
  EXPECT_GT(device_->state().commands, 20u);
}

// Aravis's own command line tools, in processes of their own (umockdev's
// preload library and testbed are inherited; the device answers from this
// process): arv-tool lists the device as a USB3 Vision one and reads and
// writes a feature through GenCP; arv-camera-test streams from it.
TEST_F(U3vCameraTest, AravisCommandLineToolsSeeAndStreamTheDevice) {
  const std::string id = device_->deviceId();
  EXPECT_THAT(testing_support::runCommand("arv-tool-0.8 2>&1").output, ::testing::HasSubstr(id + " (USB3)"));
  EXPECT_THAT(
      testing_support::runCommand("arv-tool-0.8 -n '" + id + "' control Width=160 Width SensorHeight 2>&1").output,
      ::testing::AllOf(::testing::HasSubstr("Width = 160"), ::testing::HasSubstr("SensorHeight = 240")));
  // Three seconds free running at 50 Hz, in each of Aravis's USB modes (sync: one
  // read at a time, hunting for the leader; async: a frame's transfers queued ahead),
  // until the tool is interrupted, as a user stops it.
  for (const char* mode : {"sync", "async"}) {
    const std::uint64_t sent = device_->state().framesSent;
    const std::string streamed = testing_support::runCommand("timeout --signal=INT 3 arv-camera-test-0.8 -n '" + id +
                                                             "' -f 50 -s " + mode + " 2>&1")
                                     .output;
    EXPECT_GT(device_->state().framesSent, sent + 50) << mode << ": " << streamed;
    // Its closing statistics: about 150 frames complete, none failed.
    auto statistic = [&](const std::string& name) {
      const std::size_t at = streamed.find(name + " ");
      return at == std::string::npos ? -1L : std::stol(streamed.substr(streamed.find('=', at) + 1));
    };
    EXPECT_GT(statistic("n_completed_buffers"), 50) << mode << ": " << streamed;
    EXPECT_EQ(statistic("n_failures"), 0) << mode << ": " << streamed;
  }
}

// lfi's aravis: backend on the emulated device, in each pixel format and in
// both of Aravis's USB modes (aravis:<id>?usb_mode=sync|async): every frame it
// delivers, software-triggered in a region of the sensor, is the one the device
// made under that frame id, pixel for pixel.
TEST_F(U3vCameraTest, EveryFrameTheBackendDeliversIsTheFrameTheDeviceMadeForIt) {
  for (const char* mode : {"sync", "async"})
    for (PixelFormat format : {PixelFormat::Mono8, PixelFormat::Mono12, PixelFormat::Mono16}) {
      SCOPED_TRACE(std::string(mode) + " " + toString(format));
      auto camera = openCamera("aravis:" + device_->deviceId() + "?usb_mode=" + mode);
      CameraSettings s;
      s.pixelFormat = format;
      s.roiX_px = 13, s.roiY_px = 7, s.roiWidth_px = 200, s.roiHeight_px = 150;
      s.trigger = TriggerMode::Software;
      camera->configure(s);
      camera->start(4);
      for (int k = 0; k < 5; ++k) {
        camera->softwareTrigger();
        const Frame frame = camera->grab(5s);
        ASSERT_EQ(frame.status, FrameStatus::Complete) << "frame " << k;
        const cv::Mat expected = made(frame.frameId);
        ASSERT_FALSE(expected.empty()) << "the device made no frame " << frame.frameId;
        ASSERT_EQ(frame.image.size(), cv::Size(200, 150));
        ASSERT_EQ(frame.image.type(), expected.type());
        EXPECT_EQ(cv::norm(frame.image, expected, cv::NORM_INF), 0) << "frame " << frame.frameId;
      }
      camera->stop();
      camera->close();
    }
  EXPECT_EQ(device_->state().framesDropped, 0u);
  EXPECT_TRUE(throwsError([&] { openCamera("aravis:" + device_->deviceId() + "?usb_mode=bulk"); }, Errc::Config,
                          {"usb_mode", "bulk", "sync or async"}));
}

// While it streams, the backend reads the settings from the device once (the
// controller asks at every part; each read is a GenCP round trip), and again
// after a feature written through it.
TEST_F(U3vCameraTest, AStreamingCamerasSettingsAreReadOnceAndAgainAfterAFeatureWrite) {
  auto camera = openCamera("aravis:" + device_->deviceId());
  CameraSettings s;
  s.trigger = TriggerMode::Software;
  camera->configure(s);
  camera->start(2);
  EXPECT_DOUBLE_EQ(camera->settings().exposure_us, 10000);
  const std::uint64_t commands = device_->state().commands;
  for (int i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(camera->settings().exposure_us, 10000);
  EXPECT_EQ(device_->state().commands, commands) << "settings() went to the device again";
  camera->setFloatFeature("ExposureTime", 2500);
  EXPECT_DOUBLE_EQ(camera->settings().exposure_us, 2500);
  camera->stop();
  camera->setFloatFeature("ExposureTime", 4000);
  camera->start(2);
  EXPECT_DOUBLE_EQ(camera->settings().exposure_us, 4000);
}

}  // namespace
}  // namespace lfi
