// SPDX-License-Identifier: Apache-2.0
// A received GigE Vision buffer's image as the Aravis backend checks it (drivers/src/aravis/image_payload.h): the
// first 8 bytes are what the GVSP leader would say (the configured format, the image's width and height against
// the stream's, its wire pixel format and line padding), the rest is the payload. An image taken must be the
// configured size and type.
#include "fuzz_input.h"

#include "aravis/aravis_camera_impl.h"
#include "aravis/image_payload.h"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 8) return 0;
  const lfi::PixelFormat formats[] = {lfi::PixelFormat::Mono8, lfi::PixelFormat::Mono12, lfi::PixelFormat::Mono16};
  const lfi::PixelFormat configured = formats[data[0] % 3];
  const int width = 1 + data[1] % 64, height = 1 + data[2] % 64;
  lfi::detail::ImagePayload p;
  p.width = data[3] & 0x80 ? width : static_cast<std::int8_t>(data[3]);  // mostly the stream's, sometimes not
  p.height = data[4] & 0x80 ? height : static_cast<std::int8_t>(data[4]);
  const auto wire = lfi::detail::wireFormats(configured);
  p.pixelFormat = data[5] < 250 ? wire[data[5] % wire.size()].code : 0x01080001u + data[5];
  p.xPadding = static_cast<std::int8_t>(data[6]);
  p.data = data + 8;
  p.size = size - 8;
  cv::Mat out;
  if (!lfi::detail::imageFromPayload(p, configured, width, height, out)) {
    const int type = configured == lfi::PixelFormat::Mono8 ? CV_8UC1 : CV_16UC1;
    if (out.rows != height || out.cols != width || out.type() != type) std::abort();
  }
  return 0;
}
