// SPDX-License-Identifier: Apache-2.0
// Device discovery and address handling for the Aravis backend: Aravis's device
// list (listAravisDevices) and reaching a GigE Vision device at one of this host's
// own addresses through loopback.

#include "aravis_camera_impl.h"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>

#include <cstring>

namespace lfi {
namespace detail {

std::mutex& aravisMutex() {
  static std::mutex mutex;
  return mutex;
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

namespace {

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

}  // namespace

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

}  // namespace detail

std::vector<AravisDeviceInfo> listAravisDevices() {
  std::lock_guard lock(detail::aravisMutex());
  return detail::listDevicesLocked(true);
}

}  // namespace lfi
