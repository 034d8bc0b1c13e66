// SPDX-License-Identifier: Apache-2.0
// UsbdevfsNode (usbdevfs_node.h): umockdev's shared testbed, the ioctl handler
// on its own GLib main context thread, and the usbdevfs ioctls libusb sends.

#include "usbdevfs_node.h"

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
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <future>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace lfi::emulation::detail {
namespace {

// The process's one testbed: umockdev's preload library follows the newest
// testbed's directory, so devices emulated at once must share one. Never
// freed (devices come and go in it; usePrivateTmpDir's folder goes at exit).
UMockdevTestbed* sharedTestbed() {
  static UMockdevTestbed* const testbed = umockdev_testbed_new();
  return testbed;
}

// Drops the umockdev references `u` holds and empties it.
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

}  // namespace

int Urb::length() const {
  return reinterpret_cast<const usbdevfs_urb*>(urb->data)->buffer_length;
}

UsbdevfsNode::UsbdevfsNode(int busNumber, int deviceNumber, std::string name, UsbdevfsDevice& device)
    : busNumber_(busNumber),
      deviceNumber_(deviceNumber),
      devnode_(fmt::format("/dev/bus/usb/{:03d}/{:03d}", busNumber, deviceNumber)),
      syspath_(fmt::format("/sys/devices/{}-{}", busNumber, deviceNumber)),
      name_(std::move(name)),
      device_(device),
      testbed_(sharedTestbed()),
      context_(g_main_context_new()),
      trace_(std::getenv("LFI_USB_EMULATION_TRACE") != nullptr) {
  thread_ = std::thread([this] {
    g_main_context_push_thread_default(context_);
    while (!stop_.load()) g_main_context_iteration(context_, TRUE);
    // Let pending completions flush before the context goes away.
    while (g_main_context_iteration(context_, FALSE)) {
    }
    g_main_context_pop_thread_default(context_);
  });
}

UsbdevfsNode::~UsbdevfsNode() {
  try {
    runOnHandlerThread([this] {
      {
        std::lock_guard lock(mutex_);
        for (Urb& u : done_) release(u);
        for (Urb& u : held_) release(u);
        done_.clear();
        held_.clear();
      }
      detachHandler();
    });
  } catch (...) {
  }
  removeFromTestbed();  // (the testbed is shared: the next device must not find this one)
  stop_ = true;
  g_main_context_wakeup(context_);
  thread_.join();
  g_main_context_unref(context_);
}

// Runs `f` on the handler thread and waits for it (umockdev's handler objects
// belong to that thread's main context; never called on that thread). GLib
// hands the source to the thread under the context's lock, a futex that
// ThreadSanitizer does not see: `posted`, released once the source and the
// call are made and acquired first on the handler thread, is the hand-over it
// sees, of the call and of the source GLib frees there.
void UsbdevfsNode::runOnHandlerThread(const std::function<void()>& f) {
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
  g_source_attach(source, context_);
  g_source_unref(source);
  future.get();
}

void UsbdevfsNode::attachHandler() {
  handler_ = UMOCKDEV_IOCTL_BASE(g_object_new(UMOCKDEV_TYPE_IOCTL_BASE, nullptr));
  g_signal_connect(handler_, "handle-ioctl",
                   G_CALLBACK(+[](UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) -> gboolean {
                     return static_cast<UsbdevfsNode*>(self)->onIoctl(client);
                   }),
                   this);
  GError* error = nullptr;
  if (!umockdev_testbed_attach_ioctl(testbed_, devnode_.c_str(), handler_, &error)) {
    std::string message = error ? error->message : "unknown error";
    g_clear_error(&error);
    fail(Errc::Device, "{}: attaching the ioctl handler to {} failed: {}", name_, devnode_, message);
  }
}

void UsbdevfsNode::detachHandler() {
  if (!handler_) return;
  GError* error = nullptr;
  umockdev_testbed_detach_ioctl(testbed_, devnode_.c_str(), &error);
  g_clear_error(&error);
  g_object_unref(handler_);
  handler_ = nullptr;
}

// The device's node file (not part of the sysfs tree umockdev removes).
void UsbdevfsNode::removeNode() const {
  std::error_code ec;
  gchar* root = umockdev_testbed_get_root_dir(testbed_);  // transfer full
  std::filesystem::remove(std::filesystem::path(root) / devnode_.substr(1), ec);
  g_free(root);
}

// Takes the device out of the (shared) testbed, for good.
void UsbdevfsNode::removeFromTestbed() {
  if (!std::exchange(inTestbed_, false)) return;
  umockdev_testbed_uevent(testbed_, syspath_.c_str(), "remove");
  umockdev_testbed_remove_device(testbed_, syspath_.c_str());
  removeNode();
}

void UsbdevfsNode::plug(const std::string& record) {
  runOnHandlerThread([this] {
    detachHandler();
    attachHandler();
  });
  {
    std::lock_guard lock(mutex_);
    vanished_ = false;
  }
  GError* error = nullptr;
  if (!umockdev_testbed_add_from_string(testbed_, record.c_str(), &error)) {
    std::string message = error ? error->message : "unknown error";
    g_clear_error(&error);
    fail(Errc::Device, "{}: adding the device to the testbed failed: {}", name_, message);
  }
  inTestbed_ = true;
  umockdev_testbed_uevent(testbed_, syspath_.c_str(), "add");
}

void UsbdevfsNode::unplug() {
  {
    std::lock_guard lock(mutex_);
    vanish();
  }
  removeFromTestbed();
}

void UsbdevfsNode::vanish() {
  for (Urb& u : held_) {
    u.status = -ESHUTDOWN;
    u.actualLength = 0;
    done_.push_back(u);
  }
  held_.clear();
  for (Urb& u : done_)
    if (u.status == 0 && u.bulk) u.status = -ESHUTDOWN;
  vanished_ = true;
}

Urb* UsbdevfsNode::oldestHeld(unsigned char endpoint) {
  auto it = std::find_if(held_.begin(), held_.end(), [&](const Urb& u) { return u.endpoint == endpoint; });
  return it == held_.end() ? nullptr : &*it;
}

void UsbdevfsNode::complete(Urb* urb) {
  auto it = std::find_if(held_.begin(), held_.end(), [&](const Urb& u) { return &u == urb; });
  if (it == held_.end()) return;
  done_.push_back(*it);
  held_.erase(it);
}

// ---- on the handler thread ----

int UsbdevfsNode::onIoctl(UMockdevIoctlClient* client) {
  std::lock_guard lock(mutex_);
  const gulong request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  GError* error = nullptr;
  auto finish = [&](long result, int err) {
    if (trace_) std::fprintf(stderr, "%s: ioctl 0x%lx -> %ld errno %d\n", name_.c_str(), request, result, err);
    umockdev_ioctl_client_complete(client, result, err);
  };
  auto argument = [&](std::size_t size) -> std::uint8_t* {
    UMockdevIoctlData* data = umockdev_ioctl_data_resolve(arg, 0, size, &error);
    return data ? data->data : nullptr;
  };

  if (request == USBDEVFS_REAPURB || request == USBDEVFS_REAPURBNDELAY) {
    auto it = std::find_if(done_.begin(), done_.end(), [&](const Urb& u) { return u.client == client; });
    if (it == done_.end()) {
      finish(-1, vanished_ ? ENODEV : EAGAIN);
      return TRUE;
    }
    Urb u = *it;
    done_.erase(it);
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
    if (u.bulk && bulkInFlight_ > 0) --bulkInFlight_;
    release(u);
    finish(0, 0);
    return TRUE;
  }
  if (vanished_) {
    finish(-1, ENODEV);
    return TRUE;
  }
  switch (request) {
    case USBDEVFS_GET_CAPABILITIES: {
      std::uint8_t* data = argument(sizeof(std::uint32_t));
      if (!data) break;
      // What an xHCI controller reports: scatter-gather makes libusb send one URB per transfer.
      const std::uint32_t caps = USBDEVFS_CAP_ZERO_PACKET | USBDEVFS_CAP_BULK_CONTINUATION |
                                 USBDEVFS_CAP_NO_PACKET_SIZE_LIM | USBDEVFS_CAP_BULK_SCATTER_GATHER |
                                 USBDEVFS_CAP_REAP_AFTER_DISCONNECT;
      std::memcpy(data, &caps, sizeof(caps));
      finish(0, 0);
      return TRUE;
    }
    case USBDEVFS_CLAIMINTERFACE:
    case USBDEVFS_RELEASEINTERFACE: {
      std::uint8_t* data = argument(sizeof(unsigned));
      if (!data) break;
      unsigned interface = 0;
      std::memcpy(&interface, data, sizeof(interface));
      const int err = device_.claimInterface(interface, request == USBDEVFS_CLAIMINTERFACE);
      finish(err ? -1 : 0, err);
      return TRUE;
    }
    case USBDEVFS_DISCONNECT_CLAIM: {  // (libusb with auto-detach on: claim, detaching a kernel driver first)
      std::uint8_t* data = argument(sizeof(usbdevfs_disconnect_claim));
      if (!data) break;
      unsigned interface = 0;
      std::memcpy(&interface, data, sizeof(interface));
      const int err = device_.claimInterface(interface, true);
      finish(err ? -1 : 0, err);
      return TRUE;
    }
    case USBDEVFS_CLEAR_HALT: {
      std::uint8_t* data = argument(sizeof(unsigned));
      if (!data) break;
      unsigned endpoint = 0;
      std::memcpy(&endpoint, data, sizeof(endpoint));
      const int err = device_.clearHalt(endpoint);
      finish(err ? -1 : 0, err);
      return TRUE;
    }
    case USBDEVFS_GETDRIVER:
      finish(-1, ENODATA);
      return TRUE;
    case USBDEVFS_DISCARDURB: {
      // The argument is the URB's address itself.
      gulong address = 0;
      std::memcpy(&address, arg->data, sizeof(address));
      auto it = std::find_if(held_.begin(), held_.end(), [&](const Urb& u) { return u.urb->client_addr == address; });
      if (it == held_.end()) {
        finish(-1, EINVAL);
        return TRUE;
      }
      it->status = -ENOENT;
      it->actualLength = 0;
      done_.push_back(*it);
      held_.erase(it);
      finish(0, 0);
      return TRUE;
    }
    case USBDEVFS_SUBMITURB:
      submit(client, arg);
      return TRUE;
    default:
      finish(-1, ENOTTY);
      return TRUE;
  }
  g_clear_error(&error);
  finish(-1, EFAULT);
  return TRUE;
}

void UsbdevfsNode::submit(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
  GError* error = nullptr;
  UMockdevIoctlData* urbData = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_urb), &error);
  if (!urbData) {
    g_clear_error(&error);
    umockdev_ioctl_client_complete(client, -1, EFAULT);
    return;
  }
  auto* urb = reinterpret_cast<usbdevfs_urb*>(urbData->data);
  UMockdevIoctlData* bufData = nullptr;
  if (urb->buffer_length > 0) {
    bufData = umockdev_ioctl_data_resolve(urbData, offsetof(usbdevfs_urb, buffer),
                                          static_cast<gsize>(urb->buffer_length), &error);
    if (!bufData) {
      g_clear_error(&error);
      umockdev_ioctl_client_complete(client, -1, EFAULT);
      return;
    }
  }
  const bool control = urb->type == USBDEVFS_URB_TYPE_CONTROL && urb->buffer_length >= 8;
  if (!control && urb->type != USBDEVFS_URB_TYPE_BULK) {
    umockdev_ioctl_client_complete(client, -1, EINVAL);
    return;
  }
  Urb u;
  u.client = static_cast<UMockdevIoctlClient*>(g_object_ref(client));
  u.urb = static_cast<UMockdevIoctlData*>(g_object_ref(urbData));
  u.buffer = bufData ? static_cast<UMockdevIoctlData*>(g_object_ref(bufData)) : nullptr;
  u.endpoint = control ? 0 : urb->endpoint;
  u.bulk = !control;
  if (u.bulk) ++bulkInFlight_;
  switch (device_.submit(u)) {
    case UsbdevfsDevice::Submitted::Complete:
      done_.push_back(u);
      if (vanished_) vanish();  // (the device vanished with this URB: it and what is pending fail)
      break;
    case UsbdevfsDevice::Submitted::Hold:
      held_.push_back(u);
      if (vanished_) vanish();
      break;
    case UsbdevfsDevice::Submitted::Refuse:
      if (u.bulk) --bulkInFlight_;
      release(u);
      umockdev_ioctl_client_complete(client, -1, EINVAL);
      return;
  }
  umockdev_ioctl_client_complete(client, 0, 0);
}

std::string recordText(const UsbdevfsNode& node, const UsbRecord& r) {
  const int busNumber = node.busNumber(), deviceNumber = node.deviceNumber();
  return fmt::format(
      "P: {}\n"
      "N: {}\n"
      "E: SUBSYSTEM=usb\n"
      "E: DEVTYPE=usb_device\n"
      "E: DEVNAME={}\n"
      "E: PRODUCT={:x}/{:x}/100\n"
      "E: BUSNUM={:03d}\n"
      "E: DEVNUM={:03d}\n"
      "E: MAJOR=189\n"
      "E: MINOR={}\n"
      "A: busnum={}\\n\n"
      "A: devnum={}\\n\n"
      "A: speed={}\\n\n"
      "A: idVendor={:04x}\\n\n"
      "A: idProduct={:04x}\\n\n"
      "A: bConfigurationValue=1\\n\n"
      "A: bNumConfigurations=1\\n\n"
      "A: bNumInterfaces= {}\\n\n"
      "A: manufacturer={}\\n\n"
      "A: product={}\\n\n"
      "A: serial={}\\n\n"
      "A: dev=189:{}\\n\n"
      "H: descriptors={}\n",
      node.syspath().substr(4), node.devnode().substr(5), node.devnode(), r.vendorId, r.productId, busNumber,
      deviceNumber, (busNumber - 1) * 128 + deviceNumber - 1, busNumber, deviceNumber, r.speed_mbps, r.vendorId,
      r.productId, r.interfaces, r.manufacturer, r.product, r.serial, (busNumber - 1) * 128 + deviceNumber - 1,
      hex(r.descriptors));
}

void appendDeviceDescriptor(std::vector<std::uint8_t>& out, const UsbDeviceDescriptor& d) {
  auto u16 = [&](std::uint16_t v) {
    out.push_back(static_cast<std::uint8_t>(v));
    out.push_back(static_cast<std::uint8_t>(v >> 8));
  };
  out.insert(out.end(), {18, 1});
  u16(d.usbRelease);
  out.insert(out.end(), {d.deviceClass, d.deviceSubclass, d.deviceProtocol, d.maxPacket0});
  u16(d.vendorId);
  u16(d.productId);
  u16(d.deviceRelease);
  out.insert(out.end(), {d.manufacturerString, d.productString, d.serialString, 1});
}

std::vector<std::uint8_t> stringDescriptor(const std::string& text) {
  std::vector<std::uint8_t> d{static_cast<std::uint8_t>(2 + 2 * text.size()), 3};
  for (char c : text) {
    d.push_back(static_cast<std::uint8_t>(c));
    d.push_back(0);
  }
  return d;
}

}  // namespace lfi::emulation::detail
