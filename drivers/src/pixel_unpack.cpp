// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/pixel_unpack.h"

#include "lfi/core/error.h"

namespace lfi {

std::size_t mono12PackedSize(int width, int height) {
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  return (pixels * 3 + 1) / 2;
}

void unpackMono12(const std::uint8_t* data, std::size_t size, int width, int height, Mono12Packing packing,
                  cv::Mat& out) {
  if (width <= 0 || height <= 0) fail(Errc::InvalidArgument, "unpackMono12: image size {} x {}", width, height);
  const std::size_t needed = mono12PackedSize(width, height);
  if (size < needed)
    fail(Errc::InvalidArgument, "unpackMono12: {} x {} pixels need {} bytes, the buffer has {}", width, height, needed,
         size);
  if (!out.isContinuous()) out.release();  // (a view into a larger image)
  out.create(height, width, CV_16UC1);     // continuous: the pixels are one sequence, as on the wire
  auto* dst = out.ptr<std::uint16_t>(0);
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  // Two pixels per three bytes; an odd last pixel has the first two bytes of a triple.
  auto pair = [&](const std::uint8_t* t, std::uint16_t& p0, std::uint16_t& p1) {
    if (packing == Mono12Packing::Pfnc) {
      p0 = static_cast<std::uint16_t>(t[0] | ((t[1] & 0x0F) << 8));
      p1 = static_cast<std::uint16_t>((t[1] >> 4) | (t[2] << 4));
    } else {
      p0 = static_cast<std::uint16_t>((t[0] << 4) | (t[1] & 0x0F));
      p1 = static_cast<std::uint16_t>((t[2] << 4) | (t[1] >> 4));
    }
  };
  const std::size_t pairs = pixels / 2;
  for (std::size_t i = 0; i < pairs; ++i) pair(data + 3 * i, dst[2 * i], dst[2 * i + 1]);
  if (pixels % 2) {
    const std::uint8_t last[3] = {data[3 * pairs], data[3 * pairs + 1], 0};
    std::uint16_t unused;
    pair(last, dst[pixels - 1], unused);
  }
}

}  // namespace lfi
