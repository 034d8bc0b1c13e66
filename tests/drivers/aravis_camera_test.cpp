// The Aravis backend against Aravis's own simulated GigE Vision camera
// (arv-fake-gv-camera-0.8, Debian package aravis-tools) on loopback: the real
// driver code path, GVCP control and GVSP streaming over UDP.
//
// Every GigE Vision device listens on UDP port 3956, so two fake cameras on
// 127.0.0.1 would answer each other's requests: the fixture holds an exclusive
// lock file while its camera runs, which serialises these tests across the
// processes `ctest -j` starts. Each camera gets a serial unique to the process.

#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/camera_registry.h"

#include "aravis_discovery.h"
#include "gige_device_process.h"

#include <arv.h>
#include "lfi_test_support.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>


namespace lfi {
namespace {

using namespace std::chrono_literals;
using testing_support::throwsError;
using Clock = std::chrono::steady_clock;
using lfi::testing_support::discoverDevice;
using lfi::testing_support::gigeDeviceAnswers;
using lfi::testing_support::GigeDeviceProcess;
using lfi::testing_support::gigeWriteRegister;
using lfi::testing_support::kHeartbeatTimeoutRegister;
using lfi::testing_support::LoopbackGigeLock;
using lfi::testing_support::missingBlockIds;

constexpr const char* kFakeCameraBinary = "arv-fake-gv-camera-0.8";

std::string findInPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/bin:/bin";
  std::size_t start = 0;
  while (start <= dirs.size()) {
    const std::size_t end = dirs.find(':', start);
    const std::filesystem::path candidate =
        std::filesystem::path(dirs.substr(start, end == std::string::npos ? std::string::npos : end - start)) / name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return {};
}

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// One arv-fake-gv-camera-0.8 process serving on 127.0.0.1.
class FakeGvCamera {
 public:
  explicit FakeGvCamera(std::string serial) : serial_(std::move(serial)) {}

  std::string id() const { return "Aravis-Fake-" + serial_; }
  const std::string& serial() const { return serial_; }

  // Starts the process and waits (up to 5 s) until it answers GVCP.
  // genicam: a GenICam description to serve instead of the built-in one (it
  // must address the fake device's registers).
  void start(const std::string& binary, int lostPacketsPerThousand = 0, const std::string& genicam = {},
             const std::string& address = "127.0.0.1") {
    std::vector<std::string> args = {binary, "-i", address, "-s", serial_};
    if (lostPacketsPerThousand > 0) {
      args.push_back("-r");
      args.push_back(std::to_string(lostPacketsPerThousand));
    }
    if (!genicam.empty()) {
      args.push_back("-g");
      args.push_back(genicam);
    }
    process_ = std::make_unique<GigeDeviceProcess>(args, 5s, /*quietStderr=*/true, address);
    address_ = address;
    // The fake device drops a controller that has not sent a heartbeat for 3 s (its default), as a real one does;
    // a client process stalled that long on a loaded CI host would lose its stream. 10 s, as `lfi serve-camera`.
    setHeartbeatTimeout(10s);
  }

  // Sets the device's heartbeat timeout (GigE Vision bootstrap register 0x0938); no controller may hold it.
  void setHeartbeatTimeout(std::chrono::milliseconds timeout) {
    if (!gigeWriteRegister(kHeartbeatTimeoutRegister, static_cast<std::uint32_t>(timeout.count()), address_))
      throw std::runtime_error("the fake device at " + address_ + " did not take its heartbeat timeout");
  }

  static bool answersGvcp() { return gigeDeviceAnswers(); }

  // SIGKILL: the device vanishes without a word, like a pulled cable.
  void kill() { process_.reset(); }

  // SIGSTOP, then SIGCONT after `duration`: the device stalls and comes back.
  void stall(std::chrono::milliseconds duration) {
    ::kill(process_->pid(), SIGSTOP);
    std::this_thread::sleep_for(duration);
    ::kill(process_->pid(), SIGCONT);
  }

 private:
  std::string serial_;
  std::string address_;
  std::unique_ptr<GigeDeviceProcess> process_;
};

class AravisCameraTest : public ::testing::Test {
 protected:
  void SetUp() override {
    binary_ = findInPath(kFakeCameraBinary);
    if (binary_.empty())
      LFI_SKIP_WITHOUT_TOOL(kFakeCameraBinary << " not found in PATH: install Debian's aravis-tools "
                                              << "(scripts/install-deps.sh) to run the GigE Vision loopback tests");
    lock_ = std::make_unique<LoopbackGigeLock>();
    registerDriverBackends();
    fake_ = std::make_unique<FakeGvCamera>("LFI" + std::to_string(::getpid()));
    fake_->start(binary_);
  }

  void TearDown() override {
    fake_.reset();
    lock_.reset();
  }

  std::unique_ptr<Camera> openFake() { return openCamera("aravis:" + fake_->id()); }

  // Replaces the fake device by one serving the GenICam description `xml`
  // (serial `prefix` + pid), and opens it.
  std::unique_ptr<Camera> openFakeWith(const std::string& prefix, const std::filesystem::path& xml) {
    fake_.reset();
    fake_ = std::make_unique<FakeGvCamera>(prefix + std::to_string(::getpid()));
    fake_->start(binary_, 0, xml.string());
    return openFake();
  }

  // A small free-running Mono8 set-up that streams fast on loopback.
  static CameraSettings smallSettings() {
    CameraSettings s;
    s.exposure_us = 1000;
    s.roiWidth_px = 256;
    s.roiHeight_px = 256;
    s.frameRate_hz = 200;
    return s;
  }

  std::string binary_;
  std::unique_ptr<LoopbackGigeLock> lock_;
  std::unique_ptr<FakeGvCamera> fake_;
};

TEST_F(AravisCameraTest, DiscoveryFindsTheFakeCamera) {
  int rounds = 0;
  const std::optional<AravisDeviceInfo> d = discoverDevice(fake_->id(), 3, rounds);
  ASSERT_TRUE(d) << fake_->id() << " not discovered in " << rounds << " rounds";
  EXPECT_EQ(d->vendor, "Aravis");
  EXPECT_EQ(d->model, "Fake");
  EXPECT_EQ(d->serial, fake_->serial());
  EXPECT_EQ(d->address, "127.0.0.1");
  EXPECT_EQ(d->protocol, "GigEVision");
  if (rounds > 1) std::printf("[ info     ] discovered in round %d\n", rounds);
}

TEST_F(AravisCameraTest, OpensByIdAndByAddress) {
  auto camera = openFake();
  EXPECT_EQ(camera->state(), Camera::State::Open);
  const CameraInfo info = camera->info();
  EXPECT_EQ(info.vendor, "Aravis");
  EXPECT_EQ(info.model, "Fake");
  EXPECT_EQ(info.serial, fake_->serial());
  EXPECT_EQ(info.deviceId, fake_->id());
  EXPECT_EQ(info.sensorWidth_px, 2048);
  EXPECT_EQ(info.sensorHeight_px, 2048);
  camera.reset();  // one controller at a time

  auto byAddress = openCamera("aravis:127.0.0.1");
  EXPECT_EQ(byAddress->info().serial, fake_->serial());
  byAddress.reset();

  // "The first camera found" (the only one here) is kept by its id: info() names it, so does a reopen.
  auto first = openCamera("aravis:");
  EXPECT_EQ(first->info().deviceId, fake_->id());
  first->close();
  first->open();
  EXPECT_EQ(first->info().deviceId, fake_->id());
}

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
  const std::filesystem::path xml = genicamWithout(
      {"SensorWidth", "SensorHeight"}, std::filesystem::temp_directory_path() / ("lfi-genicam-" + fake_->serial() + ".xml"));
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
  replaceOnce(text, "<Max>10000000.0</Max>", "<pMax>ExposureTimeAbsMax</pMax>");  // ExposureTimeAbs's, in us
  replaceOnce(text, "<Min>1000</Min>", "<pMin>AcquisitionFramePeriodMin</pMin>");  // AcquisitionFramePeriod's, in us
  if (HasFatalFailure()) return;  // (the fake device's description changed)
  const std::filesystem::path xml = writeGenicam(
      text, std::filesystem::temp_directory_path() / ("lfi-genicam-bounds-" + fake_->serial() + ".xml"),
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
  const std::filesystem::path xml = writeGenicam(
      text, std::filesystem::temp_directory_path() / ("lfi-genicam-cap-" + fake_->serial() + ".xml"),
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

TEST_F(AravisCameraTest, WrongIdIsNotFoundAndListsTheDevices) {
  const auto t0 = Clock::now();
  EXPECT_TRUE(throwsError([] { openCamera("aravis:No-Such-Camera"); }, Errc::NotFound,
                          {"No-Such-Camera", "devices found", fake_->id(), "127.0.0.1"}));
  std::printf("[ info     ] not found after %.3f s (two discovery rounds)\n", secondsSince(t0));
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
  EXPECT_EQ(camera->grab(2s).status, FrameStatus::Complete);

  camera->stop();
  EXPECT_EQ(camera->state(), S::Configured);
  camera->start(2);  // and again
  EXPECT_EQ(camera->grab(2s).status, FrameStatus::Complete);

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
  Frame frame = camera->grab(2s);
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
  frame = camera->grab(2s);
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

// This host's first IPv4 address outside 127/8 that is up, or "" if it has none.
std::string ownNonLoopbackAddress() {
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return {};
  std::string found;
  for (const ifaddrs* a = list; a != nullptr && found.empty(); a = a->ifa_next) {
    if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET || (a->ifa_flags & IFF_UP) == 0 ||
        (a->ifa_flags & IFF_LOOPBACK) != 0)
      continue;
    char text[INET_ADDRSTRLEN] = {};
    if (::inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(a->ifa_addr)->sin_addr, text, sizeof text))
      found = text;
  }
  ::freeifaddrs(list);
  return found;
}

// A device at one of this host's own addresses sends its stream through the
// loopback interface, whatever the address. Aravis listens for the stream on
// the interface it reached the device through: opened by its eth0 address, or
// by an id whose discovery answer came back through eth0 first (a race; the
// served camera tests timed out that way), control worked and no frame ever
// came. Opening by address makes Aravis pick eth0 every time; the backend
// reaches such a device through 127.0.0.1.
TEST_F(AravisCameraTest, ADeviceAtAnotherOwnAddressStreams) {
  const std::string address = ownNonLoopbackAddress();
  if (address.empty()) GTEST_SKIP() << "this host has no IPv4 address outside 127/8";
  FakeGvCamera other("LFIO" + std::to_string(::getpid()));
  other.start(binary_, 0, {}, address);
  auto camera = openCamera("aravis:" + address);
  camera->configure(smallSettings());
  camera->start(8);
  for (int i = 0; i < 5; ++i) {
    const Frame frame = camera->grab(2s);
    const StreamStatistics st = camera->statistics();
    ASSERT_EQ(frame.status, FrameStatus::Complete)
        << "device at " << address << ", frame " << i << ": " << toString(frame.status) << "; stream: "
        << st.completed << " completed, " << st.failed << " failed, " << st.missingPackets << " packets missing";
  }
}

// A device that sends another pixel format than the one configured (its
// firmware ignores PixelFormat, or a generic feature write changed it) must
// not hand out a complete frame of the wrong type or scale.
TEST_F(AravisCameraTest, AFrameInAnotherPixelFormatIsAnError) {
  auto camera = openFake();
  CameraSettings s = smallSettings();
  ASSERT_EQ(s.pixelFormat, PixelFormat::Mono8);
  camera->configure(s);
  camera->setFeature("PixelFormat", "Mono16");
  camera->start(4);
  Frame frame;
  EXPECT_TRUE(throwsError([&] { camera->grabInto(frame, 2s); }, Errc::Device,
                          {fake_->id(), "pixel format is 0x01100007", "configured Mono8"}));
  camera->stop();
  camera->setFeature("PixelFormat", "Mono8");
  camera->start(4);
  camera->grabInto(frame, 2s);
  EXPECT_EQ(frame.status, FrameStatus::Complete);
  EXPECT_EQ(frame.image.type(), CV_8UC1);
}

// The buffers are sized for the region the stream started with: a device that
// sends frames of another size (here one whose region changes while it
// streams; real ones lock it) gives an error naming both sizes, not a frame
// of a size the settings do not say.
TEST_F(AravisCameraTest, AFrameOfAnotherSizeThanTheStreamsRegionIsAnError) {
  auto camera = openFake();
  camera->configure(smallSettings());
  camera->start(4);
  Frame frame;
  camera->grabInto(frame, 2s);
  ASSERT_EQ(frame.status, FrameStatus::Complete);
  ASSERT_EQ(frame.image.size(), cv::Size(256, 256));
  camera->setFeature("Width", "128");
  std::string refused;
  for (int i = 0; i < 50 && refused.empty(); ++i) {  // (frames already on their way are still 256 wide)
    try {
      camera->grabInto(frame, 2s);
      ASSERT_EQ(frame.image.size(), cv::Size(256, 256));
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::Device);
      refused = e.what();
    }
  }
  EXPECT_NE(refused.find(fake_->id()), std::string::npos) << refused;
  EXPECT_NE(refused.find("128 x 256 px, not the 256 x 256 px region"), std::string::npos) << refused;
}

TEST_F(AravisCameraTest, StreamsContinuousCompleteFramesIntoReusedMemory) {
  auto camera = openFake();
  camera->configure(smallSettings());
  camera->start(8);
  constexpr int kFrames = 60;
  Frame frame;
  camera->grabInto(frame, 2s);
  ASSERT_EQ(frame.status, FrameStatus::Complete);
  const std::uint8_t* memory = frame.image.data;
  std::uint64_t lastId = frame.frameId;
  std::uint64_t lastTimestamp = frame.timestamp_ns;
  std::uint64_t gaps = 0;
  const auto t0 = Clock::now();
  for (int i = 1; i < kFrames; ++i) {
    camera->grabInto(frame, 2s);
    ASSERT_EQ(frame.status, FrameStatus::Complete) << "frame " << i;
    gaps += missingBlockIds(lastId, frame.frameId);
    EXPECT_GT(frame.timestamp_ns, lastTimestamp);
    EXPECT_EQ(frame.image.data, memory) << "grabInto must reuse the frame's memory";
    lastId = frame.frameId;
    lastTimestamp = frame.timestamp_ns;
  }
  const double fps = (kFrames - 1) / secondsSince(t0);
  RecordProperty("frames_per_second", std::to_string(fps));
  std::printf("[ info     ] %d frames of 256 x 256 Mono8 at %.1f frames/s (asked 200)\n", kFrames - 1, fps);

  // A caller holding on to a frame's image keeps it: the next grab writes elsewhere.
  cv::Mat kept = frame.image;
  camera->grabInto(frame, 2s);
  EXPECT_NE(frame.image.data, kept.data);

  const StreamStatistics stats = camera->statistics();
  EXPECT_GE(stats.completed, static_cast<std::uint64_t>(kFrames));
  EXPECT_EQ(stats.failed, 0u);
  EXPECT_EQ(stats.missingPackets, 0u);
  // Frame ids are consecutive unless this client let the buffer pool run dry
  // (a stall of 40 ms on a loaded host; Aravis then counts underruns): no id may go missing otherwise.
  if (stats.underruns == 0) EXPECT_EQ(gaps, 0u) << "frame ids must be consecutive";
  else EXPECT_LE(gaps, stats.underruns) << "frame ids skipped without an underrun";
  camera->stop();
  const StreamStatistics after = camera->statistics();  // kept after stop
  EXPECT_GE(after.completed, stats.completed);
}

TEST_F(AravisCameraTest, SlowConsumerSeesUnderruns) {
  auto camera = openFake();
  camera->configure(smallSettings());
  camera->start(2);
  std::this_thread::sleep_for(300ms);  // ~60 frames arrive for 2 buffers
  EXPECT_EQ(camera->grab(2s).status, FrameStatus::Complete);
  EXPECT_GT(camera->statistics().underruns, 0u);
}

TEST_F(AravisCameraTest, SoftwareTriggerGivesExactlyOneFramePerTrigger) {
  auto camera = openFake();
  CameraSettings s = smallSettings();
  s.trigger = TriggerMode::Software;
  camera->configure(s);
  camera->start(4);
  EXPECT_EQ(camera->grab(300ms).status, FrameStatus::Timeout) << "a frame arrived without a trigger";
  std::uint64_t lastId = 0;
  for (int i = 0; i < 5; ++i) {
    camera->softwareTrigger();
    const Frame frame = camera->grab(2s);
    ASSERT_EQ(frame.status, FrameStatus::Complete) << "trigger " << i;
    if (i > 0) {
      EXPECT_EQ(frame.frameId, lastId + 1);
    }
    lastId = frame.frameId;
    EXPECT_EQ(camera->grab(200ms).status, FrameStatus::Timeout) << "more than one frame for trigger " << i;
  }
  EXPECT_EQ(camera->statistics().completed, 5u);
}

TEST_F(AravisCameraTest, KilledDeviceIsReportedWithinTheTimeoutAndReopens) {
  auto camera = openFake();
  camera->configure(smallSettings());
  camera->start(4);
  ASSERT_EQ(camera->grab(2s).status, FrameStatus::Complete);

  fake_->kill();
  const auto t0 = Clock::now();
  bool deviceError = false;
  int timeouts = 0;
  while (secondsSince(t0) < 5) {
    try {
      const Frame frame = camera->grab(200ms);
      if (frame.status == FrameStatus::Timeout) ++timeouts;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::Device) << e.what();
      EXPECT_NE(std::string(e.what()).find(fake_->id()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("device lost"), std::string::npos) << e.what();
      deviceError = true;
      break;
    }
  }
  const double detected_s = secondsSince(t0);
  std::printf("[ info     ] device loss detected after %.3f s (%d timeouts before)\n", detected_s, timeouts);
  EXPECT_TRUE(deviceError);  // (expected after about 0.2 s: one 200 ms timeout and a probe the ICMP refusal ends)
  EXPECT_EQ(camera->state(), Camera::State::Closed);
  EXPECT_TRUE(throwsError([&] { camera->grab(10ms); }, Errc::InvalidArgument, {"state Closed"}));

  // The device comes back: open() reconnects.
  fake_->start(binary_);
  camera->open();
  camera->configure(smallSettings());
  camera->start(4);
  EXPECT_EQ(camera->grab(2s).status, FrameStatus::Complete);

  // Gone when the caller stops the stream: stop() finds it gone and closes.
  fake_->kill();
  const auto t1 = Clock::now();
  EXPECT_TRUE(throwsError([&] { camera->stop(); }, Errc::Device, {fake_->id(), "device lost", "AcquisitionStop"}));
  std::printf("[ info     ] stop() found the device gone after %.3f s\n", secondsSince(t1));
  EXPECT_EQ(camera->state(), Camera::State::Closed);
  const auto t2 = Clock::now();
  camera.reset();
  std::printf("[ info     ] destroyed after %.3f s\n", secondsSince(t2));
}

// Gone outside a grab or stop(): a software trigger, a configure() or a
// feature that finds the device gone closes the camera too (camera.h), and it
// reopens when the device is back.
TEST_F(AravisCameraTest, ADeviceGoneAtAnyRequestClosesTheCamera) {
  CameraSettings triggered = smallSettings();
  triggered.trigger = TriggerMode::Software;
  const std::vector<std::pair<std::string, std::function<void(Camera&)>>> requests = {
      {"software trigger", [&](Camera& c) { c.softwareTrigger(); }},
      {"configure", [&](Camera& c) { c.configure(smallSettings()); }},
      {"feature", [&](Camera& c) { c.getIntegerFeature("Width"); }},
  };
  auto camera = openFake();
  for (const auto& [what, request] : requests) {
    SCOPED_TRACE(what);
    camera->configure(triggered);
    if (what == "software trigger") camera->start(4);
    fake_->kill();
    const auto t0 = Clock::now();
    EXPECT_TRUE(throwsError([&] { request(*camera); }, Errc::Device, {fake_->id(), "device lost", "closed"}));
    std::printf("[ info     ] %s found the device gone after %.3f s\n", what.c_str(), secondsSince(t0));
    EXPECT_EQ(camera->state(), Camera::State::Closed);
    fake_->start(binary_);
    camera->open();
  }
}

// A device that stalls longer than its heartbeat timeout (3 s here, the fake
// device's default) drops its controller and stops streaming for good, though
// it answers again: the grab waiting for the next frame must say so, not time
// out, and open() takes control again.
TEST_F(AravisCameraTest, AControlChannelLostWhileStreamingIsADeviceError) {
  fake_->setHeartbeatTimeout(3s);
  auto camera = openFake();
  camera->configure(smallSettings());
  camera->start(4);
  ASSERT_EQ(camera->grab(2s).status, FrameStatus::Complete);
  fake_->stall(3500ms);
  const auto t0 = Clock::now();
  // Grabs until the loss is reported (a frame that arrived before Aravis noticed it may come first).
  int buffered = 0;
  EXPECT_TRUE(throwsError(
      [&] {
        while (camera->grab(20s).status != FrameStatus::Timeout && buffered < 100) ++buffered;
      },
      Errc::Device, {"control channel lost"}));
  std::printf("[ info     ] control loss reported %.2f s after the device came back, after %d buffered frames\n",
              secondsSince(t0), buffered);
  EXPECT_EQ(camera->state(), Camera::State::Closed);
  camera->open();
  camera->configure(smallSettings());
  camera->start(4);
  // It streams again. A frame may come out Incomplete on a loaded host (the fake device resends nothing; once in
  // CI under ASan the first one did), never timed out. (The wait is generous: once in CI under ASan, beside a
  // CLI test that rendered on both cores, no frame came within 2 s of the restart.)
  int complete = 0, incomplete = 0;
  for (int i = 0; i < 5 && complete == 0; ++i) {
    const FrameStatus status = camera->grab(10s).status;
    ASSERT_NE(status, FrameStatus::Timeout) << "frame " << i << " after the reopen";
    ++(status == FrameStatus::Complete ? complete : incomplete);
  }
  EXPECT_EQ(complete, 1) << incomplete << " incomplete frames and no complete one after the reopen";
}

TEST_F(AravisCameraTest, LostPacketsMakeIncompleteFramesNeverCompleteOnes) {
  fake_.reset();
  fake_ = std::make_unique<FakeGvCamera>("LFIR" + std::to_string(::getpid()));
  fake_->start(binary_, 5);  // the fake device drops 0.5 % of its stream packets
  // Small packets: 256 x 256 Mono8 is ~48 packets per frame, so about a fifth of the frames lose one.
  auto camera = openCamera("aravis:" + fake_->id() + "?packetSize=1400");
  camera->configure(smallSettings());
  camera->start(8);
  std::uint64_t complete = 0, incomplete = 0;
  for (int i = 0; i < 60; ++i) {
    const Frame frame = camera->grab(2s);
    ASSERT_NE(frame.status, FrameStatus::Timeout);
    (frame.status == FrameStatus::Complete ? complete : incomplete) += 1;
  }
  const StreamStatistics stats = camera->statistics();
  std::printf("[ info     ] 0.5 %% packet loss: %llu complete, %llu incomplete; %llu packets resent, %llu missing\n",
              static_cast<unsigned long long>(complete), static_cast<unsigned long long>(incomplete),
              static_cast<unsigned long long>(stats.resentPackets),
              static_cast<unsigned long long>(stats.missingPackets));
  // Aravis 0.8's fake GigE Vision camera does not answer PACKETRESEND_CMD, so nothing is recovered here.
  EXPECT_GT(incomplete, 0u);
  EXPECT_GT(stats.missingPackets, 0u);
  EXPECT_GT(complete, 0u);
  EXPECT_GE(stats.failed, incomplete);
  EXPECT_GE(stats.completed, complete);
}

}  // namespace
}  // namespace lfi
