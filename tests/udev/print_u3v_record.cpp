// SPDX-License-Identifier: Apache-2.0
// Prints the emulated USB3 Vision camera's umockdev record (EmulatedU3vCamera::record)
// with serial argv[1], for udev_rules_test.sh: the rules are tested on the device
// the USB3 Vision tests use, not on a description of one.

#include "lfi/emulation/emulated_u3v_camera.h"

#include <cstdio>

int main(int argc, char** argv) {
  lfi::emulation::EmulatedU3vCameraConfig config;
  if (argc > 1) config.serial = argv[1];
  const lfi::emulation::EmulatedU3vCamera camera(config, [](const auto&, auto&) {});
  std::fputs(camera.record().c_str(), stdout);
  return 0;
}
