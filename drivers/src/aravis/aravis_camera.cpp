// SPDX-License-Identifier: Apache-2.0
// The Aravis backend's Camera (aravis_camera.h): opening and closing the device,
// its info and generic feature access. Every Aravis call that takes a GError is
// checked; failures become lfi::Error naming the device and the call.

#include "aravis_camera_impl.h"

#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/driver_trace.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <memory>

namespace lfi {
namespace detail {
namespace {

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

}  // namespace

std::string orEmpty(const char* s) {
  return s != nullptr ? std::string(s) : std::string();
}

// Throws if `error` is set, freeing it. `call` names the Aravis function (and feature).
void check(GError* error, const std::string& device, const std::string& call) {
  if (driverTraceOn()) {
    const auto args = call.find('(');
    traceDriverCall("aravis", device, call.substr(0, args),
                    (args == std::string::npos ? std::string() : call.substr(args)) +
                        (error ? " failed: " + orEmpty(error->message) : std::string()));
  }
  if (error == nullptr) return;
  const Errc code = errcFor(error);
  const std::string message = orEmpty(error->message);
  g_error_free(error);
  fail(code, "camera '{}': {} failed: {}", device, call, message);
}

void AravisCamera::open() {
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
    traceDriverCall("aravis", name(), "arv_camera_new");
    camera_ = throughLoopbackIfOwnAddress(std::exchange(camera_, nullptr), name());
  }
  if (options_.usbMode) {  // (read when the stream is made; Aravis sets its default when the device is)
    if (!arv_camera_is_uv_device(camera_)) {
      releaseDevice();
      fail(Errc::Config, "camera '{}': usb_mode applies to USB3 Vision devices; this one is not", name());
    }
    arv_camera_uv_set_usb_mode(
        camera_, *options_.usbMode == AravisUsbMode::Async ? ARV_UV_USB_MODE_ASYNC : ARV_UV_USB_MODE_SYNC);
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

void AravisCamera::close() noexcept {
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

CameraInfo AravisCamera::info() const {
  requireCameraState(state_, {State::Open, State::Configured, State::Streaming}, "info", name());
  return info_;
}

std::string AravisCamera::getFeature(const std::string& feature) {
  ArvGcFeatureNode* node = featureNode("getFeature", feature);
  return onDevice([&] {
    GError* error = nullptr;
    const char* value = arv_gc_feature_node_get_value_as_string(node, &error);
    check(error, name(), fmt::format("reading feature '{}'", feature));
    return orEmpty(value);
  });
}

void AravisCamera::setFeature(const std::string& feature, const std::string& value) {
  ArvGcFeatureNode* node = featureNode("setFeature", feature);
  streamSettings_.reset();  // (it may change what settings() reads)
  onDevice([&] {
    GError* error = nullptr;
    arv_gc_feature_node_set_value_from_string(node, value.c_str(), &error);
    check(error, name(), fmt::format("setting feature '{}' to '{}'", feature, value));
  });
}

std::int64_t AravisCamera::getIntegerFeature(const std::string& feature) {
  featureNode("getIntegerFeature", feature);
  return onDevice([&] {
    GError* error = nullptr;
    const gint64 value = arv_camera_get_integer(camera_, feature.c_str(), &error);
    check(error, name(), fmt::format("reading integer feature '{}'", feature));
    return value;
  });
}

void AravisCamera::setIntegerFeature(const std::string& feature, std::int64_t value) {
  featureNode("setIntegerFeature", feature);
  streamSettings_.reset();  // (it may change what settings() reads)
  onDevice([&] {
    GError* error = nullptr;
    arv_camera_set_integer(camera_, feature.c_str(), value, &error);
    check(error, name(), fmt::format("setting integer feature '{}' to {}", feature, value));
  });
}

double AravisCamera::getFloatFeature(const std::string& feature) {
  featureNode("getFloatFeature", feature);
  return onDevice([&] {
    GError* error = nullptr;
    const double value = arv_camera_get_float(camera_, feature.c_str(), &error);
    check(error, name(), fmt::format("reading float feature '{}'", feature));
    return value;
  });
}

void AravisCamera::setFloatFeature(const std::string& feature, double value) {
  featureNode("setFloatFeature", feature);
  streamSettings_.reset();  // (it may change what settings() reads)
  onDevice([&] {
    GError* error = nullptr;
    arv_camera_set_float(camera_, feature.c_str(), value, &error);
    check(error, name(), fmt::format("setting float feature '{}' to {}", feature, value));
  });
}

void AravisCamera::executeCommand(const std::string& feature) {
  featureNode("executeCommand", feature);
  streamSettings_.reset();  // (it may change what settings() reads)
  GError* error = nullptr;
  arv_camera_execute_command(camera_, feature.c_str(), &error);
  check(error, name(), fmt::format("executing command '{}'", feature));
}

// Everything open() does once Aravis has a camera object.
void AravisCamera::connectDevice() {
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

void AravisCamera::releaseDevice() noexcept {
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

void AravisCamera::readInfo() {
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
void AravisCamera::readSensorSize() {
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

ArvGcFeatureNode* AravisCamera::featureNode(const char* method, const std::string& feature) {
  requireCameraState(state_, {State::Open, State::Configured, State::Streaming}, method, name());
  ArvGcNode* node = arv_device_get_feature(arv_camera_get_device(camera_), feature.c_str());
  if (node == nullptr || !ARV_IS_GC_FEATURE_NODE(node))
    fail(Errc::NotFound, "camera '{}': {}('{}'): the device has no such feature", name(), method, feature);
  return ARV_GC_FEATURE_NODE(node);
}

}  // namespace detail

std::unique_ptr<Camera> openAravisCamera(const std::string& deviceId, const AravisOptions& options) {
  return std::make_unique<detail::AravisCamera>(deviceId, options);
}

}  // namespace lfi
