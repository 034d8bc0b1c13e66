#pragma once
// The method's reference step (README, "the method"): the light field an intact part
// produces under a collimated beam, recorded on the plane where the display
// will sit (plane frame of lfi/core/light_field.h; +z towards the part). One
// interface whatever records it:
//
//   scheme  backend                                          where
//   sim:    the simulated lensless light field sensor         lfi_sim (registerSimBackends)
//           behind the part of a scene file, lit by a
//           collimated beam from the camera side
//
// Opened by URI from its registry (capture_registry.h), like cameras and displays.

#include "lfi/core/light_field.h"

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace lfi {

class LightFieldCapture {
public:
  LightFieldCapture() = default;
  LightFieldCapture(const LightFieldCapture&) = delete;
  LightFieldCapture& operator=(const LightFieldCapture&) = delete;
  LightFieldCapture(LightFieldCapture&&) = delete;
  LightFieldCapture& operator=(LightFieldCapture&&) = delete;
  virtual ~LightFieldCapture() = default;

  // What the capture will record (distance_mm = Δ, the plane's distance to the part).
  virtual LightFieldGeometry geometry() const = 0;
  // Records the light field; `progress` gets the fraction done (0..1) from any thread.
  virtual LightField capture(const std::function<void(double)>& progress = {}) = 0;
  // One line naming the source, for logs and file headers.
  virtual std::string description() const = 0;
};

}  // namespace lfi
