// SPDX-License-Identifier: Apache-2.0
// The served camera's registers as GVCP commands reach them, without sockets
// (emulation/src/gige/served_camera_device.h): Aravis's register model set up
// as GvCameraServer serves it, and lfi's frame fill. The input is GVCP command
// packets one after another, each an 8-byte header (0x42, flags, command,
// length, id; big-endian) and `length` bytes. Each is carried out as Aravis's
// device answers it (arvgvfakecamera.c, _handle_control_packet: DISCOVERY,
// READREG, WRITEREG, READMEM, WRITEMEM on the register model, bytes past the
// packet read as 0), and after each, while a controller holds the device and
// acquisition runs, a frame is filled as Aravis's device thread fills one: into
// a buffer of the payload the registers asked for when the stream started.
// A frame the fill writes must fit the sensor and the buffer; a frame it
// refuses must go out black.
//
// Aravis 0.8.26's register model reads from outside its memory for a read that
// starts past its memory and GenICam description, and writes outside it for a
// write whose end passes 2^32: one such packet stops `lfi serve-camera` with a
// segmentation fault (docs/reliability.md). Those commands are left out here,
// so that the target can look for lfi's faults.
#include "fuzz_input.h"

#include "gige/served_camera_device.h"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <vector>

namespace {

constexpr std::uint16_t kDiscovery = 0x0002, kReadRegister = 0x0080, kWriteRegister = 0x0082, kReadMemory = 0x0084,
                        kWriteMemory = 0x0086;
constexpr std::uint64_t kMemory = ARV_FAKE_CAMERA_MEMORY_SIZE;
constexpr std::size_t kMostPayload = 1 << 20;  // (Aravis would allocate up to 4 GiB: the stream is not started)

std::uint32_t be32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} << 24 | std::uint32_t{p[1]} << 16 | std::uint32_t{p[2]} << 8 | p[3];
}

// The size of Aravis's fake camera's GenICam description, which reads follow its memory with.
std::uint64_t descriptionSize() {
  static const std::uint64_t bytes = [] {
    ArvFakeCamera* camera = arv_fake_camera_new("LFIFUZZ");
    gsize size = 0;
    arv_fake_camera_get_genicam_xml(camera, &size);
    g_object_unref(camera);
    return static_cast<std::uint64_t>(size);
  }();
  return bytes;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  lfi::fuzz::folder();  // (the device's warnings off)
  lfi::emulation::GvCameraServerOptions options;
  options.sensorWidth_px = 64;
  options.sensorHeight_px = 48;
  std::vector<std::uint8_t> pixels;  // the stream's buffer
  bool filled = false;               // the filler ran for the frame
  ArvFakeCamera* camera = arv_fake_camera_new("LFIFUZZ");
  {
    lfi::emulation::detail::ServedCameraDevice device(
        camera, options, [&](const lfi::emulation::ServedFrameRequest& request, cv::Mat& image) {
          filled = true;
          const std::size_t bytes = image.total() * image.elemSize();
          if (request.width_px < 1 || request.width_px > options.sensorWidth_px || request.height_px < 1 ||
              request.height_px > options.sensorHeight_px || !request.pixelFormat || image.cols != request.width_px ||
              image.rows != request.height_px || image.data != pixels.data() || bytes > pixels.size())
            std::abort();
          std::fill_n(image.data, bytes, std::uint8_t{0x5a});  // (every byte the frame takes, in the buffer)
        });
    ArvBuffer* buffer = nullptr;
    std::array<std::uint8_t, 8 + 0xffff + 8> packet;
    for (std::size_t at = 0; at + 8 <= size;) {
      const std::uint8_t* header = data + at;
      const std::size_t length = std::min<std::size_t>(header[4] << 8 | header[5], size - at - 8);
      packet.fill(0);
      std::copy_n(header, 8 + length, packet.begin());
      at += 8 + length;
      if (packet[0] != 0x42) continue;  // not a command: ignored
      const std::uint8_t* body = packet.data() + 8;
      const std::uint64_t address = be32(body);
      const unsigned command = packet[2] << 8 | packet[3];
      switch (command) {
        case kDiscovery: {
          std::array<std::uint8_t, 0xf8> ack;
          arv_fake_camera_read_memory(camera, 0, ack.size(), ack.data());
          break;
        }
        case kReadRegister:
        case kReadMemory: {
          const std::uint32_t count = command == kReadRegister ? 4 : be32(body + 4) & 0xffff;
          if (count == 0 || address > kMemory + descriptionSize()) break;  // (Aravis: see above)
          std::vector<std::uint8_t> ack(count);
          arv_fake_camera_read_memory(camera, static_cast<guint32>(address), count, ack.data());
          break;
        }
        case kWriteRegister:
          if (address + 4 > kMemory) break;  // (Aravis refuses it, or with the end past 2^32 writes it anywhere)
          arv_fake_camera_write_register(camera, static_cast<guint32>(address), be32(body + 4));
          break;
        case kWriteMemory: {
          const std::uint32_t count = static_cast<std::uint32_t>((packet[4] << 8 | packet[5]) - 4);
          if (count == 0 || address + count > kMemory) break;  // (the same)
          arv_fake_camera_write_memory(camera, static_cast<guint32>(address), count, body + 4);
          break;
        }
        default:
          break;
      }
      // The device thread: a stream while a controller holds the device and acquisition runs.
      if (arv_fake_camera_get_control_channel_privilege(camera) == 0 ||
          arv_fake_camera_get_acquisition_status(camera) == 0) {
        if (buffer) g_object_unref(buffer);
        buffer = nullptr;
        continue;
      }
      if (!buffer) {
        const std::size_t payload = arv_fake_camera_get_payload(camera);
        if (payload > kMostPayload) continue;
        pixels.assign(std::max<std::size_t>(payload, 1), 0);
        buffer = arv_buffer_new(pixels.size(), pixels.data());
      }
      std::fill(pixels.begin(), pixels.end(), std::uint8_t{0xa5});
      filled = false;
      arv_fake_camera_fill_buffer(camera, buffer, nullptr);
      if (arv_buffer_get_status(buffer) != ARV_BUFFER_STATUS_SUCCESS || filled) continue;
      // Refused: black, as far as the payload the registers ask for now.
      const std::size_t black = std::min(arv_fake_camera_get_payload(camera), pixels.size());
      if (std::any_of(pixels.begin(), pixels.begin() + static_cast<std::ptrdiff_t>(black),
                      [](std::uint8_t b) { return b != 0; }))
        std::abort();
    }
    if (buffer) g_object_unref(buffer);
  }
  g_object_unref(camera);
  return 0;
}
