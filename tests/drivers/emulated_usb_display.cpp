#include "emulated_usb_display.h"

#include "lfi/core/error.h"

#include <fmt/format.h>
#include <linux/usbdevice_fs.h>
#include <sys/ioctl.h>
#include <umockdev.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace lfi::testing_support {
namespace {

namespace proto = usbdisplay;

// One URB the host submitted: the umockdev copies of the struct and its buffer
// (kept referenced until reaped) and its outcome, applied at reap time.
struct Urb {
  UMockdevIoctlClient* client = nullptr;
  UMockdevIoctlData* urb = nullptr;
  UMockdevIoctlData* buffer = nullptr;
  bool bulk = false;
  int status = 0;
  int actualLength = 0;
};

void release(Urb& u) {
  if (u.buffer) g_object_unref(u.buffer);
  if (u.urb) g_object_unref(u.urb);
  if (u.client) g_object_unref(u.client);
  u = {};
}

std::string hex(const std::vector<std::uint8_t>& bytes) {
  std::string out;
  for (std::uint8_t b : bytes) out += fmt::format("{:02X}", b);
  return out;
}

std::vector<std::uint8_t> utf16Descriptor(const std::string& text) {
  std::vector<std::uint8_t> d{static_cast<std::uint8_t>(2 + 2 * text.size()), 3};
  for (char c : text) {
    d.push_back(static_cast<std::uint8_t>(c));
    d.push_back(0);
  }
  return d;
}

// The process's one testbed: umockdev's preload library follows the newest
// testbed's directory, so devices emulated at once must share one. Never
// freed (devices come and go in it; usePrivateTmpDir's folder goes at exit).
UMockdevTestbed* sharedTestbed() {
  static UMockdevTestbed* const testbed = umockdev_testbed_new();
  return testbed;
}

}  // namespace

struct EmulatedUsbDisplay::Impl {
  EmulatedDisplayConfig config;
  UMockdevTestbed* testbed = nullptr;
  UMockdevIoctlBase* handler = nullptr;
  GMainContext* context = nullptr;
  std::thread thread;
  std::atomic<bool> stop{false};
  std::string devnode;
  std::string syspath;
  bool inTestbed = false;  // its sysfs entry and node are in the testbed (from plug() to unplug())
  bool trace = std::getenv("LFI_USB_EMULATION_TRACE") != nullptr;  // log every ioctl to stderr

  mutable std::mutex mutex;
  EmulatedDisplayState state;
  std::deque<Urb> done;     // completed, waiting to be reaped
  std::deque<Urb> held;     // accepted but never completed (silent device)
  std::uint32_t inFlight = 0;
  bool unplugged = true;
  bool halted = false;
  // faults
  bool stallAll = false, corruptNext = false, unplugNext = false, silent = false;
  int stallNextAt = -1;                  // the next frame's bulk URB that halts the endpoint; -1: none
  int shortNextAt = -1;                  // the next frame's bulk URB the device takes only part of; -1: none
  int shortNextBy = 0;                   // and how many of its bytes it leaves
  int unplugAtRequest = -1;              // the vendor request at which the device vanishes; -1: none
  int claimErrno = 0;                    // CLAIMINTERFACE fails with this errno (0: it succeeds)
  bool absurdInfo = false, badCalibrationCrc = false, forgetErrors = false;
  int statusBrightness = -1;              // GET_STATUS's brightness, -1: the true one
  std::int64_t statusPresentedSequence = -1;  // and its presented sequence
  std::size_t truncateNext = 0;
  int silentAfterUrbs = -1;  // bulk URBs to take before turning silent; -1: never
  bool silentAtPresent = false;
  int clearHaltErrno = 0;  // CLEAR_HALT fails with this errno (0: it succeeds)
  // frame assembly
  std::vector<std::uint8_t> rx;
  std::size_t expected = 0;  // header + payload once the header is in
  proto::FrameHeader header;
  proto::DeviceError rxError = proto::DeviceError::None;
  bool frameStarted = false;
  bool frameCorrupt = false;
  std::size_t frameTruncate = 0;
  bool frameUnplug = false;
  int frameUrb = 0;  // bulk URBs of this frame so far
  int frameStallAt = -1, frameShortAt = -1, frameShortBy = 0;
  std::uint32_t lastErrorSequence = 0;
  std::string lastErrorText;
  cv::Mat presented;

  // Runs `f` on the handler thread and waits for it (umockdev's handler objects
  // belong to that thread's main context).
  void runOnHandlerThread(const std::function<void()>& f) {
    struct Call {
      const std::function<void()>* f;
      std::promise<void> done;
    } call{&f, {}};
    auto future = call.done.get_future();
    g_main_context_invoke(
        context,
        [](gpointer data) -> gboolean {
          auto* c = static_cast<Call*>(data);
          try {
            (*c->f)();
            c->done.set_value();
          } catch (...) {
            c->done.set_exception(std::current_exception());
          }
          return G_SOURCE_REMOVE;
        },
        &call);
    future.get();
  }

  void attachHandler() {
    handler = UMOCKDEV_IOCTL_BASE(g_object_new(UMOCKDEV_TYPE_IOCTL_BASE, nullptr));
    g_signal_connect(handler, "handle-ioctl", G_CALLBACK(+[](UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                                             gpointer self) -> gboolean {
                       return static_cast<Impl*>(self)->onIoctl(client);
                     }),
                     this);
    GError* error = nullptr;
    if (!umockdev_testbed_attach_ioctl(testbed, devnode.c_str(), handler, &error)) {
      std::string message = error ? error->message : "unknown error";
      g_clear_error(&error);
      fail(Errc::Device, "emulated display: attaching the ioctl handler to {} failed: {}", devnode, message);
    }
  }

  // The device's node file (not part of the sysfs tree umockdev removes).
  void removeNode() const {
    std::error_code ec;
    gchar* root = umockdev_testbed_get_root_dir(testbed);  // transfer full
    std::filesystem::remove(std::filesystem::path(root) / devnode.substr(1), ec);
    g_free(root);
  }

  // Takes the device out of the (shared) testbed, for good.
  void removeFromTestbed() {
    if (!std::exchange(inTestbed, false)) return;
    umockdev_testbed_uevent(testbed, syspath.c_str(), "remove");
    umockdev_testbed_remove_device(testbed, syspath.c_str());
    removeNode();
  }

  void detachHandler() {
    if (!handler) return;
    GError* error = nullptr;
    umockdev_testbed_detach_ioctl(testbed, devnode.c_str(), &error);
    g_clear_error(&error);
    g_object_unref(handler);
    handler = nullptr;
  }

  std::string description() const {
    std::vector<std::uint8_t> d;
    auto u16 = [&](int v) {
      d.push_back(static_cast<std::uint8_t>(v));
      d.push_back(static_cast<std::uint8_t>(v >> 8));
    };
    // device descriptor
    d.insert(d.end(), {18, 1});
    u16(0x0200);
    d.insert(d.end(), {0, 0, 0, 64});
    u16(config.vendorId);
    u16(config.productId);
    u16(0x0100);
    d.insert(d.end(), {1, 2, static_cast<std::uint8_t>(config.serialDescriptor ? 3 : 0), 1});
    // configuration, interface, bulk OUT endpoint (512 byte packets, high speed)
    d.insert(d.end(), {9, 2});
    u16(9 + 9 + 7);
    d.insert(d.end(), {1, 1, 0, 0x80, 50});
    d.insert(d.end(), {9, 4, 0, 0, 1, proto::kInterfaceClass, proto::kInterfaceSubclass, proto::kInterfaceProtocol, 0});
    d.insert(d.end(), {7, 5, proto::kFrameEndpoint, 2});
    u16(512);
    d.push_back(0);
    const std::string node = devnode.substr(5);  // without /dev/
    return fmt::format(
        "P: /devices/{}-{}\n"
        "N: {}\n"
        "E: SUBSYSTEM=usb\n"
        "E: DEVTYPE=usb_device\n"
        "E: DEVNAME={}\n"
        "E: PRODUCT={:x}/{:x}/100\n"
        "E: BUSNUM={:03d}\n"
        "E: DEVNUM={:03d}\n"
        "A: busnum={}\\n\n"
        "A: devnum={}\\n\n"
        "A: speed=480\\n\n"
        "A: idVendor={:04x}\\n\n"
        "A: idProduct={:04x}\\n\n"
        "A: bConfigurationValue=1\\n\n"
        "A: bNumConfigurations=1\\n\n"
        "A: bNumInterfaces= 1\\n\n"
        "A: manufacturer={}\\n\n"
        "A: product={}\\n\n"
        "A: serial={}\\n\n"
        "A: dev=189:{}\\n\n"
        "H: descriptors={}\n",
        config.busNumber, config.deviceNumber, node, devnode, config.vendorId, config.productId, config.busNumber, config.deviceNumber,
        config.busNumber, config.deviceNumber, config.vendorId, config.productId, config.vendor, config.model,
        config.serial, (config.busNumber - 1) * 128 + config.deviceNumber - 1, hex(d));
  }

  // ---- device side, on the handler thread, under `mutex` ----

  gboolean onIoctl(UMockdevIoctlClient* client) {
    std::lock_guard lock(mutex);
    const gulong request = umockdev_ioctl_client_get_request(client);
    UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
    GError* error = nullptr;
    auto finish = [&](long result, int err) {
      if (trace) std::fprintf(stderr, "emulated display: ioctl 0x%lx -> %ld errno %d\n", request, result, err);
      umockdev_ioctl_client_complete(client, result, err);
    };

    if (request == USBDEVFS_REAPURB || request == USBDEVFS_REAPURBNDELAY) {
      auto it = std::find_if(done.begin(), done.end(), [&](const Urb& u) { return u.client == client; });
      if (it == done.end()) {
        finish(-1, unplugged ? ENODEV : EAGAIN);
        return TRUE;
      }
      Urb u = *it;
      done.erase(it);
      auto* urb = reinterpret_cast<usbdevfs_urb*>(u.urb->data);
      urb->status = u.status;
      urb->actual_length = u.actualLength;
      UMockdevIoctlData* slot = umockdev_ioctl_data_resolve(arg, 0, sizeof(void*), &error);
      if (!slot) {
        g_clear_error(&error);
        release(u);
        finish(-1, EFAULT);
        return TRUE;
      }
      umockdev_ioctl_data_set_ptr(slot, 0, u.urb);
      if (u.bulk && inFlight > 0) --inFlight;
      release(u);
      finish(0, 0);
      return TRUE;
    }
    if (unplugged) {
      finish(-1, ENODEV);
      return TRUE;
    }
    switch (request) {
      case USBDEVFS_GET_CAPABILITIES: {
        UMockdevIoctlData* data = umockdev_ioctl_data_resolve(arg, 0, sizeof(std::uint32_t), &error);
        if (!data) break;
        // What an xHCI controller reports: scatter-gather makes libusb send one URB per transfer.
        const std::uint32_t caps = USBDEVFS_CAP_ZERO_PACKET | USBDEVFS_CAP_BULK_CONTINUATION |
                                   USBDEVFS_CAP_NO_PACKET_SIZE_LIM | USBDEVFS_CAP_BULK_SCATTER_GATHER |
                                   USBDEVFS_CAP_REAP_AFTER_DISCONNECT;
        std::memcpy(data->data, &caps, sizeof(caps));
        finish(0, 0);
        return TRUE;
      }
      case USBDEVFS_CLAIMINTERFACE:
      case USBDEVFS_RELEASEINTERFACE: {
        UMockdevIoctlData* data = umockdev_ioctl_data_resolve(arg, 0, sizeof(unsigned), &error);
        if (!data) break;
        unsigned iface = 0;
        std::memcpy(&iface, data->data, sizeof(iface));
        if (iface != 0) {
          finish(-1, EINVAL);
          return TRUE;
        }
        if (request == USBDEVFS_CLAIMINTERFACE && claimErrno != 0) {
          finish(-1, claimErrno);
          return TRUE;
        }
        state.claimed = request == USBDEVFS_CLAIMINTERFACE;
        finish(0, 0);
        return TRUE;
      }
      case USBDEVFS_CLEAR_HALT: {
        UMockdevIoctlData* data = umockdev_ioctl_data_resolve(arg, 0, sizeof(unsigned), &error);
        if (!data) break;
        if (clearHaltErrno != 0) {
          finish(-1, clearHaltErrno);
          return TRUE;
        }
        halted = false;
        ++state.clearHalts;
        resetFrame();  // the firmware drops a partly received frame when its endpoint is reset
        finish(0, 0);
        return TRUE;
      }
      case USBDEVFS_GETDRIVER:
        finish(-1, ENODATA);
        return TRUE;
      case USBDEVFS_DISCARDURB: {
        // The argument is the URB's address itself.
        gulong address = 0;
        std::memcpy(&address, arg->data, sizeof(address));
        auto it = std::find_if(held.begin(), held.end(), [&](const Urb& u) { return u.urb->client_addr == address; });
        if (it == held.end()) {
          finish(-1, EINVAL);
          return TRUE;
        }
        it->status = -ENOENT;
        it->actualLength = 0;
        done.push_back(*it);
        held.erase(it);
        finish(0, 0);
        return TRUE;
      }
      case USBDEVFS_SUBMITURB:
        return submit(client, arg);
      default:
        finish(-1, ENOTTY);
        return TRUE;
    }
    g_clear_error(&error);
    finish(-1, EFAULT);
    return TRUE;
  }

  gboolean submit(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
    GError* error = nullptr;
    UMockdevIoctlData* urbData = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_urb), &error);
    if (!urbData) {
      g_clear_error(&error);
      umockdev_ioctl_client_complete(client, -1, EFAULT);
      return TRUE;
    }
    auto* urb = reinterpret_cast<usbdevfs_urb*>(urbData->data);
    UMockdevIoctlData* bufData = nullptr;
    if (urb->buffer_length > 0) {
      bufData = umockdev_ioctl_data_resolve(urbData, offsetof(usbdevfs_urb, buffer),
                                            static_cast<gsize>(urb->buffer_length), &error);
      if (!bufData) {
        g_clear_error(&error);
        umockdev_ioctl_client_complete(client, -1, EFAULT);
        return TRUE;
      }
    }
    Urb u;
    u.client = static_cast<UMockdevIoctlClient*>(g_object_ref(client));
    u.urb = static_cast<UMockdevIoctlData*>(g_object_ref(urbData));
    u.buffer = bufData ? static_cast<UMockdevIoctlData*>(g_object_ref(bufData)) : nullptr;
    std::uint8_t* bytes = bufData ? bufData->data : nullptr;
    const int length = urb->buffer_length;

    if (urb->type == USBDEVFS_URB_TYPE_CONTROL && length >= 8) {
      ++state.controlRequests;
      if (silentAtPresent && bytes[1] == static_cast<std::uint8_t>(proto::Request::Present))
        silent = true, silentAtPresent = false;
      const bool vendor = bytes[0] == proto::kRequestTypeIn || bytes[0] == proto::kRequestTypeOut;
      if (vendor && bytes[1] == unplugAtRequest) {  // the request and everything pending fail as the device goes
        unplugAtRequest = -1;
        u.status = -ESHUTDOWN;
        done.push_back(u);
        failAll();
        state.plugged = state.claimed = false;
      } else if (silent) {
        held.push_back(u);
      } else {
        control(bytes, length, u);
        done.push_back(u);
      }
    } else if (urb->type == USBDEVFS_URB_TYPE_BULK && urb->endpoint == proto::kFrameEndpoint) {
      u.bulk = true;
      if (silentAfterUrbs >= 0 && silentAfterUrbs-- == 0) silent = true;
      ++state.bulkUrbs;
      ++inFlight;
      state.maxUrbsInFlight = std::max(state.maxUrbsInFlight, inFlight);
      if (silent) {
        held.push_back(u);
      } else {
        bulkOut(bytes, length, u);
        done.push_back(u);
        if (frameUnplug) failAll();
      }
    } else {
      release(u);
      umockdev_ioctl_client_complete(client, -1, EINVAL);
      return TRUE;
    }
    umockdev_ioctl_client_complete(client, 0, 0);
    return TRUE;
  }

  void failAll() {
    for (Urb& u : held) {
      u.status = -ESHUTDOWN;
      u.actualLength = 0;
      done.push_back(u);
    }
    held.clear();
    for (Urb& u : done)
      if (u.status == 0 && u.bulk) u.status = -ESHUTDOWN;
    unplugged = true;
    frameUnplug = false;
  }

  void resetFrame() {
    rx.clear();
    expected = 0;
    rxError = proto::DeviceError::None;
    frameStarted = false;
    frameCorrupt = frameUnplug = false;
    frameTruncate = 0;
    frameUrb = frameShortBy = 0;
    frameStallAt = frameShortAt = -1;
  }

  void bulkOut(const std::uint8_t* bytes, int length, Urb& u) {
    if (stallAll || halted) {
      halted = true;
      u.status = -EPIPE;
      return;
    }
    if (!frameStarted) {
      frameStarted = true;
      frameCorrupt = std::exchange(corruptNext, false);
      frameTruncate = std::exchange(truncateNext, 0);
      frameUnplug = std::exchange(unplugNext, false);
      frameStallAt = std::exchange(stallNextAt, -1);
      frameShortAt = std::exchange(shortNextAt, -1);
      frameShortBy = std::exchange(shortNextBy, 0);
    }
    const int urb = frameUrb++;
    if (urb == frameStallAt) {  // (CLEAR_HALT then drops what the frame sent before)
      halted = true;
      u.status = -EPIPE;
      return;
    }
    if (urb == frameShortAt) length = std::max(0, length - frameShortBy);
    u.status = 0;
    u.actualLength = length;
    if (rxError != proto::DeviceError::None) return;  // discard until PRESENT
    if (expected > 0 && rx.size() + static_cast<std::size_t>(length) > expected) {
      rxError = proto::DeviceError::Overflow;
      return;
    }
    rx.insert(rx.end(), bytes, bytes + length);
    if (expected == 0 && rx.size() >= proto::kFrameHeaderSize) {
      rxError = proto::decodeFrameHeader(rx, header);
      if (rxError == proto::DeviceError::None) {
        const int sub = config.subpixels == proto::SubpixelCode::Mono ? 1 : 3;
        const auto want = static_cast<int>(proto::bytesPerPixel(header.format));
        if (header.width != config.panelWidth_px || header.height != config.panelHeight_px || want != sub)
          rxError = proto::DeviceError::BadSize;
        expected = proto::kFrameHeaderSize + header.payloadSize;
      }
    }
    if (expected > 0 && rx.size() > expected) rxError = proto::DeviceError::Overflow;
    if (expected > 0 && rx.size() == expected) {
      if (frameCorrupt) rx[proto::kFrameHeaderSize + header.payloadSize / 2] ^= 0x5a;
      if (frameTruncate > 0) rx.resize(rx.size() - std::min(frameTruncate, header.payloadSize + std::size_t{0}));
    }
  }

  void reject(proto::DeviceError error, std::uint32_t sequence, std::string text) {
    state.lastError = error;
    lastErrorSequence = sequence;
    lastErrorText = std::move(text);
    ++state.framesRejected;
  }

  proto::DeviceError present(std::uint16_t sequence16) {
    const std::uint32_t sequence = expected ? header.sequence : 0;
    if (!frameStarted || rx.empty()) {
      reject(proto::DeviceError::NoFrame, sequence, "nothing received since the last PRESENT");
      return proto::DeviceError::NoFrame;
    }
    proto::DeviceError error = rxError;
    std::string text;
    if (error == proto::DeviceError::None && (expected == 0 || rx.size() < expected)) {
      error = proto::DeviceError::Truncated;
      text = fmt::format("received {} of {} bytes", rx.size(), expected ? expected : proto::kFrameHeaderSize);
    }
    if (error == proto::DeviceError::None && static_cast<std::uint16_t>(header.sequence) != sequence16) {
      error = proto::DeviceError::SequenceMismatch;
      text = fmt::format("PRESENT names {} but frame {} arrived", sequence16, header.sequence);
    }
    if (error == proto::DeviceError::None) {
      const std::uint32_t crc =
          proto::crc32Of(std::span<const std::uint8_t>(rx).subspan(proto::kFrameHeaderSize, header.payloadSize));
      if (crc != header.payloadCrc) {
        error = proto::DeviceError::PayloadCrc;
        text = fmt::format("header says 0x{:08x}, payload has 0x{:08x}", header.payloadCrc, crc);
      }
    }
    if (error != proto::DeviceError::None) {
      reject(error, sequence, text);
      resetFrame();
      return error;
    }
    const int type = header.format == proto::Format::Rgb888 ? CV_8UC3 : CV_8UC1;
    cv::Mat image(header.height, header.width, type);
    std::memcpy(image.data, rx.data() + proto::kFrameHeaderSize, header.payloadSize);
    presented = image;
    state.presentedSequence = header.sequence;
    ++state.framesPresented;
    state.showing = true;
    resetFrame();
    return proto::DeviceError::None;
  }

  // Answers one control transfer; `bytes` is the 8-byte setup packet and the data stage.
  void control(std::uint8_t* bytes, int length, Urb& u) {
    const std::uint8_t type = bytes[0], request = bytes[1];
    const std::uint16_t value = proto::getU16(bytes + 2), wLength = proto::getU16(bytes + 6);
    std::vector<std::uint8_t> reply;
    bool stall = false;
    if (type == 0x80 && request == 6 && (value >> 8) == 3) {  // GET_DESCRIPTOR(string)
      const int index = value & 0xff;
      if (index == 0) reply = {4, 3, 0x09, 0x04};
      else if (index == 1) reply = utf16Descriptor(config.vendor);
      else if (index == 2) reply = utf16Descriptor(config.model);
      else if (index == 3 && config.serialDescriptor) reply = utf16Descriptor(config.serial);
      else stall = true;
    } else if (type == proto::kRequestTypeIn) {
      switch (static_cast<proto::Request>(request)) {
        case proto::Request::GetProtocolVersion:
          proto::putU16(reply, proto::kProtocolMajor);
          proto::putU16(reply, proto::kProtocolMinor);
          break;
        case proto::Request::GetDeviceInfo: reply = deviceInfo(); break;
        case proto::Request::GetCalibration: {
          std::vector<std::uint8_t> blob = proto::encodeCalibration(config.calibration);
          if (badCalibrationCrc) blob[20] ^= 0xff;
          const std::size_t offset = static_cast<std::size_t>(value) * proto::kCalibrationChunk;
          if (offset >= blob.size()) stall = true;
          else
            reply.assign(
                blob.begin() + static_cast<std::ptrdiff_t>(offset),
                blob.begin() + static_cast<std::ptrdiff_t>(std::min(blob.size(), offset + proto::kCalibrationChunk)));
          break;
        }
        case proto::Request::GetStatus: {
          proto::StatusBlock s;
          s.showing = state.showing ? 1 : 0;
          s.presentedSequence = statusPresentedSequence >= 0 ? static_cast<std::uint32_t>(statusPresentedSequence)
                                                             : state.presentedSequence;
          s.framesPresented = state.framesPresented;
          s.framesRejected = state.framesRejected;
          s.brightness = static_cast<std::uint16_t>(statusBrightness >= 0 ? statusBrightness : state.brightness);
          s.lastError = static_cast<std::uint32_t>(state.lastError);
          s.lastErrorSequence = lastErrorSequence;
          reply = proto::encodeStatus(s);
          break;
        }
        case proto::Request::GetLastError:
          reply = forgetErrors ? proto::encodeLastError(proto::DeviceError::None, 0, "")
                               : proto::encodeLastError(state.lastError, lastErrorSequence, lastErrorText);
          break;
        default: stall = true;
      }
    } else if (type == proto::kRequestTypeOut) {
      switch (static_cast<proto::Request>(request)) {
        case proto::Request::SetBrightness:
          if (value > config.brightnessMax) {
            reject(proto::DeviceError::BadRequest, 0, fmt::format("brightness {} > {}", value, config.brightnessMax));
            stall = true;
          } else {
            state.brightness = value;
          }
          break;
        case proto::Request::Present: stall = present(value) != proto::DeviceError::None; break;
        case proto::Request::Blank: state.showing = false; break;
        default: stall = true;
      }
    } else {
      stall = true;
    }
    if (stall) {
      u.status = -EPIPE;
      u.actualLength = 0;
      return;
    }
    const std::size_t n = std::min<std::size_t>({reply.size(), wLength, static_cast<std::size_t>(length - 8)});
    if (n > 0) std::memcpy(bytes + 8, reply.data(), n);
    u.status = 0;
    u.actualLength = static_cast<int>(n);
  }

  std::vector<std::uint8_t> deviceInfo() const {
    proto::DeviceInfoBlock info;
    info.vendor = config.vendor;
    info.model = config.model;
    info.serial = config.serial;
    info.panelWidth_px = config.panelWidth_px;
    info.panelHeight_px = config.panelHeight_px;
    info.subpixels = config.subpixels;
    info.formats = config.subpixels == proto::SubpixelCode::Mono ? 0x1 : 0x2;
    info.brightnessMax = config.brightnessMax;
    info.brightness = state.brightness;
    info.viewCount = config.viewCount;
    info.calibrationSize =
        absurdInfo ? 0xffffffffu : static_cast<std::uint32_t>(proto::encodeCalibration(config.calibration).size());
    info.maxPayloadSize = static_cast<std::uint32_t>(config.panelWidth_px * config.panelHeight_px *
                                                      (config.subpixels == proto::SubpixelCode::Mono ? 1 : 3));
    return proto::encodeDeviceInfo(info);
  }
};

EmulatedUsbDisplay::EmulatedUsbDisplay(EmulatedDisplayConfig config) : config_(std::move(config)), impl_(new Impl) {
  if (config_.calibration.pixelPitch_mm == 0) {
    config_.calibration.pixelPitch_mm = 25.4 / 338.0;
    config_.calibration.optics = usbdisplay::OpticsCode::Lenslet;
    config_.calibration.lensPitch_px = 7.22;
    config_.calibration.slant_rad = 0.1826;
    config_.calibration.offset_px = 0.3;
    config_.calibration.gap_mm = 0.7333;
    config_.calibration.focalLength_mm = 0.7333;
  }
  Impl& d = *impl_;
  d.config = config_;
  d.devnode = fmt::format("/dev/bus/usb/{:03d}/{:03d}", config_.busNumber, config_.deviceNumber);
  d.syspath = fmt::format("/sys/devices/{}-{}", config_.busNumber, config_.deviceNumber);
  d.testbed = sharedTestbed();
  d.context = g_main_context_new();
  d.thread = std::thread([&d] {
    g_main_context_push_thread_default(d.context);
    while (!d.stop.load()) g_main_context_iteration(d.context, TRUE);
    // Let pending completions flush before the context goes away.
    while (g_main_context_iteration(d.context, FALSE)) {
    }
    g_main_context_pop_thread_default(d.context);
  });
}

EmulatedUsbDisplay::~EmulatedUsbDisplay() {
  Impl& d = *impl_;
  try {
    d.runOnHandlerThread([&d] {
      {
        std::lock_guard lock(d.mutex);
        for (Urb& u : d.done) release(u);
        for (Urb& u : d.held) release(u);
        d.done.clear();
        d.held.clear();
      }
      d.detachHandler();
    });
  } catch (...) {
  }
  d.removeFromTestbed();  // (the testbed is shared: the next device must not find this one)
  d.stop = true;
  g_main_context_wakeup(d.context);
  d.thread.join();
  g_main_context_unref(d.context);
}

void EmulatedUsbDisplay::plug() {
  Impl& d = *impl_;
  {
    std::lock_guard lock(d.mutex);
    if (!d.unplugged) return;
  }
  d.runOnHandlerThread([&d] {
    d.detachHandler();
    d.attachHandler();
  });
  {
    std::lock_guard lock(d.mutex);
    d.unplugged = false;
    d.halted = false;
    d.resetFrame();
    d.state.plugged = true;
    d.state.claimed = false;
  }
  GError* error = nullptr;
  if (!umockdev_testbed_add_from_string(d.testbed, d.description().c_str(), &error)) {
    std::string message = error ? error->message : "unknown error";
    g_clear_error(&error);
    fail(Errc::Device, "emulated display: adding the device to the testbed failed: {}", message);
  }
  d.inTestbed = true;
  umockdev_testbed_uevent(d.testbed, d.syspath.c_str(), "add");
}

void EmulatedUsbDisplay::unplug() {
  Impl& d = *impl_;
  {
    std::lock_guard lock(d.mutex);
    d.failAll();
    d.state.plugged = false;
    d.state.claimed = false;
  }
  d.removeFromTestbed();
}

void EmulatedUsbDisplay::loseNode() { impl_->removeNode(); }

void EmulatedUsbDisplay::stallNextFrame(int urb) {
  std::lock_guard lock(impl_->mutex);
  impl_->stallNextAt = urb;
}
void EmulatedUsbDisplay::shortenNextFrame(int urb, int bytes) {
  std::lock_guard lock(impl_->mutex);
  impl_->shortNextAt = urb;
  impl_->shortNextBy = bytes;
}
void EmulatedUsbDisplay::unplugAtRequest(usbdisplay::Request request) {
  std::lock_guard lock(impl_->mutex);
  impl_->unplugAtRequest = static_cast<int>(request);
}
void EmulatedUsbDisplay::failClaim(int errnoValue) {
  std::lock_guard lock(impl_->mutex);
  impl_->claimErrno = errnoValue;
}
void EmulatedUsbDisplay::stallAlways(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->stallAll = on;
}
void EmulatedUsbDisplay::corruptNextFrame() {
  std::lock_guard lock(impl_->mutex);
  impl_->corruptNext = true;
}
void EmulatedUsbDisplay::truncateNextFrame(std::size_t bytes) {
  std::lock_guard lock(impl_->mutex);
  impl_->truncateNext = bytes;
}
void EmulatedUsbDisplay::unplugDuringNextFrame() {
  std::lock_guard lock(impl_->mutex);
  impl_->unplugNext = true;
}
void EmulatedUsbDisplay::setSilent(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->silent = on;
}
void EmulatedUsbDisplay::silentAfterBulkUrbs(int urbs) {
  std::lock_guard lock(impl_->mutex);
  impl_->silentAfterUrbs = urbs;
}
void EmulatedUsbDisplay::silentAtNextPresent() {
  std::lock_guard lock(impl_->mutex);
  impl_->silentAtPresent = true;
}
void EmulatedUsbDisplay::failClearHalt(int errnoValue) {
  std::lock_guard lock(impl_->mutex);
  impl_->clearHaltErrno = errnoValue;
}
void EmulatedUsbDisplay::setAbsurdDeviceInfo(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->absurdInfo = on;
}
void EmulatedUsbDisplay::setBadCalibrationCrc(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->badCalibrationCrc = on;
}
void EmulatedUsbDisplay::lieInStatus(int brightness, std::int64_t presentedSequence) {
  std::lock_guard lock(impl_->mutex);
  impl_->statusBrightness = brightness;
  impl_->statusPresentedSequence = presentedSequence;
}
void EmulatedUsbDisplay::forgetErrors(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->forgetErrors = on;
}

EmulatedDisplayState EmulatedUsbDisplay::state() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->state;
}

cv::Mat EmulatedUsbDisplay::presented() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->presented.clone();
}

std::string EmulatedUsbDisplay::syspath() const { return impl_->syspath; }

void usePrivateTmpDir() {
  // Never destroyed: the atexit handler below runs after static destructors.
  static const std::string* dir = [] {
    std::string pattern = (std::filesystem::temp_directory_path() / "lfi-usb-test.XXXXXX").string();
    if (!mkdtemp(pattern.data())) fail(Errc::Io, "cannot create a private TMPDIR from '{}'", pattern);
    setenv("TMPDIR", pattern.c_str(), 1);
    auto* path = new std::string(pattern);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(*dir, ec);
    });
    return path;
  }();
}

bool umockdevPreloadActive() {
  const char* preload = std::getenv("LD_PRELOAD");
  return preload && std::strstr(preload, "libumockdev-preload") != nullptr;
}

}  // namespace lfi::testing_support
