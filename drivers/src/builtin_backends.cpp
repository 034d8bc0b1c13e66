// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/builtin_backends.h"

#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/usb/usb_display.h"
#include "lfi/drivers/window/window_display.h"

namespace lfi {

void registerDriverBackends() {
  registerAravisBackend();
  registerUsbBackend();
  registerWindowBackend();
}

}  // namespace lfi
