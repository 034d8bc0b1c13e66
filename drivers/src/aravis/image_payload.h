// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to the Aravis backend: a received buffer's image checked before it
// becomes a frame. Aravis parsed the GVSP leader (size, pixel format, padding)
// and gathered the payload's bytes from the network; nothing of it is trusted
// here. Free of Aravis's types, so that the check runs on any bytes
// (fuzz/gige_payload.cpp).

#include "lfi/drivers/camera.h"

#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace lfi::detail {

struct ImagePayload {
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;  // bytes
  int width = 0, height = 0;
  std::uint32_t pixelFormat = 0;  // PFNC code
  int xPadding = 0;               // bytes after each line
};

// Copies (or unpacks) the payload's image into `out`, reusing its memory when
// the size and type fit and nobody else holds it. Returns why the payload is
// not the image of `configured` format and `width` x `height` px the stream
// started with (`out` then undefined), or nothing.
std::optional<std::string> imageFromPayload(const ImagePayload& payload, PixelFormat configured, int width, int height,
                                            cv::Mat& out);

}  // namespace lfi::detail
