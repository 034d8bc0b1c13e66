// The `usb:` display backend through the real libusb against the emulated device
// (emulated_usb_display.h). Runs under umockdev's preload library (CTest starts it
// through tests/drivers/run_with_umockdev.sh).

#include "emulated_usb_display.h"
#include "lfi_test_support.h"

#include "lfi/drivers/display.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/usb/usb_display.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace lfi {
namespace {

using testing_support::EmulatedDisplayConfig;
using testing_support::EmulatedUsbDisplay;
using testing_support::throwsError;
using Clock = std::chrono::steady_clock;

const bool kPrivateTmp = (testing_support::usePrivateTmpDir(), true);

class UsbDisplayTest : public ::testing::Test {
protected:
  void SetUp() override {
    ASSERT_TRUE(kPrivateTmp);
    ASSERT_TRUE(testing_support::umockdevPreloadActive())
        << "umockdev's preload library is not active: run this test through ctest, umockdev-wrapper or "
           "LD_PRELOAD=libumockdev-preload.so.0";
    registerDriverBackends();
  }

  static cv::Mat randomPanel(const DisplayInfo& info, unsigned seed) {
    cv::Mat panel(info.panelHeight_px, info.panelWidth_px, info.panelType());
    cv::RNG rng(seed);
    rng.fill(panel, cv::RNG::UNIFORM, 0, 256);
    return panel;
  }

  static bool sameBytes(const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
  }

  // `panel` is presented whole, after one CLEAR_HALT that drops what the device holds of an earlier frame.
  static void expectPresentedAfterOneClearHalt(EmulatedUsbDisplay& device, Display& display, const cv::Mat& panel) {
    const std::uint32_t halts = device.state().clearHalts;
    const PresentResult result = display.show(panel);
    ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
    EXPECT_TRUE(sameBytes(device.presented(), panel));
    EXPECT_EQ(device.state().clearHalts, halts + 1);
  }
};

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
  EXPECT_EQ(info.optics.type, OpticsType::Lenslet);
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

// A serial with a space, a '/' and a '%' is named percent-encoded wherever a
// URI shows it, and that URI opens the display.
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

TEST_F(UsbDisplayTest, ASerialWithSpacesAndSlashesIsNamedPercentEncoded) {
  EmulatedDisplayConfig config;
  config.serial = "Bench A/2 50%";
  EmulatedUsbDisplay device(config);
  device.plug();
  const std::string uri = "usb:1209:4c46/Bench%20A%2F2%2050%25";
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46/NOPE"); }, Errc::NotFound, {"1209:4c46/Bench%20A%2F2%2050%25"}));
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
    EXPECT_EQ(parseUsbDisplayPath(parseDeviceUri(text, "display", "usb:1209:4c46").path, text).serial, s.serial);
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

TEST_F(UsbDisplayTest, StateMachine) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const DisplayInfo info = display->info();
  EXPECT_TRUE(throwsError([&] { display->open(); }, Errc::InvalidArgument, {"open", "state Open"}));
  display->blank();  // Open → Open
  EXPECT_EQ(display->state(), Display::State::Open);
  EXPECT_EQ(display->show(randomPanel(info, 1)).status, PresentStatus::Presented);
  EXPECT_EQ(display->state(), Display::State::Showing);
  EXPECT_EQ(display->show(randomPanel(info, 2)).status, PresentStatus::Presented);
  EXPECT_EQ(display->state(), Display::State::Showing);
  EXPECT_TRUE(display->status().showing);
  display->blank();
  EXPECT_EQ(display->state(), Display::State::Open);
  EXPECT_FALSE(display->status().showing);
  EXPECT_FALSE(device.state().showing);
  display->close();
  EXPECT_EQ(display->state(), Display::State::Closed);
  EXPECT_FALSE(device.state().claimed);
  EXPECT_TRUE(throwsError([&] { display->info(); }, Errc::InvalidArgument, {"info", "state Closed"}));
  EXPECT_TRUE(throwsError([&] { display->show(randomPanel(info, 3)); }, Errc::InvalidArgument, {"show"}));
  EXPECT_TRUE(throwsError([&] { display->blank(); }, Errc::InvalidArgument, {"blank"}));
  display->close();  // idempotent
  display->open();
  EXPECT_EQ(display->state(), Display::State::Open);
  // A wrong panel image is the caller's error.
  EXPECT_TRUE(throwsError([&] { display->show(cv::Mat(4, 4, CV_8UC3)); }, Errc::InvalidArgument,
                          {"640x400", "got 4x4"}));
}

TEST_F(UsbDisplayTest, Brightness) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  display->setBrightness(100);
  EXPECT_EQ(device.state().brightness, 100);
  EXPECT_EQ(display->status().brightness, 100);
  EXPECT_TRUE(throwsError([&] { display->setBrightness(256); }, Errc::InvalidArgument, {"brightness 256", "0..255"}));
}

struct PanelCase {
  int width;
  int height;
  usbdisplay::SubpixelCode subpixels;
};

// (GoogleTest would print the struct's bytes, padding included, into the CTest names: a different name each build.)
void PrintTo(const PanelCase& c, std::ostream* out) {
  *out << c.width << " x " << c.height << (c.subpixels == usbdisplay::SubpixelCode::Mono ? " mono" : " RGB stripe");
}

class UsbDisplayFrames : public UsbDisplayTest, public ::testing::WithParamInterface<PanelCase> {};

TEST_P(UsbDisplayFrames, ArriveByteExact) {
  EmulatedDisplayConfig config;
  config.panelWidth_px = GetParam().width;
  config.panelHeight_px = GetParam().height;
  config.subpixels = GetParam().subpixels;
  EmulatedUsbDisplay device(config);
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 256 * 1024;
  auto display = openUsbDisplay({usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""}, options);
  const DisplayInfo info = display->info();
  for (unsigned seed = 1; seed <= 2; ++seed) {
    const cv::Mat panel = randomPanel(info, seed);
    const auto start = Clock::now();
    const PresentResult result = display->show(panel);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
    EXPECT_TRUE(sameBytes(device.presented(), panel));
    EXPECT_EQ(device.state().presentedSequence, result.sequence);
    RecordProperty(fmt::format("show_{}x{}x{}_ms", info.panelWidth_px, info.panelHeight_px, panel.channels()),
                   static_cast<int>(seconds * 1000));
  }
  const std::size_t bytes =
      static_cast<std::size_t>(info.panelWidth_px) * info.panelHeight_px * info.subpixelsPerPixel();
  if (bytes > 2 * options.transferSize_bytes) {
    EXPECT_GE(device.state().maxUrbsInFlight, 2u);
  }
  EXPECT_EQ(display->status().framesPresented, 2u);
}

INSTANTIATE_TEST_SUITE_P(Sizes, UsbDisplayFrames,
                         ::testing::Values(PanelCase{1, 1, usbdisplay::SubpixelCode::Mono},
                                           PanelCase{333, 77, usbdisplay::SubpixelCode::Mono},
                                           PanelCase{640, 400, usbdisplay::SubpixelCode::RgbStripe},
                                           PanelCase{3840, 2160, usbdisplay::SubpixelCode::RgbStripe}),
                         [](const auto& param) {
                           return fmt::format("{}x{}x{}", param.param.width, param.param.height,
                                              param.param.subpixels == usbdisplay::SubpixelCode::Mono ? 1 : 3);
                         });

TEST_F(UsbDisplayTest, PresentedImageIsTheEncodedLightField) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const DisplayInfo info = display->info();
  LightFieldGeometry g{.spatialX = 24, .spatialY = 16, .angular = 8, .pixelPitch_mm = 0.25};
  LightField lf(g);
  cv::RNG rng(7);
  rng.fill(lf.lensletImage(), cv::RNG::UNIFORM, 0.0, 1.0);
  const PresentResult result = display->show(lf);
  ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
  const cv::Mat expected = encodeLightField(lf, DisplayOptics(info));
  EXPECT_TRUE(sameBytes(device.presented(), expected));
  EXPECT_GT(cv::countNonZero(expected.reshape(1)), static_cast<int>(expected.total()));  // not a blank panel
}

TEST_F(UsbDisplayTest, StallIsClearedAndTheFrameResent) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const cv::Mat panel = randomPanel(display->info(), 5);
  const std::uint32_t halts = device.state().clearHalts;  // one at open
  device.stallNextFrame();
  const PresentResult result = display->show(panel);
  ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), panel));
  EXPECT_EQ(device.state().clearHalts, halts + 1);
  EXPECT_EQ(display->status().stallsCleared, 1u);

  device.stallAlways(true);
  EXPECT_TRUE(throwsError([&] { display->show(panel); }, Errc::Device,
                          {"usb:1209:4c46", "endpoint 0x01 stalled again", "frame 2"}));
  device.stallAlways(false);
  EXPECT_EQ(display->show(panel).status, PresentStatus::Presented);
}

// A stall on a later transfer of a frame: the device's CLEAR_HALT drops the
// part it took, so the host must send the whole frame again, not the rest.
TEST_F(UsbDisplayTest, AStallOnALaterTransferIsClearedAndTheWholeFrameResent) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;  // 13 transfers for the 640 x 400 RGB panel
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat panel = randomPanel(display->info(), 21);
  const std::uint32_t halts = device.state().clearHalts;
  device.stallNextFrame(5);
  const PresentResult result = display->show(panel);
  ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), panel));
  EXPECT_EQ(device.state().clearHalts, halts + 1);
  EXPECT_EQ(display->status().stallsCleared, 1u);
}

// A transfer the device acknowledged with fewer bytes than it was given
// leaves a hole in the frame: the frame is an error, never PRESENTed, and
// the next one (after a CLEAR_HALT that drops the rest) arrives whole.
TEST_F(UsbDisplayTest, ATransferTheDeviceTookOnlyPartOfIsAnErrorAndTheNextFrameIsWhole) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat first = randomPanel(display->info(), 22), second = randomPanel(display->info(), 23);
  device.shortenNextFrame(2, 100);
  EXPECT_TRUE(throwsError([&] { display->show(first); }, Errc::Device,
                          {"usb:1209:4c46", "bulk OUT of frame 1", "failed"}));
  EXPECT_EQ(device.state().framesPresented, 0u);
  EXPECT_EQ(device.state().framesRejected, 0u);  // (nothing PRESENTed, so nothing refused)
  expectPresentedAfterOneClearHalt(device, *display, second);
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

// An open display is dark at full backlight, as display.h says and the sim:
// display is: close() blanks a panel that shows a frame, and open() blanks
// whatever an earlier host left (here one whose BLANK at close went unanswered).
TEST_F(UsbDisplayTest, ADisplayOpensDarkAtFullBacklightWhateverTheLastHostLeft) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46?timeout_ms=300");
  EXPECT_FALSE(device.state().showing);
  EXPECT_EQ(device.state().brightness, device.config().brightnessMax);
  display->setBrightness(7);
  ASSERT_EQ(display->show(randomPanel(display->info(), 30)).status, PresentStatus::Presented);
  display->close();
  EXPECT_FALSE(device.state().showing);
  EXPECT_EQ(device.state().brightness, 7);

  display->open();
  ASSERT_EQ(display->show(randomPanel(display->info(), 31)).status, PresentStatus::Presented);
  device.setSilent(true);
  display->close();  // its BLANK times out: the device still shows the frame
  device.setSilent(false);
  EXPECT_TRUE(device.state().showing);
  display->open();
  EXPECT_FALSE(device.state().showing);
  EXPECT_EQ(device.state().brightness, device.config().brightnessMax);
  const DisplayStatus status = display->status();
  EXPECT_FALSE(status.showing);
  EXPECT_EQ(status.brightness, device.config().brightnessMax);
  EXPECT_EQ(status.stallsCleared, 0u);
}

// The device vanishes at each request the host sends, at open and after: each
// is an error naming the device and the request, the display is closed, and
// it opens again once the device is back.
TEST_F(UsbDisplayTest, ADeviceThatVanishesAtAnyRequestIsNamedAndOpensAgainWhenBack) {
  using usbdisplay::Request;
  struct Case {
    Request request;
    bool atOpen;
    std::function<void(Display&, const cv::Mat&)> act;
  };
  const std::vector<Case> cases = {
      {Request::GetProtocolVersion, true, {}},
      {Request::GetDeviceInfo, true, {}},
      {Request::GetCalibration, true, {}},
      {Request::Blank, true, {}},
      {Request::SetBrightness, true, {}},
      {Request::SetBrightness, false, [](Display& d, const cv::Mat&) { d.setBrightness(7); }},
      {Request::Present, false, [](Display& d, const cv::Mat& panel) { d.show(panel); }},
      {Request::GetStatus, false, [](Display& d, const cv::Mat&) { d.status(); }},
      {Request::Blank, false, [](Display& d, const cv::Mat&) { d.blank(); }},
  };
  for (const Case& c : cases) {
    const std::string name = usbdisplay::toString(c.request);
    SCOPED_TRACE(name);
    EmulatedUsbDisplay device;
    device.plug();
    auto display = openDisplay("usb:1209:4c46");
    const cv::Mat panel = randomPanel(display->info(), 24);
    if (c.atOpen) display->close();
    device.unplugAtRequest(c.request);
    EXPECT_TRUE(throwsError([&] { c.atOpen ? display->open() : c.act(*display, panel); }, Errc::Device,
                            {"usb:1209:4c46", "vanished during " + name}));
    EXPECT_EQ(display->state(), Display::State::Closed);
    device.unplug();
    device.plug();
    display->open();
    const cv::Mat again = randomPanel(display->info(), 25);
    const PresentResult result = display->show(again);
    ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
    EXPECT_TRUE(sameBytes(device.presented(), again));
  }
  // And while it reads the reason for a refused frame.
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  device.corruptNextFrame();
  device.unplugAtRequest(Request::GetLastError);
  EXPECT_TRUE(throwsError([&] { display->show(randomPanel(display->info(), 26)); }, Errc::Device,
                          {"usb:1209:4c46", "vanished during GET_LAST_ERROR"}));
  EXPECT_EQ(display->state(), Display::State::Closed);
}

TEST_F(UsbDisplayTest, CrcMismatchIsARejectedFrame) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const cv::Mat first = randomPanel(display->info(), 1), second = randomPanel(display->info(), 2);
  ASSERT_EQ(display->show(first).status, PresentStatus::Presented);
  device.corruptNextFrame();
  const PresentResult result = display->show(second);
  EXPECT_EQ(result.status, PresentStatus::Rejected);
  EXPECT_NE(result.message.find("usb:1209:4c46"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("PRESENT of frame 2"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("payload CRC mismatch"), std::string::npos) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), first));  // the panel keeps the last good frame
  const DisplayStatus status = display->status();
  EXPECT_EQ(status.framesRejected, 1u);
  EXPECT_NE(status.lastError.find("payload CRC mismatch"), std::string::npos) << status.lastError;
  EXPECT_EQ(display->show(second).status, PresentStatus::Presented);  // and the next one goes through
  EXPECT_TRUE(sameBytes(device.presented(), second));
}

TEST_F(UsbDisplayTest, TruncatedFrameIsARejectedFrame) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const DisplayInfo info = display->info();
  device.truncateNextFrame(100);
  const PresentResult result = display->show(randomPanel(info, 3));
  EXPECT_EQ(result.status, PresentStatus::Rejected);
  EXPECT_NE(result.message.find("truncated frame"), std::string::npos) << result.message;
  const std::size_t full = 32 + static_cast<std::size_t>(info.panelWidth_px) * info.panelHeight_px * 3;
  EXPECT_NE(result.message.find(fmt::format("received {} of {} bytes", full - 100, full)), std::string::npos)
      << result.message;
  EXPECT_EQ(display->show(randomPanel(info, 4)).status, PresentStatus::Presented);
}

TEST_F(UsbDisplayTest, AbsurdDeviceRepliesAreClearErrors) {
  EmulatedUsbDisplay device;
  device.plug();
  device.setAbsurdDeviceInfo(true);
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46"); }, Errc::Device,
                          {"usb:1209:4c46", "calibration size 4294967295 bytes is outside"}));
  device.setAbsurdDeviceInfo(false);
  device.setBadCalibrationCrc(true);
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46"); }, Errc::Device,
                          {"usb:1209:4c46", "calibration blob CRC-32"}));
  device.setBadCalibrationCrc(false);
  EXPECT_NO_THROW(openDisplay("usb:1209:4c46"));  // the failed opens released the device
}

// A status that contradicts what the host did, or the device's own
// description, is an error naming the field; a rejection the device gives no
// reason for says so (never "no error" as the reason).
TEST_F(UsbDisplayTest, AStatusOrARejectionThatContradictsTheHostIsAnError) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const DisplayInfo info = display->info();
  ASSERT_EQ(display->show(randomPanel(info, 5)).status, PresentStatus::Presented);  // frame 1
  EXPECT_NO_THROW(display->status());
  device.lieInStatus(-1, 7);
  EXPECT_TRUE(throwsError([&] { display->status(); }, Errc::Device,
                          {"usb:1209:4c46", "GET_STATUS says it shows frame 7", "last frame this host presented is 1"}));
  device.lieInStatus(info.brightnessMax + 1, -1);
  EXPECT_TRUE(throwsError([&] { display->status(); }, Errc::Device,
                          {"usb:1209:4c46", fmt::format("brightness {}", info.brightnessMax + 1)}));
  device.lieInStatus(-1, -1);
  EXPECT_NO_THROW(display->status());
  display->blank();
  EXPECT_NO_THROW(display->status());  // blank: no frame to hold the device to
  ASSERT_EQ(display->show(randomPanel(info, 7)).status, PresentStatus::Presented);  // frame 2
  EXPECT_EQ(display->status().presentedSequence, 2u);

  device.forgetErrors(true);
  device.corruptNextFrame();
  const PresentResult result = display->show(randomPanel(info, 6));  // frame 3
  EXPECT_EQ(result.status, PresentStatus::Rejected);
  EXPECT_NE(result.message.find("PRESENT of frame 3 refused by the device: the device gives no reason for it"),
            std::string::npos)
      << result.message;
}

TEST_F(UsbDisplayTest, ADeviceThatNeverAnswersTimesOut) {
  EmulatedUsbDisplay device;
  device.plug();
  device.setSilent(true);
  auto start = Clock::now();
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46?timeout_ms=500"); }, Errc::Timeout,
                          {"usb:1209:4c46", "timed out after 500 ms"}));
  std::printf("[ info     ] timed out after %.3f s\n", std::chrono::duration<double>(Clock::now() - start).count());

  device.setSilent(false);
  auto display = openDisplay("usb:1209:4c46?timeout_ms=500");
  const cv::Mat panel = randomPanel(display->info(), 9);
  device.setSilent(true);
  start = Clock::now();
  const PresentResult result = display->show(panel);
  EXPECT_EQ(result.status, PresentStatus::Timeout);
  EXPECT_NE(result.message.find("timed out"), std::string::npos) << result.message;
  std::printf("[ info     ] timed out after %.3f s\n", std::chrono::duration<double>(Clock::now() - start).count());
  EXPECT_TRUE(throwsError([&] { display->status(); }, Errc::Timeout, {"GET_STATUS timed out"}));
  device.setSilent(false);
  EXPECT_EQ(display->show(panel).status, PresentStatus::Presented);
  EXPECT_TRUE(sameBytes(device.presented(), panel));
}

// A device that stops answering keeps the bytes of the frame it was taking
// until PRESENT or CLEAR_HALT resets it: the next frame must not be appended
// to them (it would overflow and be refused), whether the device fell silent
// mid-frame or at PRESENT.
TEST_F(UsbDisplayTest, AFrameAfterATimeoutIsPresented) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;  // several transfers per frame
  options.transferTimeout = options.controlTimeout = std::chrono::milliseconds(500);
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat first = randomPanel(display->info(), 12), second = randomPanel(display->info(), 13);
  device.silentAfterBulkUrbs(2);
  const PresentResult result = display->show(first);
  EXPECT_EQ(result.status, PresentStatus::Timeout);
  EXPECT_NE(result.message.find("timed out"), std::string::npos) << result.message;
  device.setSilent(false);
  std::uint32_t halts = device.state().clearHalts;
  PresentResult next = display->show(second);
  EXPECT_EQ(next.status, PresentStatus::Presented) << next.message;
  EXPECT_TRUE(sameBytes(device.presented(), second));
  EXPECT_EQ(device.state().clearHalts, halts + 1);

  device.silentAtNextPresent();
  EXPECT_TRUE(throwsError([&] { display->show(first); }, Errc::Timeout, {"PRESENT timed out"}));
  device.setSilent(false);
  halts = device.state().clearHalts;
  next = display->show(first);
  EXPECT_EQ(next.status, PresentStatus::Presented) << next.message;
  EXPECT_TRUE(sameBytes(device.presented(), first));
  EXPECT_EQ(device.state().clearHalts, halts + 1);
}

// A device that does not take the CLEAR_HALT meant to discard a failed frame
// (Linux reports the kernel's timeout as LIBUSB_ERROR_OTHER): that frame is a
// Timeout, and the next one clears the halt again before it is sent.
TEST_F(UsbDisplayTest, AFailedClearHaltIsTriedAgainBeforeTheNextFrame) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;
  options.transferTimeout = options.controlTimeout = std::chrono::milliseconds(500);
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat first = randomPanel(display->info(), 14), second = randomPanel(display->info(), 15);
  device.silentAfterBulkUrbs(2);
  EXPECT_EQ(display->show(first).status, PresentStatus::Timeout);
  device.setSilent(false);
  device.failClearHalt(ETIMEDOUT);
  const PresentResult refused = display->show(second);
  EXPECT_EQ(refused.status, PresentStatus::Timeout);
  EXPECT_NE(refused.message.find("CLEAR_HALT"), std::string::npos) << refused.message;
  EXPECT_NE(refused.message.find("LIBUSB_ERROR_OTHER"), std::string::npos) << refused.message;
  device.failClearHalt(0);
  expectPresentedAfterOneClearHalt(device, *display, second);
}

// The same when the host that left part of a frame is gone (a crashed
// process): the next host's first frame is presented.
TEST_F(UsbDisplayTest, AFrameAfterAnotherHostLeftPartOfOneIsPresented) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;
  options.transferTimeout = std::chrono::milliseconds(500);
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto first = openUsbDisplay(selector, options);
  const cv::Mat panel = randomPanel(first->info(), 14);
  device.silentAfterBulkUrbs(2);
  EXPECT_EQ(first->show(panel).status, PresentStatus::Timeout);
  first.reset();
  device.setSilent(false);
  auto second = openUsbDisplay(selector, options);
  const PresentResult result = second->show(panel);
  EXPECT_EQ(result.status, PresentStatus::Presented) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), panel));
}

TEST_F(UsbDisplayTest, UnplugMidTransferThenReplug) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;  // several transfers per frame
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat panel = randomPanel(display->info(), 11);
  device.unplugDuringNextFrame();
  EXPECT_TRUE(throwsError([&] { display->show(panel); }, Errc::Device,
                          {"usb:1209:4c46", "vanished during bulk OUT of frame 1"}));
  EXPECT_EQ(display->state(), Display::State::Closed);
  device.unplug();
  EXPECT_TRUE(throwsError([&] { display->open(); }, Errc::NotFound, {"usb:1209:4c46"}));
  device.plug();
  display->open();
  const PresentResult result = display->show(panel);
  ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), panel));
}

TEST_F(UsbDisplayTest, UnplugWhileIdle) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  device.unplug();
  EXPECT_TRUE(throwsError([&] { display->setBrightness(3); }, Errc::Device, {"vanished during SET_BRIGHTNESS"}));
  EXPECT_EQ(display->state(), Display::State::Closed);
  device.plug();
  display->open();
  EXPECT_EQ(display->state(), Display::State::Open);
}

}  // namespace
}  // namespace lfi
