// SPDX-License-Identifier: Apache-2.0
// The Aravis backend's stream: its buffer pool, grabbing frames and checking each
// against the configured pixel format, region and padding, the stream statistics,
// and telling a device that is gone from one that is slow.

#include "aravis_camera_impl.h"
#include "image_payload.h"

#include "lfi/drivers/driver_trace.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>

namespace lfi::detail {
namespace {

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

}  // namespace

void AravisCamera::start(int bufferCount) {
  requireCameraState(state_, {State::Configured}, "start", name());
  if (bufferCount < 1 || bufferCount > 1024)
    fail(Errc::InvalidArgument, "camera '{}': start(bufferCount = {}) needs 1..1024 buffers", name(), bufferCount);
  streamSettings_.reset();
  onDevice([&] { startStream(bufferCount); });
}

// start() on the device: the stream, its buffers, the acquisition.
void AravisCamera::startStream(int bufferCount) {
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
  stream_ = arv_camera_create_stream(camera_, &AravisCamera::onStreamEvent, this, &error);
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
    fail(Errc::Device, "camera '{}': the device reports a {} x {} px region on its {} x {} px sensor", name(), width,
         height, info_.sensorWidth_px, info_.sensorHeight_px);
  }
  // (The fewest bytes a frame of the format takes on the wire: Mono12 packed.)
  const std::uint64_t image = static_cast<std::uint64_t>(std::max(width, 0)) *
                              static_cast<std::uint64_t>(std::max(height, 0)) *
                              static_cast<unsigned>(significantBits(settings_.pixelFormat)) / 8;
  if (const std::uint64_t most = 4 * image + (16u << 20); payload < image || payload > most) {
    g_clear_object(&stream_);
    fail(Errc::Device,
         "camera '{}': the device's PayloadSize of {} bytes does not fit its {} x {} px {} image "
         "({} to {} bytes)",
         name(), payload, width, height, toString(settings_.pixelFormat), image, most);
  }
  // Without CAP_NET_RAW (a user of the udev group, not root) Aravis reads the stream from a UDP socket whose
  // receive buffer is the system's default, 208 KiB: a stall of 2 ms at 1 Gb/s overflows it and the packets
  // after are lost. It holds as many frames as the buffers instead (the kernel caps it at net.core.rmem_max).
  if (ARV_IS_GV_STREAM(stream_))
    g_object_set(stream_, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                 static_cast<gint>(std::min<std::uint64_t>(std::uint64_t{payload} * bufferCount, INT_MAX)), nullptr);
  for (int i = 0; i < bufferCount; ++i) {
    ArvBuffer* buffer = arv_buffer_new_allocate(payload);
    buffersPushed_.store(true, std::memory_order_release);
    arv_stream_push_buffer(stream_, buffer);
  }
  arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
  const char* call = "arv_camera_set_acquisition_mode";
  if (error == nullptr) arv_camera_start_acquisition(camera_, &error), call = "arv_camera_start_acquisition";
  if (error != nullptr) {
    g_clear_object(&stream_);
    check(error, name(), call);
  }
  traceDriverCall("aravis", name(), "arv_camera_start_acquisition",
                  fmt::format("({} buffers of {} bytes)", bufferCount, payload));
  statistics_ = {};
  frameWidth_ = width, frameHeight_ = height;
  framePayload_ = payload;
  framePixelFormat_ = arv_camera_get_pixel_format(camera_, nullptr);
  state_ = State::Streaming;
}

void AravisCamera::stop() {
  requireCameraState(state_, {State::Streaming}, "stop", name());
  streamSettings_.reset();
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

void AravisCamera::softwareTrigger() {
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

void AravisCamera::grabInto(Frame& frame, std::chrono::milliseconds timeout) {
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
    traceDriverCall("aravis", name(), "arv_stream_timeout_pop_buffer", "no buffer");
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
    std::atomic<bool>& pushed;
    ~PushBack() {
      pushed.store(true, std::memory_order_release);
      arv_stream_push_buffer(stream, buffer);
    }
  } pushBack{stream_, buffer, buffersPushed_};

  const ArvBufferStatus status = arv_buffer_get_status(buffer);
  frame.frameId = arv_buffer_get_frame_id(buffer);
  frame.timestamp_ns = arv_buffer_get_timestamp(buffer);
  if (frame.timestamp_ns == 0) frame.timestamp_ns = arv_buffer_get_system_timestamp(buffer);
  frame.status = status == ARV_BUFFER_STATUS_SUCCESS ? FrameStatus::Complete : FrameStatus::Incomplete;
  traceDriverCall("aravis", name(), "arv_stream_timeout_pop_buffer",
                  fmt::format("frame {} status {}", frame.frameId, static_cast<int>(status)));
  if (const auto refused = copyImage(buffer, frame.image)) {
    if (frame.status == FrameStatus::Complete)
      fail(Errc::Device, "camera '{}': frame {} is complete but {}", name(), frame.frameId, *refused);
    frame.image.release();
  }
}

StreamStatistics AravisCamera::statistics() const {
  requireCameraState(state_, {State::Configured, State::Streaming}, "statistics", name());
  return state_ == State::Streaming ? readStatistics() : statistics_;
}

// The device is gone: the camera becomes Closed (open() may reconnect later).
void AravisCamera::declareLost(const std::string& why) {
  statistics_ = readStatistics();
  lost_ = true;
  const bool streaming = state_ == State::Streaming;
  state_ = State::Closed;
  fail(Errc::Device, "camera '{}': device lost{}: {}; the camera is closed, open() it again when it is back", name(),
       streaming ? " while streaming" : "", why);
}

bool AravisCamera::deviceAnswers() {
  if (!gvcpIp_.empty()) return gvcpDeviceAnswers(gvcpIp_, gvcpPort_, 5, 200);
  guint32 value = 0;
  GError* error = nullptr;
  const bool ok = arv_device_read_register(arv_camera_get_device(camera_), 0, &value, &error);
  if (error != nullptr) g_error_free(error);
  return ok;
}

// The buffer's image into `out` (imageFromPayload), or why the payload is not
// the image the camera was configured for.
std::optional<std::string> AravisCamera::copyImage(ArvBuffer* buffer, cv::Mat& out) const {
  if (arv_buffer_get_status(buffer) != ARV_BUFFER_STATUS_SUCCESS) {
    // Aravis describes only a complete buffer's image (its getters refuse the others): an incomplete one is
    // the stream's region and format, in the buffer's bytes as far as they arrived.
    ImagePayload payload{.data = static_cast<const std::uint8_t*>(arv_buffer_get_data(buffer, nullptr)),
                         .size = framePayload_,
                         .width = frameWidth_,
                         .height = frameHeight_,
                         .pixelFormat = framePixelFormat_};
    return imageFromPayload(payload, settings_.pixelFormat, frameWidth_, frameHeight_, out);
  }
  if (arv_buffer_get_payload_type(buffer) != ARV_BUFFER_PAYLOAD_TYPE_IMAGE) return "its payload is not an image";
  // A frame whose leader was lost has no image part (Aravis then asserts in the getters below).
  if (arv_buffer_get_n_parts(buffer) < 1 ||
      arv_buffer_get_part_data_type(buffer, 0) != ARV_BUFFER_PART_DATA_TYPE_2D_IMAGE)
    return "its payload has no 2D image part";
  ImagePayload payload;
  payload.data = static_cast<const std::uint8_t*>(arv_buffer_get_image_data(buffer, &payload.size));
  payload.width = arv_buffer_get_image_width(buffer);
  payload.height = arv_buffer_get_image_height(buffer);
  payload.pixelFormat = arv_buffer_get_image_pixel_format(buffer);
  arv_buffer_get_image_padding(buffer, &payload.xPadding, nullptr);
  return imageFromPayload(payload, settings_.pixelFormat, frameWidth_, frameHeight_, out);
}

StreamStatistics AravisCamera::readStatistics() const {
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

}  // namespace lfi::detail
