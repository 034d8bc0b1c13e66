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
  out.create(height, width, CV_16UC1);
  // The packing runs across line ends, so walk the pixels as one sequence.
  const bool pfnc = packing == Mono12Packing::Pfnc;
  std::size_t index = 0;
  for (int row = 0; row < height; ++row) {
    auto* dst = out.ptr<std::uint16_t>(row);
    for (int col = 0; col < width; ++col, ++index) {
      const std::uint8_t* triple = data + (index / 2) * 3;
      std::uint16_t value;
      if (index % 2 == 0)
        value = pfnc ? static_cast<std::uint16_t>(triple[0] | ((triple[1] & 0x0F) << 8))
                     : static_cast<std::uint16_t>((triple[0] << 4) | (triple[1] & 0x0F));
      else
        value = pfnc ? static_cast<std::uint16_t>((triple[1] >> 4) | (triple[2] << 4))
                     : static_cast<std::uint16_t>((triple[2] << 4) | (triple[1] >> 4));
      dst[col] = value;
    }
  }
}

}  // namespace lfi
