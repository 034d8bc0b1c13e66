// The Aravis backend (aravis_camera.h). Every Aravis call that takes a GError is
// checked; failures become lfi::Error naming the device and the call. Aravis's
// process-wide device list is not thread-safe, so discovery and opening are
// serialised by one mutex.

#include "lfi/drivers/aravis/aravis_camera.h"

#include "lfi/core/error.h"
#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/pixel_unpack.h"

#include <arpa/inet.h>
#include <arv.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <optional>
#include <utility>

namespace lfi {
namespace {

// Not in Aravis 0.8's arvenums.h; PFNC value.
constexpr ArvPixelFormat kPixelFormatMono12p = 0x010C0047u;

// The wire formats that give each of our pixel formats, in order of
// preference: GenICam name and PFNC code.
struct WireFormat {
  const char* name;
  ArvPixelFormat code;
};
std::vector<WireFormat> wireFormats(PixelFormat format) {
  switch (format) {
    case PixelFormat::Mono8: return {{"Mono8", ARV_PIXEL_FORMAT_MONO_8}};
    case PixelFormat::Mono12:
      return {{"Mono12", ARV_PIXEL_FORMAT_MONO_12},
              {"Mono12p", kPixelFormatMono12p},
              {"Mono12Packed", ARV_PIXEL_FORMAT_MONO_12_PACKED}};
    case PixelFormat::Mono16: return {{"Mono16", ARV_PIXEL_FORMAT_MONO_16}};
  }
  return {};
}
std::vector<std::string> wireFormatNames(PixelFormat format) {
  std::vector<std::string> names;
  for (const WireFormat& w : wireFormats(format)) names.emplace_back(w.name);
  return names;
}
// The fewest bits per pixel any of them takes.
unsigned bitsOnTheWire(PixelFormat format) {
  return format == PixelFormat::Mono8 ? 8 : format == PixelFormat::Mono12 ? 12 : 16;
}

std::mutex& aravisMutex() {
  static std::mutex mutex;
  return mutex;
}

std::string orEmpty(const char* s) {
  return s != nullptr ? std::string(s) : std::string();
}

Errc errcFor(const GError* error) {
  if (error->domain == ARV_GC_ERROR) {
    if (error->code == ARV_GC_ERROR_NODE_NOT_FOUND || error->code == ARV_GC_ERROR_ENUM_ENTRY_NOT_FOUND)
      return Errc::NotFound;
    if (error->code == ARV_GC_ERROR_OUT_OF_RANGE || error->code == ARV_GC_ERROR_READ_ONLY ||
        error->code == ARV_GC_ERROR_SET_FROM_STRING_UNDEFINED || error->code == ARV_GC_ERROR_INVALID_SYNTAX)
      return Errc::InvalidArgument;
  }
  if (error->domain == ARV_DEVICE_ERROR && error->code == ARV_DEVICE_ERROR_FEATURE_NOT_FOUND) return Errc::NotFound;
  return Errc::Device;
}

// Throws if `error` is set, freeing it. `call` names the Aravis function (and feature).
void check(GError* error, const std::string& device, const std::string& call) {
  if (error == nullptr) return;
  const Errc code = errcFor(error);
  const std::string message = orEmpty(error->message);
  g_error_free(error);
  fail(code, "camera '{}': {} failed: {}", device, call, message);
}

// Aravis's device list; `update` runs discovery first. Lock held.
std::vector<AravisDeviceInfo> listDevicesLocked(bool update) {
  if (update) arv_update_device_list();
  std::vector<AravisDeviceInfo> devices;
  const unsigned count = arv_get_n_devices();
  for (unsigned i = 0; i < count; ++i)
    devices.push_back({
        .id = orEmpty(arv_get_device_id(i)),
        .physicalId = orEmpty(arv_get_device_physical_id(i)),
        .address = orEmpty(arv_get_device_address(i)),
        .vendor = orEmpty(arv_get_device_vendor(i)),
        .model = orEmpty(arv_get_device_model(i)),
        .serial = orEmpty(arv_get_device_serial_nbr(i)),
        .protocol = orEmpty(arv_get_device_protocol(i)),
    });
  return devices;
}

// Whether `id` is in Aravis's cached device list (no discovery). Lock held.
bool knownToAravis(const std::string& id) {
  const unsigned count = arv_get_n_devices();
  for (unsigned i = 0; i < count; ++i)
    if (orEmpty(arv_get_device_id(i)) == id) return true;
  return false;
}

// Discovery is a UDP broadcast answered within Aravis's fixed wait: on a loaded
// host or network an answer can miss a round. Up to two rounds, until `id` (any
// device when empty) is listed; returns whether it is. Lock held.
bool discoverLocked(const std::string& id) {
  constexpr int kRounds = 2;
  for (int round = 0; round < kRounds; ++round) {
    arv_update_device_list();
    if (id.empty() ? arv_get_n_devices() > 0 : knownToAravis(id)) return true;
  }
  return false;
}

bool isIpv4Address(const std::string& text) {
  in_addr address{};
  return ::inet_pton(AF_INET, text.c_str(), &address) == 1;
}

std::string describe(const std::vector<AravisDeviceInfo>& devices) {
  if (devices.empty()) return "no devices found";
  std::string text = "devices found:";
  for (const AravisDeviceInfo& d : devices) text += fmt::format(" '{}' ({} at {})", d.id, d.protocol, d.address);
  return text;
}

// One of this host's own IPv4 addresses (any of 127/8 included).
bool isOwnAddress(GInetAddress* address) {
  if (g_inet_address_get_family(address) != G_SOCKET_FAMILY_IPV4) return false;
  if (g_inet_address_get_is_loopback(address)) return true;
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return false;
  bool own = false;
  for (const ifaddrs* a = list; a != nullptr && !own; a = a->ifa_next) {
    if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET) continue;
    const auto* in = reinterpret_cast<const sockaddr_in*>(a->ifa_addr);
    own = std::memcmp(&in->sin_addr, g_inet_address_to_bytes(address), sizeof in->sin_addr) == 0;
  }
  ::freeifaddrs(list);
  return own;
}

// A GigE Vision device at one of this host's own addresses (a served camera, a
// simulator) sends its stream through the loopback interface, whatever the
// address. With CAP_NET_RAW (root, as in CI) Aravis receives streams on a
// packet socket bound to the interface it found the device through. When that
// is not loopback (the device serves on eth0's address, or its discovery answer
// came back through eth0) the socket never sees a packet: control works and no
// frame ever arrives. Such a camera is replaced by one reaching the same device
// through 127.0.0.1, which works with either kind of socket.
ArvCamera* throughLoopbackIfOwnAddress(ArvCamera* camera, const std::string& name) {
  if (!arv_camera_is_gv_device(camera)) return camera;
  ArvGvDevice* gv = ARV_GV_DEVICE(arv_camera_get_device(camera));
  GSocketAddress* device = arv_gv_device_get_device_address(gv);
  GSocketAddress* interface = arv_gv_device_get_interface_address(gv);
  if (!G_IS_INET_SOCKET_ADDRESS(device) || !G_IS_INET_SOCKET_ADDRESS(interface)) return camera;
  GInetAddress* deviceIp = g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(device));
  GInetAddress* interfaceIp = g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(interface));
  if (g_inet_address_get_is_loopback(interfaceIp) || !isOwnAddress(deviceIp)) return camera;
  GInetAddress* loopback = g_inet_address_new_loopback(G_SOCKET_FAMILY_IPV4);
  g_object_ref(deviceIp);
  gchar* ip = g_inet_address_to_string(deviceIp);
  const std::string deviceIpText = ip != nullptr ? ip : "";
  g_free(ip);
  g_object_unref(camera);  // gives the control channel back before the new device asks for it
  GError* error = nullptr;
  ArvDevice* throughLoopback = arv_gv_device_new(loopback, deviceIp, &error);
  g_object_unref(loopback);
  g_object_unref(deviceIp);
  ArvCamera* replaced = throughLoopback != nullptr ? arv_camera_new_with_device(throughLoopback, &error) : nullptr;
  if (throughLoopback != nullptr) g_object_unref(throughLoopback);  // the camera holds its own reference
  if (replaced == nullptr) {
    const std::string message = error != nullptr ? error->message : "no error message";
    if (error != nullptr) g_error_free(error);
    fail(Errc::Device, "camera '{}': reaching the device at this host's address {} through 127.0.0.1 failed: {}", name,
         deviceIpText, message);
  }
  spdlog::debug("camera '{}': device at this host's address {}: reached through 127.0.0.1", name, deviceIpText);
  return replaced;
}

// Asks a GigE Vision device for its control channel privilege register over a
// separate GVCP socket. Aravis's own register reads retry 5 × 500 ms; this one
// gives up after `tries` × `timeout_ms`. Any answer, even an error ack, means
// the device is there.
bool gvcpDeviceAnswers(const std::string& ip, std::uint16_t port, int tries, int timeout_ms) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return true;  // cannot tell; do not declare the device lost
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(port);
  if (::inet_pton(AF_INET, ip.c_str(), &address.sin_addr) != 1 ||
      ::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return true;
  }
  bool answered = false;
  for (int attempt = 0; attempt < tries && !answered; ++attempt) {
    const std::uint16_t requestId = static_cast<std::uint16_t>(0x7a00 + attempt);
    // GVCP READREG_CMD: key 0x42, flags (ack required), command 0x0080, length 4, request id, address 0x0A00.
    const std::uint8_t packet[12] = {0x42,
                                     0x01,
                                     0x00,
                                     0x80,
                                     0x00,
                                     0x04,
                                     static_cast<std::uint8_t>(requestId >> 8),
                                     static_cast<std::uint8_t>(requestId & 0xff),
                                     0x00,
                                     0x00,
                                     0x0a,
                                     0x00};
    if (::send(fd, packet, sizeof packet, 0) < 0) {
      if (errno == ECONNREFUSED) break;  // ICMP port unreachable: nobody listens there any more
      continue;
    }
    pollfd pfd{.fd = fd, .events = POLLIN, .revents = 0};
    if (::poll(&pfd, 1, timeout_ms) <= 0) continue;
    std::uint8_t reply[64];
    const ssize_t n = ::recv(fd, reply, sizeof reply, 0);
    if (n < 0 && errno == ECONNREFUSED) break;
    answered = n >= 8 && reply[2] == 0x00 && reply[3] == 0x81;
  }
  ::close(fd);
  return answered;
}

class AravisCamera final : public Camera {
 public:
  AravisCamera(std::string deviceId, AravisOptions options) : deviceId_(std::move(deviceId)), options_(options) {
    open();
  }

  ~AravisCamera() override { close(); }

  State state() const override { return state_; }

  void open() override {
    requireCameraState(state_, {State::Closed}, "open", name());
    releaseDevice();
    {
      std::lock_guard lock(aravisMutex());
      // Opening an id Aravis has not discovered yet takes a shortcut that can bind the
      // device to the wrong network interface (seen on loopback: control works, the
      // stream goes nowhere). A full discovery first gives the right one.
      // "The first camera found" is found once and kept by its id: info(), the
      // messages and a reopen after a loss then name this camera, not whichever
      // comes first at the time.
      if (deviceId_.empty()) {
        if (!discoverLocked("")) fail(Errc::NotFound, "camera '{}': no devices found", name());
        deviceId_ = listDevicesLocked(false).front().id;
      }
      const bool discovered = !isIpv4Address(deviceId_) && !knownToAravis(deviceId_);
      if (discovered) discoverLocked(deviceId_);
      GError* error = nullptr;
      camera_ = arv_camera_new(deviceId_.c_str(), &error);
      if (camera_ == nullptr) {
        const std::string message = error != nullptr ? orEmpty(error->message) : std::string("no error message");
        const bool notFound = error == nullptr || g_error_matches(error, ARV_DEVICE_ERROR, ARV_DEVICE_ERROR_NOT_FOUND);
        if (error != nullptr) g_error_free(error);
        const auto devices = listDevicesLocked(!discovered || arv_get_n_devices() == 0);
        fail(notFound ? Errc::NotFound : Errc::Device, "camera '{}': arv_camera_new failed: {}; {}", name(), message,
             describe(devices));
      }
      camera_ = throughLoopbackIfOwnAddress(std::exchange(camera_, nullptr), name());
    }
    try {
      connectDevice();
    } catch (...) {
      releaseDevice();
      throw;
    }
    state_ = State::Open;
    spdlog::debug("camera '{}': opened {} {} serial {}", name(), info_.vendor, info_.model, info_.serial);
  }

  void close() noexcept override {
    if (state_ == State::Streaming && !lost_) {
      GError* error = nullptr;
      arv_camera_stop_acquisition(camera_, &error);
      if (error != nullptr) {
        spdlog::warn("camera '{}': arv_camera_stop_acquisition failed while closing: {}", name(), error->message);
        g_error_free(error);
      }
    }
    releaseDevice();
    state_ = State::Closed;
  }

  CameraInfo info() const override {
    requireCameraState(state_, {State::Open, State::Configured, State::Streaming}, "info", name());
    return info_;
  }

  void configure(const CameraSettings& s) override {
    requireCameraState(state_, {State::Open, State::Configured}, "configure", name());
    state_ = State::Open;  // until every field is applied
    requireSaneSettings(s, name());
    onDevice([&] { apply(s); });
    settings_ = s;
    state_ = State::Configured;
  }

  // Sets every field of `s` on the device (configure()).
  void apply(const CameraSettings& s) {
    applyPixelFormat(s.pixelFormat);
    applyBinning(s.binning);
    applyRegion(s);
    // SFNC leaves open how ExposureTime and AcquisitionFrameRate bound each
    // other; many devices keep the exposure within the frame period and the
    // rate under 1 / exposure. An exposure past what the current period allows
    // needs the new rate first; otherwise the exposure goes first, which opens
    // the higher rates.
    if (s.trigger != TriggerMode::FreeRun)
      setFrameRateCap(false);
    else if (setsFrameRate(s))
      setFrameRateCap(true);
    const bool rateFirst = setsFrameRate(s) && s.exposure_us > exposureBounds().second;
    if (rateFirst) applyFrameRate(s);
    applyExposureAndGain(s);
    if (!rateFirst) applyFrameRate(s);
    applyTrigger(s);
  }

  CameraSettings settings() const override {
    requireCameraState(state_, {State::Configured, State::Streaming}, "settings", name());
    CameraSettings s = settings_;
    GError* error = nullptr;
    s.exposure_us = arv_camera_get_exposure_time(camera_, &error);
    check(error, name(), "arv_camera_get_exposure_time");
    if (arv_camera_is_gain_available(camera_, nullptr)) {
      s.gain = arv_camera_get_gain(camera_, &error);
      check(error, name(), "arv_camera_get_gain");
    }
    int dx = 1, dy = 1;
    if (arv_camera_is_binning_available(camera_, nullptr)) {
      arv_camera_get_binning(camera_, &dx, &dy, &error);
      check(error, name(), "arv_camera_get_binning");
    }
    s.binning = dx;
    arv_camera_get_region(camera_, &s.roiX_px, &s.roiY_px, &s.roiWidth_px, &s.roiHeight_px, &error);
    check(error, name(), "arv_camera_get_region");
    if (s.trigger == TriggerMode::FreeRun && arv_camera_is_frame_rate_available(camera_, nullptr)) {
      s.frameRate_hz = arv_camera_get_frame_rate(camera_, &error);
      check(error, name(), "arv_camera_get_frame_rate");
    }
    // What the device says must be settings at all (the controller sizes its waits by the exposure).
    try {
      requireSaneSettings(s, name());
    } catch (const Error& e) {
      fail(Errc::Device, "{} (as the device reports it)", e.what());
    }
    return s;
  }

  void start(int bufferCount) override {
    requireCameraState(state_, {State::Configured}, "start", name());
    if (bufferCount < 1 || bufferCount > 1024)
      fail(Errc::InvalidArgument, "camera '{}': start(bufferCount = {}) needs 1..1024 buffers", name(), bufferCount);
    onDevice([&] { startStream(bufferCount); });
  }

  // start() on the device: the stream, its buffers, the acquisition.
  void startStream(int bufferCount) {
    GError* error = nullptr;
    if (arv_camera_is_gv_device(camera_)) {
      ArvGvDevice* gv = ARV_GV_DEVICE(arv_camera_get_device(camera_));
      // We negotiate (or fix) the packet size here; Aravis must not redo it at stream creation.
      arv_gv_device_set_packet_size_adjustment(gv, ARV_GV_PACKET_SIZE_ADJUSTMENT_NEVER);
      if (options_.packetSize_bytes) {
        arv_camera_gv_set_packet_size(camera_, *options_.packetSize_bytes, &error);
        check(error, name(), fmt::format("arv_camera_gv_set_packet_size({})", *options_.packetSize_bytes));
      } else {
        const unsigned size = arv_camera_gv_auto_packet_size(camera_, &error);
        check(error, name(), "arv_camera_gv_auto_packet_size");
        spdlog::debug("camera '{}': GigE Vision packet size {} bytes", name(), size);
      }
    }
    stream_ = arv_camera_create_stream(camera_, nullptr, nullptr, &error);
    if (stream_ == nullptr) {
      if (error == nullptr) fail(Errc::Device, "camera '{}': arv_camera_create_stream returned no stream", name());
      check(error, name(), "arv_camera_create_stream");
    }
    if (ARV_IS_GV_STREAM(stream_)) g_object_set(stream_, "packet-resend", ARV_GV_STREAM_PACKET_RESEND_ALWAYS, nullptr);
    const unsigned payload = arv_camera_get_payload(camera_, &error);
    if (error != nullptr) {
      g_clear_object(&stream_);
      check(error, name(), "arv_camera_get_payload");
    }
    // The device's PayloadSize sizes every buffer: it must hold the image the
    // camera is configured for, and an absurd one must not reach g_malloc
    // (which aborts the process when it fails). Chunk data may add a little.
    int width = 0, height = 0;
    arv_camera_get_region(camera_, nullptr, nullptr, &width, &height, &error);
    if (error != nullptr) {
      g_clear_object(&stream_);
      check(error, name(), "arv_camera_get_region");
    }
    if (width <= 0 || height <= 0 || width > info_.sensorWidth_px || height > info_.sensorHeight_px) {
      g_clear_object(&stream_);  // (nonsense: no frame would fit, or the buffers would be absurd)
      fail(Errc::Device, "camera '{}': the device reports a {} x {} px region on its {} x {} px sensor", name(),
           width, height, info_.sensorWidth_px, info_.sensorHeight_px);
    }
    const std::uint64_t image = static_cast<std::uint64_t>(std::max(width, 0)) * static_cast<std::uint64_t>(
        std::max(height, 0)) * bitsOnTheWire(settings_.pixelFormat) / 8;
    if (const std::uint64_t most = 4 * image + (16u << 20); payload < image || payload > most) {
      g_clear_object(&stream_);
      fail(Errc::Device, "camera '{}': the device's PayloadSize of {} bytes does not fit its {} x {} px {} image "
           "({} to {} bytes)", name(), payload, width, height, toString(settings_.pixelFormat), image, most);
    }
    for (int i = 0; i < bufferCount; ++i) arv_stream_push_buffer(stream_, arv_buffer_new_allocate(payload));
    arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
    const char* call = "arv_camera_set_acquisition_mode";
    if (error == nullptr) arv_camera_start_acquisition(camera_, &error), call = "arv_camera_start_acquisition";
    if (error != nullptr) {
      g_clear_object(&stream_);
      check(error, name(), call);
    }
    statistics_ = {};
    frameWidth_ = width, frameHeight_ = height;
    state_ = State::Streaming;
  }

  void stop() override {
    requireCameraState(state_, {State::Streaming}, "stop", name());
    statistics_ = readStatistics();
    GError* error = nullptr;
    arv_camera_stop_acquisition(camera_, &error);
    if (error != nullptr && !deviceAnswers()) {  // gone: Closed, as when a grab finds it gone
      g_error_free(error);
      declareLost("it did not answer AcquisitionStop");
    }
    g_clear_object(&stream_);
    state_ = State::Configured;
    check(error, name(), "arv_camera_stop_acquisition");
  }

  void softwareTrigger() override {
    requireCameraState(state_, {State::Streaming}, "softwareTrigger", name());
    if (settings_.trigger != TriggerMode::Software)
      fail(Errc::InvalidArgument, "camera '{}': softwareTrigger() needs TriggerMode::Software, the camera is in {}",
           name(), toString(settings_.trigger));
    onDevice([&] {
      GError* error = nullptr;
      arv_camera_software_trigger(camera_, &error);
      check(error, name(), "arv_camera_software_trigger");
    });
  }

  void grabInto(Frame& frame, std::chrono::milliseconds timeout) override {
    requireCameraState(state_, {State::Streaming}, "grab", name());
    timeout = checkedGrabTimeout(timeout, name());
    // In slices, so that a lost control channel (the device stops streaming for
    // good) ends the wait at once instead of after the whole timeout.
    constexpr std::chrono::milliseconds kSlice{250};
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    ArvBuffer* buffer = nullptr;
    for (;;) {
      if (controlLost_) declareLost("Aravis reported the control channel lost (heartbeat)");
      const auto left =
          std::chrono::duration_cast<std::chrono::microseconds>(deadline - std::chrono::steady_clock::now());
      const auto wait = std::clamp(left, std::chrono::microseconds(0), std::chrono::microseconds(kSlice));
      buffer = arv_stream_timeout_pop_buffer(stream_, static_cast<guint64>(wait.count()));
      if (buffer != nullptr || left <= kSlice) break;
    }
    if (buffer == nullptr) {
      if (controlLost_) declareLost("Aravis reported the control channel lost (heartbeat)");
      frame.status = FrameStatus::Timeout;
      frame.frameId = 0;
      frame.timestamp_ns = 0;
      if (!deviceAnswers())
        declareLost(fmt::format("no frame for {} ms and the device does not answer control requests", timeout.count()));
      return;
    }
    // The buffer goes back to the pool whatever happens below.
    struct PushBack {
      ArvStream* stream;
      ArvBuffer* buffer;
      ~PushBack() { arv_stream_push_buffer(stream, buffer); }
    } pushBack{stream_, buffer};

    const ArvBufferStatus status = arv_buffer_get_status(buffer);
    frame.frameId = arv_buffer_get_frame_id(buffer);
    frame.timestamp_ns = arv_buffer_get_timestamp(buffer);
    if (frame.timestamp_ns == 0) frame.timestamp_ns = arv_buffer_get_system_timestamp(buffer);
    frame.status = status == ARV_BUFFER_STATUS_SUCCESS ? FrameStatus::Complete : FrameStatus::Incomplete;
    if (const auto refused = copyImage(buffer, frame.image)) {
      if (frame.status == FrameStatus::Complete)
        fail(Errc::Device, "camera '{}': frame {} is complete but {}", name(), frame.frameId, *refused);
      frame.image.release();
    }
  }

  StreamStatistics statistics() const override {
    requireCameraState(state_, {State::Configured, State::Streaming}, "statistics", name());
    return state_ == State::Streaming ? readStatistics() : statistics_;
  }

  std::string getFeature(const std::string& feature) override {
    ArvGcFeatureNode* node = featureNode("getFeature", feature);
    return onDevice([&] {
      GError* error = nullptr;
      const char* value = arv_gc_feature_node_get_value_as_string(node, &error);
      check(error, name(), fmt::format("reading feature '{}'", feature));
      return orEmpty(value);
    });
  }

  void setFeature(const std::string& feature, const std::string& value) override {
    ArvGcFeatureNode* node = featureNode("setFeature", feature);
    onDevice([&] {
      GError* error = nullptr;
      arv_gc_feature_node_set_value_from_string(node, value.c_str(), &error);
      check(error, name(), fmt::format("setting feature '{}' to '{}'", feature, value));
    });
  }

  std::int64_t getIntegerFeature(const std::string& feature) override {
    featureNode("getIntegerFeature", feature);
    return onDevice([&] {
      GError* error = nullptr;
      const gint64 value = arv_camera_get_integer(camera_, feature.c_str(), &error);
      check(error, name(), fmt::format("reading integer feature '{}'", feature));
      return value;
    });
  }

  void setIntegerFeature(const std::string& feature, std::int64_t value) override {
    featureNode("setIntegerFeature", feature);
    onDevice([&] {
      GError* error = nullptr;
      arv_camera_set_integer(camera_, feature.c_str(), value, &error);
      check(error, name(), fmt::format("setting integer feature '{}' to {}", feature, value));
    });
  }

  double getFloatFeature(const std::string& feature) override {
    featureNode("getFloatFeature", feature);
    return onDevice([&] {
      GError* error = nullptr;
      const double value = arv_camera_get_float(camera_, feature.c_str(), &error);
      check(error, name(), fmt::format("reading float feature '{}'", feature));
      return value;
    });
  }

  void setFloatFeature(const std::string& feature, double value) override {
    featureNode("setFloatFeature", feature);
    onDevice([&] {
      GError* error = nullptr;
      arv_camera_set_float(camera_, feature.c_str(), value, &error);
      check(error, name(), fmt::format("setting float feature '{}' to {}", feature, value));
    });
  }

  void executeCommand(const std::string& feature) override {
    featureNode("executeCommand", feature);
    GError* error = nullptr;
    arv_camera_execute_command(camera_, feature.c_str(), &error);
    check(error, name(), fmt::format("executing command '{}'", feature));
  }

 private:
  // Everything open() does once Aravis has a camera object.
  void connectDevice() {
    ArvDevice* device = arv_camera_get_device(camera_);
    // Out-of-range values must fail, not be written silently.
    arv_device_set_range_check_policy(device, ARV_RANGE_CHECK_POLICY_ENABLE);
    controlLost_ = false;
    gvcpIp_.clear();
    controlLostHandler_ = g_signal_connect(device, "control-lost", G_CALLBACK(onControlLost), &controlLost_);
    if (arv_camera_is_gv_device(camera_)) {
      GSocketAddress* socketAddress = arv_gv_device_get_device_address(ARV_GV_DEVICE(device));
      if (socketAddress != nullptr && G_IS_INET_SOCKET_ADDRESS(socketAddress)) {
        auto* inet = G_INET_SOCKET_ADDRESS(socketAddress);
        gchar* ip = g_inet_address_to_string(g_inet_socket_address_get_address(inet));
        gvcpIp_ = orEmpty(ip);
        g_free(ip);
        gvcpPort_ = g_inet_socket_address_get_port(inet);
      }
    }
    readInfo();
  }

  static void onControlLost(ArvDevice*, gpointer flag) { static_cast<std::atomic<bool>*>(flag)->store(true); }

  std::string name() const { return deviceId_.empty() ? std::string("(the first camera found)") : deviceId_; }

  void releaseDevice() noexcept {
    g_clear_object(&stream_);
    if (camera_ != nullptr) {
      // Aravis 0.8 retries its last GVCP writes to a device that is gone (or no longer takes them from us) 5 x
      // 500 ms each, with no way to shorten it: say why the program stops for a while.
      if (lost_) spdlog::warn("camera '{}': releasing the lost device; Aravis may take up to 10 s", name());
      if (controlLostHandler_ != 0) g_signal_handler_disconnect(arv_camera_get_device(camera_), controlLostHandler_);
      controlLostHandler_ = 0;
      g_clear_object(&camera_);
    }
    lost_ = false;
  }

  // The device is gone: the camera becomes Closed (open() may reconnect later).
  [[noreturn]] void declareLost(const std::string& why) {
    statistics_ = readStatistics();
    lost_ = true;
    const bool streaming = state_ == State::Streaming;
    state_ = State::Closed;
    fail(Errc::Device, "camera '{}': device lost{}: {}; the camera is closed, open() it again when it is back", name(),
         streaming ? " while streaming" : "", why);
  }

  // Runs a request to the device: a device error from a device that no longer
  // answers at all closes the camera (camera.h: a device that vanishes ends
  // in Closed), as a grab or stop() that finds it gone does.
  template <typename Call>
  auto onDevice(Call&& call) -> decltype(call()) {
    try {
      return call();
    } catch (const Error& e) {
      if (e.code() != Errc::Device || deviceAnswers()) throw;
      declareLost(fmt::format("{} (it does not answer control requests)", e.what()));
    }
  }

  bool deviceAnswers() {
    if (!gvcpIp_.empty()) return gvcpDeviceAnswers(gvcpIp_, gvcpPort_, 5, 200);
    guint32 value = 0;
    GError* error = nullptr;
    const bool ok = arv_device_read_register(arv_camera_get_device(camera_), 0, &value, &error);
    if (error != nullptr) g_error_free(error);
    return ok;
  }

  void readInfo() {
    GError* error = nullptr;
    info_ = {};
    info_.vendor = orEmpty(arv_camera_get_vendor_name(camera_, &error));
    check(error, name(), "arv_camera_get_vendor_name");
    info_.model = orEmpty(arv_camera_get_model_name(camera_, &error));
    check(error, name(), "arv_camera_get_model_name");
    info_.serial = orEmpty(arv_camera_get_device_serial_number(camera_, &error));
    check(error, name(), "arv_camera_get_device_serial_number");
    info_.deviceId = percentEncodeUriPart(deviceId_);  // (reopens it after "aravis:")
    readSensorSize();
    if (arv_camera_is_feature_available(camera_, "SensorPixelWidth", nullptr)) {
      const double pitch = arv_camera_get_float(camera_, "SensorPixelWidth", &error);
      check(error, name(), "reading feature 'SensorPixelWidth'");
      if (pitch > 0 && std::isfinite(pitch)) info_.pixelSize_um = pitch;  // else unknown, as when absent
    }
  }

  // SFNC only recommends SensorWidth and SensorHeight. Without them the sensor
  // is the largest image (WidthMax and HeightMax, else the bounds of Width and
  // Height) times the binning in force.
  void readSensorSize() {
    constexpr std::int64_t kMaxSide = 1 << 20;  // far beyond any sensor: a larger value is a misreading
    constexpr int kMaxBinning = 1 << 10;
    GError* error = nullptr;
    auto has = [&](const char* feature) { return arv_camera_is_feature_available(camera_, feature, nullptr) != FALSE; };
    auto integer = [&](const char* feature) {
      const gint64 value = arv_camera_get_integer(camera_, feature, &error);
      check(error, name(), fmt::format("reading feature '{}'", feature));
      return value;
    };
    std::int64_t width = 0, height = 0;
    if (has("SensorWidth") && has("SensorHeight")) {
      width = integer("SensorWidth"), height = integer("SensorHeight");
    } else {
      if (has("WidthMax") && has("HeightMax")) {
        width = integer("WidthMax"), height = integer("HeightMax");
      } else {
        int min = 0, w = 0, h = 0;
        arv_camera_get_width_bounds(camera_, &min, &w, &error);
        check(error, name(), "arv_camera_get_width_bounds");
        arv_camera_get_height_bounds(camera_, &min, &h, &error);
        check(error, name(), "arv_camera_get_height_bounds");
        width = w, height = h;
      }
      if (arv_camera_is_binning_available(camera_, nullptr)) {
        int bx = 1, by = 1;
        arv_camera_get_binning(camera_, &bx, &by, &error);
        check(error, name(), "arv_camera_get_binning");
        // (Checked before the product: a misread image size times the binning could wrap into range.)
        if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide || bx > kMaxBinning || by > kMaxBinning)
          fail(Errc::Device, "camera '{}': the device reports a {} x {} px image at binning {} x {}", name(), width,
               height, bx, by);
        width *= std::max(bx, 1), height *= std::max(by, 1);
      }
    }
    if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide)
      fail(Errc::Device, "camera '{}': the device reports a {} x {} px sensor", name(), width, height);
    info_.sensorWidth_px = static_cast<int>(width), info_.sensorHeight_px = static_cast<int>(height);
  }

  ArvGcFeatureNode* featureNode(const char* method, const std::string& feature) {
    requireCameraState(state_, {State::Open, State::Configured, State::Streaming}, method, name());
    ArvGcNode* node = arv_device_get_feature(arv_camera_get_device(camera_), feature.c_str());
    if (node == nullptr || !ARV_IS_GC_FEATURE_NODE(node))
      fail(Errc::NotFound, "camera '{}': {}('{}'): the device has no such feature", name(), method, feature);
    return ARV_GC_FEATURE_NODE(node);
  }

  std::vector<std::string> availablePixelFormats() const {
    GError* error = nullptr;
    guint count = 0;
    const char** formats = arv_camera_dup_available_pixel_formats_as_strings(camera_, &count, &error);
    check(error, name(), "arv_camera_dup_available_pixel_formats_as_strings");
    std::vector<std::string> result;
    for (guint i = 0; i < count; ++i) result.push_back(orEmpty(formats[i]));
    g_free(formats);
    return result;
  }

  void applyPixelFormat(PixelFormat format) {
    const std::vector<std::string> candidates = wireFormatNames(format);
    const std::vector<std::string> available = availablePixelFormats();
    for (const std::string& candidate : candidates) {
      if (std::find(available.begin(), available.end(), candidate) == available.end()) continue;
      GError* error = nullptr;
      arv_camera_set_pixel_format_from_string(camera_, candidate.c_str(), &error);
      check(error, name(), fmt::format("arv_camera_set_pixel_format_from_string('{}')", candidate));
      return;
    }
    fail(Errc::InvalidArgument, "camera '{}': pixelFormat {} needs one of {} on the wire; the device offers {}", name(),
         toString(format), fmt::join(candidates, ", "), fmt::join(available, ", "));
  }

  void applyBinning(int binning) {
    GError* error = nullptr;
    if (!arv_camera_is_binning_available(camera_, nullptr)) {
      if (binning != 1)
        fail(Errc::InvalidArgument, "camera '{}': binning {} asked, the device has no binning", name(), binning);
      return;
    }
    int min = 1, max = 1;
    arv_camera_get_x_binning_bounds(camera_, &min, &max, &error);
    check(error, name(), "arv_camera_get_x_binning_bounds");
    if (binning < min || binning > max)
      fail(Errc::InvalidArgument, "camera '{}': binning {} is outside the device's {}..{}", name(), binning, min, max);
    arv_camera_set_binning(camera_, binning, binning, &error);
    check(error, name(), fmt::format("arv_camera_set_binning({})", binning));
  }

  void checkIncrement(const char* field, int value, int increment, int min, int max) const {
    if (value < min || value > max)
      fail(Errc::InvalidArgument, "camera '{}': {} {} is outside the device's {}..{}", name(), field, value, min, max);
    if (increment > 1 && (value - min) % increment != 0)
      fail(Errc::InvalidArgument, "camera '{}': {} {} is not {} + a multiple of the device's increment {}", name(),
           field, value, min, increment);
  }

  void applyRegion(const CameraSettings& s) {
    GError* error = nullptr;
    // Offsets to 0 first so the full width/height range is open.
    if (arv_camera_is_region_offset_available(camera_, nullptr)) {
      arv_camera_set_integer(camera_, "OffsetX", 0, &error);
      check(error, name(), "setting OffsetX to 0");
      arv_camera_set_integer(camera_, "OffsetY", 0, &error);
      check(error, name(), "setting OffsetY to 0");
    } else if (s.roiX_px != 0 || s.roiY_px != 0) {
      fail(Errc::InvalidArgument, "camera '{}': ROI offset ({}, {}) asked, the device has no offsets", name(),
           s.roiX_px, s.roiY_px);
    }
    int wMin = 0, wMax = 0, hMin = 0, hMax = 0;
    arv_camera_get_width_bounds(camera_, &wMin, &wMax, &error);
    check(error, name(), "arv_camera_get_width_bounds");
    arv_camera_get_height_bounds(camera_, &hMin, &hMax, &error);
    check(error, name(), "arv_camera_get_height_bounds");
    // Binned, the image is at most the sensor over the binning: Aravis's fake camera (and some devices) keep the
    // Width and Height bounds of the unbinned sensor, so that "to the end" asked for more than there is.
    if (s.binning > 1 && info_.sensorWidth_px > 0 && info_.sensorHeight_px > 0) {
      wMax = std::min(wMax, info_.sensorWidth_px / s.binning);
      hMax = std::min(hMax, info_.sensorHeight_px / s.binning);
    }
    if (s.roiX_px >= wMax || s.roiY_px >= hMax)  // (before the sizes: a width past the sensor is the offset's fault)
      fail(Errc::InvalidArgument, "camera '{}': ROI offset ({}, {}) lies outside the {} x {} (binned) sensor",
           name(), s.roiX_px, s.roiY_px, wMax, hMax);
    const int width = s.roiWidth_px > 0 ? s.roiWidth_px : wMax - s.roiX_px;
    const int height = s.roiHeight_px > 0 ? s.roiHeight_px : hMax - s.roiY_px;
    checkIncrement("roiWidth_px", width, arv_camera_get_width_increment(camera_, nullptr), wMin, wMax);
    checkIncrement("roiHeight_px", height, arv_camera_get_height_increment(camera_, nullptr), hMin, hMax);
    if (std::int64_t{s.roiX_px} + width > wMax || std::int64_t{s.roiY_px} + height > hMax)
      fail(Errc::InvalidArgument, "camera '{}': ROI ({}, {}, {} x {}) does not fit the {} x {} (binned) sensor", name(),
           s.roiX_px, s.roiY_px, width, height, wMax, hMax);
    arv_camera_set_region(camera_, s.roiX_px, s.roiY_px, width, height, &error);
    check(error, name(), fmt::format("arv_camera_set_region({}, {}, {}, {})", s.roiX_px, s.roiY_px, width, height));
  }

  static bool setsFrameRate(const CameraSettings& s) { return s.trigger == TriggerMode::FreeRun && s.frameRate_hz > 0; }

  std::pair<double, double> exposureBounds() const {
    GError* error = nullptr;
    double min = 0, max = 0;
    arv_camera_get_exposure_time_bounds(camera_, &min, &max, &error);
    check(error, name(), "arv_camera_get_exposure_time_bounds");
    return {min, max};
  }

  void applyExposureAndGain(const CameraSettings& s) {
    GError* error = nullptr;
    if (arv_camera_is_exposure_auto_available(camera_, nullptr)) {
      arv_camera_set_exposure_time_auto(camera_, ARV_AUTO_OFF, &error);
      check(error, name(), "arv_camera_set_exposure_time_auto(Off)");
    }
    const auto [shortest, longest] = exposureBounds();
    if (s.exposure_us < shortest || s.exposure_us > longest) {
      std::string rate;  // (the bound may be the frame period's)
      if (arv_camera_is_frame_rate_available(camera_, nullptr)) {
        const double hz = arv_camera_get_frame_rate(camera_, &error);
        if (error == nullptr) rate = fmt::format(" at {} Hz", hz);
        g_clear_error(&error);
      }
      fail(Errc::InvalidArgument, "camera '{}': exposure_us {} is outside the device's {}..{} us{}", name(),
           s.exposure_us, shortest, longest, rate);
    }
    arv_camera_set_exposure_time(camera_, s.exposure_us, &error);
    check(error, name(), fmt::format("arv_camera_set_exposure_time({} us)", s.exposure_us));

    double min = 0, max = 0;
    if (!arv_camera_is_gain_available(camera_, nullptr)) {
      if (s.gain != 0)
        fail(Errc::InvalidArgument, "camera '{}': gain {} asked, the device has no gain", name(), s.gain);
      return;
    }
    if (arv_camera_is_gain_auto_available(camera_, nullptr)) {
      arv_camera_set_gain_auto(camera_, ARV_AUTO_OFF, &error);
      check(error, name(), "arv_camera_set_gain_auto(Off)");
    }
    arv_camera_get_gain_bounds(camera_, &min, &max, &error);
    check(error, name(), "arv_camera_get_gain_bounds");
    if (s.gain < min || s.gain > max)
      fail(Errc::InvalidArgument, "camera '{}': gain {} is outside the device's {}..{}", name(), s.gain, min, max);
    arv_camera_set_gain(camera_, s.gain, &error);
    check(error, name(), fmt::format("arv_camera_set_gain({})", s.gain));
  }

  // SFNC's frame-rate cap (AcquisitionFrameRateEnable), where the device has
  // it: on for a free run at a set rate (a rate does not apply without it), off
  // in a triggered mode, where the triggers set the pace. Left on from an
  // earlier free run, it would keep a triggered exposure within that rate's
  // period and drop triggers that come faster. (A device that will not change
  // it keeps it; the exposure's check then names the bound in force.)
  void setFrameRateCap(bool on) {
    static constexpr const char* kFeature = "AcquisitionFrameRateEnable";
    GError* error = nullptr;
    if (arv_camera_is_feature_available(camera_, kFeature, &error) && error == nullptr &&
        (arv_camera_get_boolean(camera_, kFeature, &error) != FALSE) != on && error == nullptr)
      arv_camera_set_boolean(camera_, kFeature, on ? TRUE : FALSE, &error);
    if (error != nullptr) {
      spdlog::warn("camera '{}': {} could not be set to {}: {}", name(), kFeature, on, error->message);
      g_clear_error(&error);
    }
  }

  // (Before applyTrigger: arv_camera_set_frame_rate switches triggers off.)
  void applyFrameRate(const CameraSettings& s) {
    if (!setsFrameRate(s)) return;
    if (!arv_camera_is_frame_rate_available(camera_, nullptr))
      fail(Errc::InvalidArgument, "camera '{}': frameRate_hz {} asked, the device has no frame rate control", name(),
           s.frameRate_hz);
    GError* error = nullptr;
    double min = 0, max = 0;
    arv_camera_get_frame_rate_bounds(camera_, &min, &max, &error);
    check(error, name(), "arv_camera_get_frame_rate_bounds");
    if (s.frameRate_hz < min || s.frameRate_hz > max)
      fail(Errc::InvalidArgument, "camera '{}': frameRate_hz {} is outside the device's {}..{} Hz", name(),
           s.frameRate_hz, min, max);
    arv_camera_set_frame_rate(camera_, s.frameRate_hz, &error);
    check(error, name(), fmt::format("arv_camera_set_frame_rate({} Hz)", s.frameRate_hz));
  }

  void applyTrigger(const CameraSettings& s) {
    GError* error = nullptr;
    switch (s.trigger) {
      case TriggerMode::FreeRun:
        arv_camera_clear_triggers(camera_, &error);
        check(error, name(), "arv_camera_clear_triggers");
        break;
      case TriggerMode::Software:
        if (!arv_camera_is_software_trigger_supported(camera_, nullptr))
          fail(Errc::InvalidArgument, "camera '{}': TriggerMode::Software asked, the device has no software trigger",
               name());
        arv_camera_set_trigger(camera_, "Software", &error);
        check(error, name(), "arv_camera_set_trigger('Software')");
        break;
      case TriggerMode::Line:
        arv_camera_set_trigger(camera_, s.triggerLine.c_str(), &error);
        check(error, name(), fmt::format("arv_camera_set_trigger('{}')", s.triggerLine));
        break;
    }
  }

  // Copies (or unpacks) the buffer's image into `out`, reusing its memory when
  // the size and type fit and nobody else holds it. Returns why the payload is
  // not the image the camera was configured for, or nothing.
  std::optional<std::string> copyImage(ArvBuffer* buffer, cv::Mat& out) const {
    if (arv_buffer_get_payload_type(buffer) != ARV_BUFFER_PAYLOAD_TYPE_IMAGE) return "its payload is not an image";
    // A frame whose leader was lost has no image part (Aravis then asserts in the getters below).
    if (arv_buffer_get_n_parts(buffer) < 1 ||
        arv_buffer_get_part_data_type(buffer, 0) != ARV_BUFFER_PART_DATA_TYPE_2D_IMAGE)
      return "its payload has no 2D image part";
    size_t size = 0;
    const auto* data = static_cast<const std::uint8_t*>(arv_buffer_get_image_data(buffer, &size));
    const int width = arv_buffer_get_image_width(buffer);
    const int height = arv_buffer_get_image_height(buffer);
    if (data == nullptr || width <= 0 || height <= 0)
      return fmt::format("its image is empty ({} x {} px, {} bytes)", width, height, size);
    const ArvPixelFormat format = arv_buffer_get_image_pixel_format(buffer);
    const auto wire = wireFormats(settings_.pixelFormat);
    if (std::none_of(wire.begin(), wire.end(), [&](const WireFormat& w) { return w.code == format; }))
      return fmt::format("its pixel format is 0x{:08x}, not one of {} (configured {})", static_cast<unsigned>(format),
                         fmt::join(wireFormatNames(settings_.pixelFormat), ", "), toString(settings_.pixelFormat));
    if (width != frameWidth_ || height != frameHeight_)  // (the buffers were sized for the region)
      return fmt::format("its image is {} x {} px, not the {} x {} px region the stream started with", width, height,
                         frameWidth_, frameHeight_);
    int xPadding = 0;  // bytes after each line
    arv_buffer_get_image_padding(buffer, &xPadding, nullptr);
    if (!out.empty() && (out.u == nullptr || out.u->refcount > 1 || !out.isContinuous() || out.isSubmatrix()))
      out.release();  // a caller still holds the previous image: do not overwrite it
    const auto rows = static_cast<std::size_t>(height);
    if (format == ARV_PIXEL_FORMAT_MONO_12_PACKED || format == kPixelFormatMono12p) {
      if (xPadding != 0) return fmt::format("its packed lines carry {} bytes of padding", xPadding);
      if (size < mono12PackedSize(width, height))
        return fmt::format("its {} x {} px packed image needs {} bytes, the payload has {}", width, height,
                           mono12PackedSize(width, height), size);
      unpackMono12(data, size, width, height,
                   format == kPixelFormatMono12p ? Mono12Packing::Pfnc : Mono12Packing::GigEVisionPacked, out);
      return std::nullopt;
    }
    const int type = format == ARV_PIXEL_FORMAT_MONO_8 ? CV_8UC1 : CV_16UC1;
    const std::size_t rowBytes = static_cast<std::size_t>(width) * (type == CV_8UC1 ? 1 : 2);
    const std::size_t stride = rowBytes + static_cast<std::size_t>(xPadding);
    if (type == CV_16UC1 && stride % 2 != 0)  // (OpenCV takes no 16-bit rows at an odd byte step)
      return fmt::format("its 16-bit lines are padded by an odd {} bytes", xPadding);
    if (size < stride * (rows - 1) + rowBytes)
      return fmt::format("its {} x {} px image ({} bytes per line) needs {} bytes, the payload has {}", width, height,
                         stride, stride * (rows - 1) + rowBytes, size);
    // GigE/USB3 Vision: little endian; padded lines are copied one by one.
    cv::Mat(height, width, type, const_cast<std::uint8_t*>(data), stride).copyTo(out);
    return std::nullopt;
  }

  StreamStatistics readStatistics() const {
    StreamStatistics stats;
    if (stream_ == nullptr) return stats;
    guint64 completed = 0, failures = 0, underruns = 0;
    arv_stream_get_statistics(stream_, &completed, &failures, &underruns);
    stats.completed = completed;
    stats.failed = failures;
    stats.underruns = underruns;
    if (ARV_IS_GV_STREAM(stream_)) {
      guint64 resent = 0, missing = 0;
      arv_gv_stream_get_statistics(ARV_GV_STREAM(stream_), &resent, &missing);
      stats.resentPackets = resent;
      stats.missingPackets = missing;
    }
    return stats;
  }

  std::string deviceId_;
  AravisOptions options_;
  State state_ = State::Closed;
  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  gulong controlLostHandler_ = 0;
  std::atomic<bool> controlLost_ = false;  // set from Aravis's heartbeat thread
  bool lost_ = false;
  std::string gvcpIp_;
  std::uint16_t gvcpPort_ = 3956;
  CameraInfo info_;
  CameraSettings settings_;
  StreamStatistics statistics_;
  int frameWidth_ = 0, frameHeight_ = 0;  // the region start() found: every frame must be of it
};

}  // namespace

std::vector<AravisDeviceInfo> listAravisDevices() {
  std::lock_guard lock(aravisMutex());
  return listDevicesLocked(true);
}

std::unique_ptr<Camera> openAravisCamera(const std::string& deviceId, const AravisOptions& options) {
  return std::make_unique<AravisCamera>(deviceId, options);
}

}  // namespace lfi
