// SPDX-License-Identifier: Apache-2.0
// GvCameraServer (gv_camera_server.h) on Aravis's ArvGvFakeCamera.

#include "lfi/emulation/gv_camera_server.h"

#include "lfi/core/error.h"

#include "served_camera_device.h"

#include <arpa/inet.h>
#include <arv.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <spdlog/spdlog.h>

#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <thread>

namespace lfi::emulation {
namespace {

// GigE Vision bootstrap registers (GigE Vision 2.x, table "bootstrap registers").
constexpr guint32 kManufacturerNameOffset = 0x0048;  // 32 bytes
constexpr guint32 kModelNameOffset = 0x0068;         // 32 bytes
constexpr std::size_t kNameSize = 32;
// GigE Vision bootstrap register: how long the device keeps its controller
// without a heartbeat (ms). Aravis's client never writes it and the device's
// default is 3 s; a host stalled that long (a loaded CI machine) would lose
// control for good and the stream would stop without a word. 10 s: a crashed
// client still frees the device soon.
constexpr guint32 kHeartbeatTimeoutOffset = 0x0938;
constexpr guint32 kHeartbeatTimeout_ms = 10'000;
constexpr double kTriggerCheckRate_hz = 200;

// The served camera's GenICam description in a file of its own, which Aravis's fake camera reads when it
// is made (detail::servedGenicamXml); written once per process.
const std::string& servedGenicamFile() {
  static const std::string file = [] {
    ArvFakeCamera* plain = arv_fake_camera_new("LFIXML");
    std::size_t size = 0;
    const char* xml = arv_fake_camera_get_genicam_xml(plain, &size);
    const std::string text = detail::servedGenicamXml(std::string(xml, size));
    g_object_unref(plain);
    std::string name = (std::filesystem::temp_directory_path() / "lfi-served-camera-XXXXXX.xml").string();
    const int fd = ::mkstemps(name.data(), 4);
    if (fd < 0) fail(Errc::Io, "served camera: cannot write its GenICam file '{}': {}", name, std::strerror(errno));
    const bool written = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
    ::close(fd);
    if (!written) fail(Errc::Io, "served camera: cannot write its GenICam file '{}'", name);
    static struct Remove {
      std::string file;
      ~Remove() { std::remove(file.c_str()); }
    } remove{name};
    return name;
  }();
  return file;
}

guint32 readRegister(ArvFakeCamera* camera, guint32 address) {
  guint32 value = 0;
  arv_fake_camera_read_register(camera, address, &value);
  return value;
}

}  // namespace

namespace detail {

std::string servedDeviceId(const GvCameraServerOptions& options) {
  return options.vendor + "-" + options.model + "-" + options.serial;
}

ServedCameraDevice::ServedCameraDevice(ArvFakeCamera* camera, const GvCameraServerOptions& options,
                                       ServedFrameFiller filler)
    : options_(options), filler_(std::move(filler)), camera_(camera) {
  // Identity and sensor size. Aravis's device thread answers from
  // arv_gv_fake_camera_new() on: a client that looks in this instant sees
  // Aravis's defaults; `lfi serve-camera` prints the device's id only after this.
  char name[kNameSize] = {};
  std::strncpy(name, options.vendor.c_str(), kNameSize - 1);
  arv_fake_camera_write_memory(camera, kManufacturerNameOffset, kNameSize, name);
  std::memset(name, 0, kNameSize);
  std::strncpy(name, options.model.c_str(), kNameSize - 1);
  arv_fake_camera_write_memory(camera, kModelNameOffset, kNameSize, name);
  const auto width = static_cast<guint32>(options.sensorWidth_px),
             height = static_cast<guint32>(options.sensorHeight_px);
  arv_fake_camera_write_register(camera, ARV_FAKE_CAMERA_REGISTER_SENSOR_WIDTH, width);
  arv_fake_camera_write_register(camera, ARV_FAKE_CAMERA_REGISTER_SENSOR_HEIGHT, height);
  arv_fake_camera_write_register(camera, ARV_FAKE_CAMERA_REGISTER_WIDTH, width);
  arv_fake_camera_write_register(camera, ARV_FAKE_CAMERA_REGISTER_HEIGHT, height);
  arv_fake_camera_write_register(camera, kHeartbeatTimeoutOffset, kHeartbeatTimeout_ms);
  // In trigger mode the device looks for a software trigger once per period
  // of this rate (Aravis's default, 25 Hz, adds 20 ms to each triggered frame
  // on average). Its loop waits in whole milliseconds and spins through the
  // last one of each period: at 1 kHz it would spin all the time and take the
  // CPU its client needs (on 2 cores the frame then reaches the client no sooner).
  arv_fake_camera_set_trigger_frequency(camera, kTriggerCheckRate_hz);
  published_.store(true, std::memory_order_release);
  arv_fake_camera_set_fill_pattern(camera, &ServedCameraDevice::fill, this);
}

// Inside Aravis's fill-pattern callback arv_buffer_get_data() reports size 0
// (the buffer's parts are not set up yet); the pointer is valid and holds the
// payload, so the size comes from the registers.
void ServedCameraDevice::fill(ArvBuffer* buffer, void* data, guint32 exposure_us, guint32 gain, ArvPixelFormat format) {
  auto* self = static_cast<ServedCameraDevice*>(data);
  self->published_.load(std::memory_order_acquire);
  if (buffer == nullptr) return;
  void* pixels = const_cast<void*>(arv_buffer_get_data(buffer, nullptr));
  if (pixels == nullptr) return;
  // The registers as a client left them. GVCP lets a client write any value
  // (GenICam's ranges are the client's courtesy): an image that would not
  // fit the sensor, or the buffer Aravis allocated for the payload it computes
  // from the same registers, is not written at all.
  ArvFakeCamera* camera = self->camera_;
  const std::uint64_t width = readRegister(camera, ARV_FAKE_CAMERA_REGISTER_WIDTH),
                      height = readRegister(camera, ARV_FAKE_CAMERA_REGISTER_HEIGHT),
                      binning = readRegister(camera, ARV_FAKE_CAMERA_REGISTER_BINNING_HORIZONTAL),
                      binningY = readRegister(camera, ARV_FAKE_CAMERA_REGISTER_BINNING_VERTICAL);
  const std::uint64_t bytesPerPixel = (ARV_PIXEL_FORMAT_BIT_PER_PIXEL(format) + 7) / 8;
  const std::uint64_t size = width * height * bytesPerPixel;
  const auto& o = self->options_;
  if (width < 1 || height < 1 || width > static_cast<std::uint64_t>(o.sensorWidth_px) ||
      height > static_cast<std::uint64_t>(o.sensorHeight_px) || size > arv_fake_camera_get_payload(camera)) {
    self->warnOnce(
        fmt::format("a {} x {} image of {} bytes a pixel does not fit the {} x {} sensor or the "
                    "payload; the frame is not written",
                    width, height, bytesPerPixel, o.sensorWidth_px, o.sensorHeight_px));
    // A black frame, not the buffer's earlier contents: Aravis sends it as complete whatever we do. (It checked
    // the buffer holds this payload before the call, on this same thread, the one that takes register writes.)
    std::memset(pixels, 0, arv_fake_camera_get_payload(camera));
    return;
  }
  std::memset(pixels, 0, static_cast<std::size_t>(size));
  ServedFrameRequest request;
  request.frameId = arv_buffer_get_frame_id(buffer);
  request.width_px = static_cast<int>(width);
  request.height_px = static_cast<int>(height);
  request.offsetX_px = static_cast<int>(readRegister(camera, ARV_FAKE_CAMERA_REGISTER_X_OFFSET));
  request.offsetY_px = static_cast<int>(readRegister(camera, ARV_FAKE_CAMERA_REGISTER_Y_OFFSET));
  request.binning = static_cast<int>(binning);
  request.exposure_us = exposure_us;
  request.gain = gain;
  int type = CV_8UC1;
  if (format == ARV_PIXEL_FORMAT_MONO_8) {
    request.pixelFormat = PixelFormat::Mono8;
  } else if (format == ARV_PIXEL_FORMAT_MONO_16) {
    request.pixelFormat = PixelFormat::Mono16;
    type = CV_16UC1;
  }
  if (!request.pixelFormat) {
    self->warnOnce(fmt::format("pixel format 0x{:08x} is not served (Mono8, Mono16); frames are black",
                               static_cast<std::uint32_t>(format)));
    return;
  }
  if (binningY != binning) {
    self->warnOnce(
        fmt::format("binning {} x {} (horizontal x vertical) is not served, only equal ones; frames "
                    "are black",
                    binning, binningY));
    return;
  }
  try {
    cv::Mat image(request.height_px, request.width_px, type, pixels);
    self->filler_(request, image);
    self->lastWarning_.clear();        // a frame as asked: the next refusal is news again
  } catch (const std::exception& e) {  // (the filler refused what the client asked: every frame alike)
    std::memset(pixels, 0, static_cast<std::size_t>(size));  // (it may have written part of the image)
    self->warnOnce(fmt::format("frames go out black: {}", e.what()));
  }
}

// A warning about what a client asked, once until it asks something else.
void ServedCameraDevice::warnOnce(const std::string& what) {
  if (what == lastWarning_) return;
  spdlog::warn("served camera '{}': {}", servedDeviceId(options_), what);
  lastWarning_ = what;
}

}  // namespace detail

struct GvCameraServer::Impl {
  GvCameraServerOptions options;
  ArvGvFakeCamera* gvCamera = nullptr;
  std::unique_ptr<detail::ServedCameraDevice> device;  // on gvCamera's camera
  std::mutex lineMutex;                                // one line edge at a time

  ArvFakeCamera* camera() const { return device->camera(); }
  std::string deviceId() const { return detail::servedDeviceId(options); }
};

namespace {

void requireIdentity(const GvCameraServerOptions& options) {
  if (options.serial.empty() || options.serial.size() >= 16)
    fail(Errc::InvalidArgument, "served camera: serial '{}' must have 1..15 characters", options.serial);
  if (options.vendor.empty() || options.vendor.size() >= kNameSize || options.model.empty() ||
      options.model.size() >= kNameSize)
    fail(Errc::InvalidArgument, "served camera: vendor '{}' and model '{}' must have 1..31 characters", options.vendor,
         options.model);
}

void requireInterface(const std::string& interfaceAddress) {
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0)
    fail(Errc::Device, "served camera: the host's network interfaces cannot be listed: {}", std::strerror(errno));
  // Aravis serves on an interface that is up, not point-to-point, with an
  // IPv4 address (arv_enumerate_network_interfaces), named or by address.
  std::string usable, why;
  bool found = false;
  for (const ifaddrs* i = list; i != nullptr; i = i->ifa_next) {
    const bool ipv4 = i->ifa_addr != nullptr && i->ifa_addr->sa_family == AF_INET;
    char address[INET_ADDRSTRLEN] = {};
    if (ipv4) inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr, address, sizeof address);
    const bool named = interfaceAddress == i->ifa_name || (ipv4 && interfaceAddress == address);
    const bool up = (i->ifa_flags & IFF_UP) != 0, pointToPoint = (i->ifa_flags & IFF_POINTOPOINT) != 0;
    if (ipv4 && up && !pointToPoint) {
      found = found || named;
      usable += fmt::format("{}{} {}", usable.empty() ? "" : ", ", i->ifa_name, address);
    } else if (named && why.empty() && (ipv4 || !up)) {
      why = !up ? "it is down" : "it is a point-to-point link";
    }
  }
  freeifaddrs(list);
  if (found) return;
  if (why.empty()) why = "it is neither a network interface with an IPv4 address nor such an address of one";
  fail(Errc::InvalidArgument, "served camera: Aravis cannot serve on '{}': {} (usable here: {})", interfaceAddress, why,
       usable.empty() ? "none" : usable);
}

}  // namespace

void GvCameraServer::validate(const GvCameraServerOptions& options) {
  requireIdentity(options);
  requireInterface(options.interfaceAddress);
}

GvCameraServer::GvCameraServer(const GvCameraServerOptions& options, ServedFrameFiller filler)
    : impl_(std::make_unique<Impl>()) {
  requireIdentity(options);
  if (options.sensorWidth_px < 1 || options.sensorHeight_px < 1)
    fail(Errc::InvalidArgument, "served camera: sensor {} x {} px", options.sensorWidth_px, options.sensorHeight_px);
  if (!filler) fail(Errc::InvalidArgument, "served camera: no frame filler");
  impl_->options = options;

  impl_->gvCamera = arv_gv_fake_camera_new_full(options.interfaceAddress.c_str(), options.serial.c_str(),
                                                servedGenicamFile().c_str());
  if (impl_->gvCamera == nullptr || !arv_gv_fake_camera_is_running(impl_->gvCamera)) {
    if (impl_->gvCamera != nullptr) g_object_unref(impl_->gvCamera);
    fail(Errc::Device,
         "served camera '{}': Aravis could not serve on '{}' (no such interface, or UDP port 3956 is taken by "
         "another GigE Vision device on it)",
         impl_->deviceId(), options.interfaceAddress);
  }
  impl_->device = std::make_unique<detail::ServedCameraDevice>(arv_gv_fake_camera_get_fake_camera(impl_->gvCamera),
                                                               options, std::move(filler));
}

GvCameraServer::~GvCameraServer() {
  // Stops and joins Aravis's device thread, which may fill one more frame on
  // its way out: with the filler, alive until the join (no NULL fill pattern
  // first: Aravis would send that frame as its diagonal test ramp).
  if (impl_ && impl_->gvCamera != nullptr) g_object_unref(impl_->gvCamera);
}

std::string GvCameraServer::deviceId() const {
  return impl_->deviceId();
}

CameraSettings ServedFrameRequest::settings() const {
  CameraSettings s;
  s.exposure_us = exposure_us;
  s.gain = gain;
  s.pixelFormat = pixelFormat.value();
  s.binning = binning;
  s.roiX_px = offsetX_px;
  s.roiY_px = offsetY_px;
  s.roiWidth_px = width_px;
  s.roiHeight_px = height_px;
  return s;
}

void writeServedFrame(const cv::Mat& frame, cv::Mat& image) {
  if (frame.size() != image.size() || frame.type() != image.type())
    fail(Errc::Device, "the frame made is {} x {} (type {}), the buffer {} x {} (type {})", frame.cols, frame.rows,
         frame.type(), image.cols, image.rows, image.type());
  frame.copyTo(image);
}

bool GvCameraServer::fireLine(int timeout_ms) {
  std::lock_guard lock(impl_->lineMutex);
  ArvFakeCamera* camera = impl_->camera();
  constexpr guint32 kLine0 = 0, kSoftware = 1;  // TriggerSource values in Aravis's fake camera description
  if (readRegister(camera, ARV_FAKE_CAMERA_REGISTER_TRIGGER_MODE) != 1 ||
      readRegister(camera, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOURCE) != kLine0 ||
      arv_fake_camera_get_acquisition_status(camera) == 0)
    return false;
  arv_fake_camera_write_register(camera, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOURCE, kSoftware);
  arv_fake_camera_write_register(camera, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE, 1);
  // The device thread clears the trigger register when it takes the trigger, before it makes the frame.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  bool taken = false;
  while (!(taken = readRegister(camera, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE) == 0) &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  if (!taken) arv_fake_camera_write_register(camera, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE, 0);
  // (unless the client changed the source meanwhile)
  if (readRegister(camera, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOURCE) == kSoftware)
    arv_fake_camera_write_register(camera, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOURCE, kLine0);
  return taken;
}

bool GvCameraServer::userOutput(int index) const {
  if (index < 0 || index > 2)
    fail(Errc::InvalidArgument, "served camera '{}': it has UserOutput0 to UserOutput2, not {}", impl_->deviceId(),
         index);
  return readRegister(impl_->camera(), detail::kUserOutputValueRegister + 4 * static_cast<guint32>(index)) != 0;
}

std::string GvCameraServer::lineSource(int line) const {
  if (line < 0 || line > 2)
    fail(Errc::InvalidArgument, "served camera '{}': it has Line0 to Line2, not {}", impl_->deviceId(), line);
  const guint32 mode = readRegister(impl_->camera(), detail::kLineModeRegister + 4 * static_cast<guint32>(line));
  const guint32 source = readRegister(impl_->camera(), detail::kLineSourceRegister + 4 * static_cast<guint32>(line));
  if (mode != 1) return "Input";
  return source == 0 ? "Off" : "UserOutput" + std::to_string(source - 1);
}

void GvCameraServer::setPacketLoss(double ratio) {
  if (!(ratio >= 0 && ratio <= 1))
    fail(Errc::InvalidArgument, "served camera '{}': packet loss {} is outside 0..1", impl_->deviceId(), ratio);
  g_object_set(impl_->gvCamera, "gvsp-lost-ratio", ratio, nullptr);
}

}  // namespace lfi::emulation
