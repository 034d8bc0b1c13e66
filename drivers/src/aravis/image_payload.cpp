// SPDX-License-Identifier: Apache-2.0
#include "image_payload.h"

#include "aravis_camera_impl.h"

#include "lfi/drivers/pixel_unpack.h"

#include <fmt/ranges.h>

#include <algorithm>

namespace lfi::detail {

std::optional<std::string> imageFromPayload(const ImagePayload& p, PixelFormat configured, int width, int height,
                                            cv::Mat& out) {
  if (p.data == nullptr || p.width <= 0 || p.height <= 0)
    return fmt::format("its image is empty ({} x {} px, {} bytes)", p.width, p.height, p.size);
  const auto wire = wireFormats(configured);
  if (std::none_of(wire.begin(), wire.end(), [&](const WireFormat& w) { return w.code == p.pixelFormat; }))
    return fmt::format("its pixel format is 0x{:08x}, not one of {} (configured {})", p.pixelFormat,
                       fmt::join(wireFormatNames(configured), ", "), toString(configured));
  if (p.width != width || p.height != height)  // (the buffers were sized for the region)
    return fmt::format("its image is {} x {} px, not the {} x {} px region the stream started with", p.width, p.height,
                       width, height);
  if (p.xPadding < 0) return fmt::format("its lines carry a padding of {} bytes", p.xPadding);
  if (!out.empty() && (out.u == nullptr || out.u->refcount > 1 || !out.isContinuous() || out.isSubmatrix()))
    out.release();  // a caller still holds the previous image: do not overwrite it
  const auto rows = static_cast<std::size_t>(height);
  if (p.pixelFormat == ARV_PIXEL_FORMAT_MONO_12_PACKED || p.pixelFormat == kPixelFormatMono12p) {
    if (p.xPadding != 0) return fmt::format("its packed lines carry {} bytes of padding", p.xPadding);
    if (p.size < mono12PackedSize(width, height))
      return fmt::format("its {} x {} px packed image needs {} bytes, the payload has {}", width, height,
                         mono12PackedSize(width, height), p.size);
    unpackMono12(p.data, p.size, width, height,
                 p.pixelFormat == kPixelFormatMono12p ? Mono12Packing::Pfnc : Mono12Packing::GigEVisionPacked, out);
    return std::nullopt;
  }
  const int type = p.pixelFormat == ARV_PIXEL_FORMAT_MONO_8 ? CV_8UC1 : CV_16UC1;
  const std::size_t rowBytes = static_cast<std::size_t>(width) * (type == CV_8UC1 ? 1 : 2);
  const std::size_t stride = rowBytes + static_cast<std::size_t>(p.xPadding);
  if (type == CV_16UC1 && stride % 2 != 0)  // (OpenCV takes no 16-bit rows at an odd byte step)
    return fmt::format("its 16-bit lines are padded by an odd {} bytes", p.xPadding);
  if (p.size < stride * (rows - 1) + rowBytes)
    return fmt::format("its {} x {} px image ({} bytes per line) needs {} bytes, the payload has {}", width, height,
                       stride, stride * (rows - 1) + rowBytes, p.size);
  // GigE/USB3 Vision: little endian; padded lines are copied one by one.
  cv::Mat(height, width, type, const_cast<std::uint8_t*>(p.data), stride).copyTo(out);
  return std::nullopt;
}

}  // namespace lfi::detail
