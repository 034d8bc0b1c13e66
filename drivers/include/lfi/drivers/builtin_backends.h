// SPDX-License-Identifier: Apache-2.0
#pragma once
// The backends built into lfi_drivers, registered explicitly so that static
// linking cannot drop one. The other libraries register their own the same
// way: lfi::sim::registerSimBackends() (sim:),
// lfi::registerControllerBackends() (coded:).

namespace lfi {

// Registers aravis: (cameras, aravis/aravis_camera.h), usb: and window:
// (displays, usb/usb_display.h, window/window_display.h). Idempotent.
void registerDriverBackends();

}  // namespace lfi
