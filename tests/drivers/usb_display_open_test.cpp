// SPDX-License-Identifier: Apache-2.0
// The `usb:` display backend finding and opening the emulated device (emulated_usb_display.h):
// its info and calibration, serials and URIs, the listing, and devices that cannot be opened.
// Runs under umockdev's preload library (CTest starts it through tests/drivers/run_with_umockdev.sh).

#include "lfi_test_support.h"
#include "usb_display_fixture.h"

#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/usb/usb_display.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace lfi {
namespace {

using emulation::EmulatedDisplayConfig;
using emulation::EmulatedUsbDisplay;
using testing_support::throwsError;
using testing_support::UsbDisplayTest;

TEST_F(UsbDisplayTest, OpenReadsInfoAndCalibrationFromTheDevice) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  ASSERT_EQ(display->state(), Display::State::Open);
  const DisplayInfo info = display->info();
  const EmulatedDisplayConfig& c = device.config();
  EXPECT_EQ(info.vendor, c.vendor);
  EXPECT_EQ(info.model, c.model);
  EXPECT_EQ(info.serial, c.serial);
  EXPECT_EQ(info.deviceId, "1209:4c46/" + c.serial);
  EXPECT_EQ(info.panelWidth_px, c.panelWidth_px);
  EXPECT_EQ(info.panelHeight_px, c.panelHeight_px);
  EXPECT_EQ(info.subpixels, SubpixelLayout::RgbStripe);
  EXPECT_EQ(info.viewCount, c.viewCount);
  EXPECT_EQ(info.brightnessMax, c.brightnessMax);
  // Doubles travel as IEEE-754 bytes: exact.
  EXPECT_EQ(info.pixelPitch_mm, c.calibration.pixelPitch_mm);
  EXPECT_EQ(info.optics.type, OpticsType::Lenticular);
  EXPECT_EQ(info.optics.lensPitch_px, c.calibration.lensPitch_px);
  EXPECT_EQ(info.optics.slant_rad, c.calibration.slant_rad);
  EXPECT_EQ(info.optics.offset_px, c.calibration.offset_px);
  EXPECT_EQ(info.optics.gap_mm, c.calibration.gap_mm);
  EXPECT_EQ(info.optics.focalLength_mm, c.calibration.focalLength_mm);
  EXPECT_TRUE(device.state().claimed);

  // By serial, and a serial that is not there.
  display->close();
  EXPECT_NO_THROW(openDisplay("usb:1209:4c46/" + c.serial));
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46/NOPE"); }, Errc::NotFound, {"usb:1209:4c46/NOPE"}));
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:0001"); }, Errc::NotFound, {"no such USB device", "1209:4c46"}));
}

// A full-parallax display sends a version 2 calibration block with its lens
// array; the host reads it into the optics model exactly. A class code the
// host does not know is refused at open, naming the device and the code.
TEST_F(UsbDisplayTest, AFullParallaxDisplayReportsItsLensArray) {
  EmulatedDisplayConfig config;
  config.model = "emulated lenslet array";
  config.viewCount = 1024;
  DisplayOpticsParams optics = defaultLensletArrayDisplay().optics;
  optics.packing = LensPacking::Hexagonal;
  optics.rotation_rad = 0.05;
  optics.arrayOffsetX_mm = 0.25;
  config.calibration = usbdisplay::toCalibrationBlock(0.0315, optics);
  {
    EmulatedUsbDisplay device(config);
    device.plug();
    auto display = openDisplay("usb:1209:4c46");
    const DisplayInfo info = display->info();
    EXPECT_EQ(info.optics, optics);
    EXPECT_EQ(info.pixelPitch_mm, 0.0315);
    EXPECT_TRUE(DisplayOptics(info).fullParallax());
  }
  config.calibration.optics = static_cast<usbdisplay::OpticsCode>(7);
  EmulatedUsbDisplay device(config);
  device.plug();
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46"); }, Errc::Device,
                          {"usb:1209:4c46", "optics class code 7 is unknown"}));
}

// A device without a USB serial string is named by VID:PID alone: the serial
// of its info block cannot select it (the backend matches the USB serial), so
// an id carrying it would not reopen the display.
TEST_F(UsbDisplayTest, ADisplayWithoutAUsbSerialIsNamedByItsIdsAlone) {
  EmulatedDisplayConfig config;
  config.serialDescriptor = false;
  EmulatedUsbDisplay device(config);
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  EXPECT_EQ(display->info().serial, config.serial);  // the info block's, for people
  const std::string id = display->info().deviceId;
  EXPECT_EQ(id, "1209:4c46");
  display->close();
  EXPECT_NO_THROW(openDisplay("usb:" + id));
  EXPECT_TRUE(throwsError([&] { openDisplay("usb:1209:4c46/" + config.serial); }, Errc::NotFound,
                          {"no such USB device", "1209:4c46/"}));
}

TEST_F(UsbDisplayTest, ABenchFileOverridesTheOpticsTheDeviceReports) {
  EmulatedUsbDisplay device;
  device.plug();
  const std::filesystem::path dir = std::filesystem::path(std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp");
  const std::filesystem::path file = dir / "bench-optics.toml";
  std::ofstream(file) << "format = \"lfi-display-calibration\"\nversion = 1\n[optics]\nslant_rad = 0.2\n"
                         "gap_mm = 0.8\n";
  const DisplayInfo reported = openDisplay("usb:1209:4c46")->info();
  const DisplayInfo overridden = openDisplay("usb:1209:4c46?calibration=" + file.string())->info();
  // The measured keys replace the device's; the others stay as the device said.
  EXPECT_DOUBLE_EQ(overridden.optics.slant_rad, 0.2);
  EXPECT_DOUBLE_EQ(overridden.optics.gap_mm, 0.8);
  EXPECT_DOUBLE_EQ(overridden.optics.lensPitch_px, reported.optics.lensPitch_px);
  EXPECT_NE(reported.optics.slant_rad, 0.2);
  // A typo in the bench file is an error naming the file, line and key.
  std::ofstream(file) << "format = \"lfi-display-calibration\"\nversion = 1\n[optics]\nslant = 0.2\n";
  EXPECT_TRUE(throwsError([&] { openDisplay("usb:1209:4c46?calibration=" + file.string()); }, Errc::Config,
                          {file.string() + ":4", "optics.slant"}));
  EXPECT_TRUE(throwsError([&] { openDisplay("usb:1209:4c46?calibration=" + (dir / "none.toml").string()); },
                          Errc::NotFound, {"none.toml"}));
}

// The listing finds a display by the protocol's vendor interface and names the
// URI that opens it; an unplugged one is gone from it.
TEST_F(UsbDisplayTest, TheListingNamesTheUriThatOpensTheDisplay) {
  EXPECT_TRUE(listUsbDisplays().empty()) << "nothing is plugged in yet";
  EmulatedDisplayConfig config;
  config.serial = "Bench A/2";
  EmulatedUsbDisplay device(config);
  device.plug();
  const std::vector<UsbDisplayInfo> displays = listUsbDisplays();
  ASSERT_EQ(displays.size(), 1u);
  EXPECT_EQ(displays[0].selector.uri(), "usb:1209:4c46/Bench%20A%2F2");
  EXPECT_EQ(displays[0].problem, "");
  EXPECT_GT(displays[0].address, 0);
  EXPECT_EQ(openDisplay(displays[0].selector.uri())->info().serial, config.serial);
  device.unplug();
  EXPECT_TRUE(listUsbDisplays().empty());
}

// A serial with a space, a '/' and a '%' is named percent-encoded wherever a
// URI shows it, and that URI opens the display.
TEST_F(UsbDisplayTest, ASerialWithSpacesAndSlashesIsNamedPercentEncoded) {
  EmulatedDisplayConfig config;
  config.serial = "Bench A/2 50%";
  EmulatedUsbDisplay device(config);
  device.plug();
  const std::string uri = "usb:1209:4c46/Bench%20A%2F2%2050%25";
  EXPECT_TRUE(
      throwsError([] { openDisplay("usb:1209:4c46/NOPE"); }, Errc::NotFound, {"1209:4c46/Bench%20A%2F2%2050%25"}));
  auto display = openDisplay(uri);
  EXPECT_EQ(display->info().serial, config.serial);
  EXPECT_EQ("usb:" + display->info().deviceId, uri);
  EXPECT_EQ((UsbDisplaySelector{0x1209, 0x4c46, config.serial}.uri()), uri);
  display->close();
  // Lower-case hex digits decode too; a '%' without two of them is an error naming the URI.
  EXPECT_NO_THROW(openDisplay("usb:1209:4c46/Bench%20A%2f2%2050%25"));
  for (const char* bad : {"usb:1209:4c46/a%2", "usb:1209:4c46/a%zz", "usb:1209:4c46/%00"})
    EXPECT_TRUE(throwsError([&] { openDisplay(bad); }, Errc::Config, {bad, "two hex digits"})) << bad;
  // Every byte but NUL survives the round trip through a URI.
  std::string all;
  for (int c = 1; c < 256; ++c) all += static_cast<char>(c);
  for (std::size_t i = 0; i < all.size(); i += 100) {
    const UsbDisplaySelector s{0x1209, 0x4c46, all.substr(i, 100)};
    const std::string text = s.uri();
    EXPECT_EQ(parseUsbDisplayPath(DeviceUri::parse(text, "display", "usb:1209:4c46").path, text).serial, s.serial);
  }
}

// Two displays of one VID:PID: without a serial the choice is refused,
// listing both; a serial opens the one it names, and frames go to it alone.
// One that cannot be opened still makes the choice ambiguous.
TEST_F(UsbDisplayTest, SeveralDisplaysAreToldApartByTheirSerials) {
  EmulatedDisplayConfig a, b;
  a.serial = "LFI-EMU-A";
  b.serial = "LFI-EMU-B";
  b.deviceNumber = 3;
  EmulatedUsbDisplay first(a), second(b);
  first.plug();
  second.plug();
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46"); }, Errc::Config,
                          {"usb:1209:4c46", "2 displays match", "name one by serial", "LFI-EMU-A", "LFI-EMU-B"}));
  std::vector<std::string> listed;
  for (const UsbDisplayInfo& d : listUsbDisplays()) listed.push_back(d.selector.uri());
  std::sort(listed.begin(), listed.end());
  EXPECT_EQ(listed, (std::vector<std::string>{"usb:1209:4c46/LFI-EMU-A", "usb:1209:4c46/LFI-EMU-B"}));

  auto display = openDisplay("usb:1209:4c46/LFI-EMU-B");
  EXPECT_EQ(display->info().serial, "LFI-EMU-B");
  const cv::Mat panel = randomPanel(display->info(), 27);
  ASSERT_EQ(display->show(panel).status, PresentStatus::Presented);
  EXPECT_TRUE(sameBytes(second.presented(), panel));
  EXPECT_TRUE(first.presented().empty());
  display.reset();

  second.loseNode();
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46"); }, Errc::Config,
                          {"usb:1209:4c46", "2 displays match, 1 of them cannot be opened", "LFI-EMU-A"}));
  EXPECT_EQ(openDisplay("usb:1209:4c46/LFI-EMU-A")->info().serial, "LFI-EMU-A");
}

TEST_F(UsbDisplayTest, UriErrorsNameTheUri) {
  EXPECT_TRUE(throwsError([] { openDisplay("usb:12:4c46"); }, Errc::Config, {"usb:12:4c46", "4 hex digits"}));
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46?speed=1"); }, Errc::Config, {"unknown key 'speed'"}));
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46?timeout_ms=x"); }, Errc::Config, {"timeout_ms"}));
  EXPECT_TRUE(throwsError([] { openDisplay("nope:1"); }, Errc::Config, {"unknown scheme 'nope:'", "usb:"}));
}

TEST_F(UsbDisplayTest, AnInterfaceAnotherProgramHoldsIsNamed) {
  EmulatedUsbDisplay device;
  device.plug();
  device.failClaim(EBUSY);
  EXPECT_TRUE(throwsError([&] { openDisplay("usb:1209:4c46"); }, Errc::Device,
                          {"usb:1209:4c46", "cannot claim interface 0", "LIBUSB_ERROR_BUSY",
                           "another program, or another display object of this process, has it"}));
  device.failClaim(0);
  auto display = openDisplay("usb:1209:4c46");
  EXPECT_EQ(display->state(), Display::State::Open);
}

TEST_F(UsbDisplayTest, AbsurdDeviceRepliesAreClearErrors) {
  EmulatedUsbDisplay device;
  device.plug();
  device.setAbsurdDeviceInfo(true);
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46"); }, Errc::Device,
                          {"usb:1209:4c46", "calibration size 4294967295 bytes is outside"}));
  device.setAbsurdDeviceInfo(false);
  device.setBadCalibrationCrc(true);
  EXPECT_TRUE(
      throwsError([] { openDisplay("usb:1209:4c46"); }, Errc::Device, {"usb:1209:4c46", "calibration blob CRC-32"}));
  device.setBadCalibrationCrc(false);
  EXPECT_NO_THROW(openDisplay("usb:1209:4c46"));  // the failed opens released the device
}

}  // namespace
}  // namespace lfi
