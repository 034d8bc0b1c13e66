// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_emulation: a USB device's /dev/bus/usb/BBB/DDD node on
// umockdev, the plumbing every emulated USB device shares. The node puts the
// device's sysfs record into the process's testbed, answers the usbdevfs
// ioctls libusb sends on a GLib main context thread of its own, and keeps the
// URBs: submitted, completed and waiting to be reaped, held by the device,
// discarded. What a URB means is the device's (UsbdevfsDevice): the node hands
// it every submitted URB and every claim and clear-halt, on the handler thread
// with the node's lock held.
//
// usbdevfs as libusb uses it (libusb/os/linux_usbfs.c): SUBMITURB (control and
// bulk), REAPURBNDELAY/REAPURB (a completed URB back; EAGAIN when none, ENODEV
// once the device is gone), DISCARDURB (a held URB completes with -ENOENT),
// CLAIMINTERFACE, RELEASEINTERFACE, DISCONNECT_CLAIM (a claim that first
// detaches a kernel driver), CLEAR_HALT, GETDRIVER (ENODATA: no kernel driver),
// GET_CAPABILITIES (an xHCI controller's: scatter-gather, so one URB per
// transfer). umockdev makes the node a regular file, so libusb's poll always
// wakes and it reaps without blocking: the handler never blocks.

#include <umockdev.h>

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace lfi::emulation::detail {

// One URB the host submitted: the umockdev copies of the struct and its buffer
// (kept referenced until reaped) and its outcome, applied at reap time.
struct Urb {
  UMockdevIoctlClient* client = nullptr;
  UMockdevIoctlData* urb = nullptr;
  UMockdevIoctlData* buffer = nullptr;
  unsigned char endpoint = 0;  // with its direction bit; 0 for control
  bool bulk = false;
  int status = 0;
  int actualLength = 0;

  std::uint8_t* bytes() const { return buffer ? buffer->data : nullptr; }
  int length() const;  // the URB's buffer_length
};

// What an emulated USB device does with what reaches its node. Called on the
// node's handler thread with the node's lock held.
class UsbdevfsDevice {
 public:
  enum class Submitted {
    Complete,  // the device set status and actualLength: reapable now
    Hold,      // the device completes it later (UsbdevfsNode::complete) or never (a hung device)
    Refuse,    // SUBMITURB fails with EINVAL (an endpoint the device does not have)
  };

  virtual ~UsbdevfsDevice() = default;
  // A control (endpoint 0: bytes() is the 8-byte setup packet and the data
  // stage) or bulk URB. The device may also vanish here (UsbdevfsNode::vanish).
  virtual Submitted submit(Urb& urb) = 0;
  // CLAIMINTERFACE (claim) and RELEASEINTERFACE: 0 or the errno to fail with.
  virtual int claimInterface(unsigned interface, bool claim) = 0;
  // CLEAR_HALT of `endpoint` (with its direction bit): 0 or an errno.
  virtual int clearHalt(unsigned endpoint) = 0;
};

class UsbdevfsNode {
 public:
  // For the device at /dev/bus/usb/<bus>/<device>, sysfs /sys/devices/<bus>-<device>.
  // `name` names it in errors and in the trace (LFI_USB_EMULATION_TRACE set: every
  // ioctl to stderr).
  UsbdevfsNode(int busNumber, int deviceNumber, std::string name, UsbdevfsDevice& device);
  ~UsbdevfsNode();
  UsbdevfsNode(const UsbdevfsNode&) = delete;
  UsbdevfsNode& operator=(const UsbdevfsNode&) = delete;

  int busNumber() const { return busNumber_; }
  int deviceNumber() const { return deviceNumber_; }
  const std::string& devnode() const { return devnode_; }
  const std::string& syspath() const { return syspath_; }

  // The lock the handler holds while it calls the device: the device's own
  // state is under it too.
  std::mutex& mutex() const { return mutex_; }

  // Adds the device to the testbed: the ioctl handler, then its sysfs record
  // (umockdev's text format: attributes and the binary "descriptors"), then an
  // "add" uevent. Throws Errc::Device if umockdev refuses either.
  void plug(const std::string& record);
  // The device vanishes (vanish()) and leaves the testbed with a "remove" uevent.
  void unplug();
  // The device stays listed (sysfs) but its /dev node is gone: libusb_open fails.
  void removeNode() const;
  // The number of bulk URBs submitted and not yet reaped.
  std::uint32_t bulkInFlight() const { return bulkInFlight_; }

  // ---- under mutex() ----
  // Every held URB fails with -ESHUTDOWN, every completed bulk URB not yet
  // reaped too, and every later ioctl but a reap fails with ENODEV: the host
  // sees the device vanish mid-transfer.
  void vanish();
  bool vanished() const { return vanished_; }
  // The oldest held URB of `endpoint` (with its direction bit), or null.
  Urb* oldestHeld(unsigned char endpoint);
  // Completes held URB `urb` (its status and actualLength set): reapable now.
  void complete(Urb* urb);

 private:
  void runOnHandlerThread(const std::function<void()>& f);
  void attachHandler();
  void detachHandler();
  void removeFromTestbed();
  int onIoctl(UMockdevIoctlClient* client);
  void submit(UMockdevIoctlClient* client, UMockdevIoctlData* arg);

  int busNumber_, deviceNumber_;
  std::string devnode_, syspath_, name_;
  UsbdevfsDevice& device_;
  UMockdevTestbed* testbed_;
  UMockdevIoctlBase* handler_ = nullptr;
  GMainContext* context_ = nullptr;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  bool inTestbed_ = false;  // its record and node are in the testbed (from plug() to unplug())
  bool trace_;

  mutable std::mutex mutex_;
  std::deque<Urb> done_;  // completed, waiting to be reaped
  std::deque<Urb> held_;  // submitted, not completed
  std::uint32_t bulkInFlight_ = 0;
  bool vanished_ = true;  // (until plugged)
};

// The 18 bytes of a USB device descriptor (one configuration), appended to `out`.
struct UsbDeviceDescriptor {
  std::uint16_t usbRelease = 0x0200;  // bcdUSB
  std::uint8_t deviceClass = 0, deviceSubclass = 0, deviceProtocol = 0;
  std::uint8_t maxPacket0 = 64;  // endpoint 0's packets: bytes (USB 2), or a power of two's exponent (USB 3)
  std::uint16_t vendorId = 0, productId = 0, deviceRelease = 0x0100;
  std::uint8_t manufacturerString = 1, productString = 2, serialString = 3;  // 0: none
};
void appendDeviceDescriptor(std::vector<std::uint8_t>& out, const UsbDeviceDescriptor& descriptor);

// A USB device's sysfs record in umockdev's text format: what libusb reads
// (busnum, devnum, speed, bConfigurationValue, the binary descriptors) and what
// udev would have put there.
struct UsbRecord {
  std::uint16_t vendorId = 0, productId = 0;
  std::string manufacturer, product, serial;
  int speed_mbps = 480;
  int interfaces = 1;
  std::vector<std::uint8_t> descriptors;  // device descriptor, then the whole configuration
};
std::string recordText(const UsbdevfsNode& node, const UsbRecord& record);

// USB string descriptor `text` (ASCII) in UTF-16LE.
std::vector<std::uint8_t> stringDescriptor(const std::string& text);

}  // namespace lfi::emulation::detail
