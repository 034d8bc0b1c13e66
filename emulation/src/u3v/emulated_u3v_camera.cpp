// SPDX-License-Identifier: Apache-2.0
// EmulatedU3vCamera (emulated_u3v_camera.h): plugging the device in and out,
// reading its state and firing its input line from the test thread.

#include "lfi/emulation/emulated_u3v_camera.h"

#include "u3v_camera_impl.h"
#include "u3v_registers.h"

#include <mutex>
#include <utility>

namespace lfi::emulation {

EmulatedU3vCamera::EmulatedU3vCamera(EmulatedU3vCameraConfig config, ServedFrameFiller filler)
    : config_(std::move(config)), impl_(new Impl(config_, std::move(filler))) {}

EmulatedU3vCamera::~EmulatedU3vCamera() = default;

void EmulatedU3vCamera::plug() {
  Impl& d = *impl_;
  {
    std::lock_guard lock(d.node.mutex());
    if (!d.node.vanished()) return;
    d.resetRegisters();
    d.acks.clear();
    d.stream.clear();
    d.queuedFrames = 0;
    d.streamHalted = false;
    d.pendingTriggers = d.framesLeft = 0;
    d.stallAll = d.corruptTrailerNext = d.silent = false;  // (a device plugged in afresh)
    d.shortNext = 0;
    d.failNext = 0;
    d.state = {};
    d.state.plugged = true;
  }
  d.node.plug(d.record());
}

void EmulatedU3vCamera::unplug() {
  Impl& d = *impl_;
  {
    std::lock_guard lock(d.node.mutex());
    d.state.plugged = d.state.controlClaimed = d.state.streamClaimed = false;
    d.state.acquiring = d.state.streamEnabled = false;
  }
  d.node.unplug();
}

std::string EmulatedU3vCamera::record() const {
  return impl_->record();
}

std::string emulatedU3vDeviceId(const EmulatedU3vCameraConfig& config) {
  return config.vendor + "-" + emulatedU3vGuid(config) + "-" + config.serial;
}

EmulatedU3vCameraState EmulatedU3vCamera::state() const {
  std::lock_guard lock(impl_->node.mutex());
  return impl_->state;
}

bool EmulatedU3vCamera::fireLine() {
  Impl& d = *impl_;
  std::lock_guard lock(d.node.mutex());
  if (!d.state.acquiring || d.reg(u3v::kRegTriggerMode) != u3v::kTriggerModeOn ||
      d.reg(u3v::kRegTriggerSource) != u3v::kTriggerSourceLine0)
    return false;
  ++d.pendingTriggers;
  d.wake.notify_all();
  return true;
}

void EmulatedU3vCamera::stallStream(bool on) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->stallAll = on;
  if (!on) impl_->deliverStream();
}
void EmulatedU3vCamera::shortenNextFrame(std::size_t bytes) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->shortNext = bytes;
}
void EmulatedU3vCamera::corruptNextTrailer() {
  std::lock_guard lock(impl_->node.mutex());
  impl_->corruptTrailerNext = true;
}
void EmulatedU3vCamera::failNextCommand(std::uint16_t status) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->failNext = status;
}
void EmulatedU3vCamera::setSilent(bool on) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->silent = on;
}

}  // namespace lfi::emulation
