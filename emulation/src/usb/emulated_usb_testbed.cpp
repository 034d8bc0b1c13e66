// SPDX-License-Identifier: Apache-2.0
// The emulated USB display's plumbing: umockdev's shared testbed, the ioctl handler on its
// own GLib main context thread, and the usbdevfs ioctls libusb sends (URBs submitted, reaped,
// discarded; claim, clear halt), handed to the device side in emulated_usb_device.cpp.

#include "emulated_usb_display_impl.h"

#include "lfi/core/error.h"

#include <fmt/format.h>
#include <linux/usbdevice_fs.h>
#include <sys/ioctl.h>
#include <umockdev.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <future>
#include <mutex>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace lfi::emulation {
namespace {

std::string hex(const std::vector<std::uint8_t>& bytes) {
  std::string out;
  for (std::uint8_t b : bytes) out += fmt::format("{:02X}", b);
  return out;
}

}  // namespace

void release(Urb& u) {
  if (u.buffer) g_object_unref(u.buffer);
  if (u.urb) g_object_unref(u.urb);
  if (u.client) g_object_unref(u.client);
  u = {};
}

UMockdevTestbed* sharedTestbed() {
  static UMockdevTestbed* const testbed = umockdev_testbed_new();
  return testbed;
}

// Runs `f` on the handler thread and waits for it (umockdev's handler objects
// belong to that thread's main context; never called on that thread). GLib
// hands the source to the thread under the context's lock, a futex that
// ThreadSanitizer does not see: `posted`, released once the source and the
// call are made and acquired first on the handler thread, is the hand-over it
// sees, of the call and of the source GLib frees there.
void EmulatedUsbDisplay::Impl::runOnHandlerThread(const std::function<void()>& f) {
  struct Call {
    const std::function<void()>* f;
    std::promise<void> done;
    std::atomic<bool> posted{false};
  } call{&f, {}};
  auto future = call.done.get_future();
  GSource* source = g_idle_source_new();
  g_source_set_priority(source, G_PRIORITY_DEFAULT);  // (as g_main_context_invoke)
  g_source_set_callback(
      source,
      [](gpointer data) -> gboolean {
        auto* c = static_cast<Call*>(data);
        c->posted.load(std::memory_order_acquire);
        try {
          (*c->f)();
          c->done.set_value();
        } catch (...) {
          c->done.set_exception(std::current_exception());
        }
        return G_SOURCE_REMOVE;
      },
      &call, nullptr);
  call.posted.store(true, std::memory_order_release);
  g_source_attach(source, context);
  g_source_unref(source);
  future.get();
}

void EmulatedUsbDisplay::Impl::attachHandler() {
  handler = UMOCKDEV_IOCTL_BASE(g_object_new(UMOCKDEV_TYPE_IOCTL_BASE, nullptr));
  g_signal_connect(handler, "handle-ioctl",
                   G_CALLBACK(+[](UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) -> gboolean {
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
void EmulatedUsbDisplay::Impl::removeNode() const {
  std::error_code ec;
  gchar* root = umockdev_testbed_get_root_dir(testbed);  // transfer full
  std::filesystem::remove(std::filesystem::path(root) / devnode.substr(1), ec);
  g_free(root);
}

// Takes the device out of the (shared) testbed, for good.
void EmulatedUsbDisplay::Impl::removeFromTestbed() {
  if (!std::exchange(inTestbed, false)) return;
  umockdev_testbed_uevent(testbed, syspath.c_str(), "remove");
  umockdev_testbed_remove_device(testbed, syspath.c_str());
  removeNode();
}

void EmulatedUsbDisplay::Impl::detachHandler() {
  if (!handler) return;
  GError* error = nullptr;
  umockdev_testbed_detach_ioctl(testbed, devnode.c_str(), &error);
  g_clear_error(&error);
  g_object_unref(handler);
  handler = nullptr;
}

std::string EmulatedUsbDisplay::Impl::description() const {
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
      config.busNumber, config.deviceNumber, node, devnode, config.vendorId, config.productId, config.busNumber,
      config.deviceNumber, config.busNumber, config.deviceNumber, config.vendorId, config.productId, config.vendor,
      config.model, config.serial, (config.busNumber - 1) * 128 + config.deviceNumber - 1, hex(d));
}

// ---- device side, on the handler thread, under `mutex` ----

gboolean EmulatedUsbDisplay::Impl::onIoctl(UMockdevIoctlClient* client) {
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

gboolean EmulatedUsbDisplay::Impl::submit(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
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
    if (unplugAfterUrbs >= 0 && unplugAfterUrbs-- == 0) {  // this URB and everything pending fail as it goes
      u.status = -ESHUTDOWN;
      done.push_back(u);
      failAll();
      state.plugged = state.claimed = false;
    } else if (silent) {
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

void EmulatedUsbDisplay::Impl::failAll() {
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

}  // namespace lfi::emulation
