// SPDX-License-Identifier: Apache-2.0
#pragma once
// Finding a device by Aravis discovery in the loopback tests.

#include "lfi/drivers/aravis/aravis_camera.h"

#include <optional>
#include <string>

namespace lfi::testing_support {

// Discovery is a UDP broadcast answered within Aravis's fixed wait: on a
// loaded host (the whole suite on 2 cores) an answer can miss one round, as on
// a real network. Up to `rounds` rounds, as a user would list again; `used`
// counts them.
inline std::optional<AravisDeviceInfo> discoverDevice(const std::string& id, int rounds, int& used) {
  for (used = 1; used <= rounds; ++used)
    for (const AravisDeviceInfo& d : listAravisDevices())
      if (d.id == id) return d;
  used = rounds;
  return std::nullopt;
}

}  // namespace lfi::testing_support
