// SPDX-License-Identifier: Apache-2.0
#pragma once
// Wire pixel formats → the stack's image types (image.h). The packed 12-bit
// formats carry two pixels in three bytes, packed continuously over the whole
// image (no per-line padding), in two incompatible layouts:
//
//   format         byte 0        byte 1                       byte 2
//   Mono12Packed   p0[11:4]      p1[3:0] << 4 | p0[3:0]       p1[11:4]     (GigE Vision 1.x, 0x010C0006)
//   Mono12p        p0[7:0]       p1[3:0] << 4 | p0[11:8]      p1[11:4]     (PFNC, LSB first, 0x010C0047)
//
// Both unpack to CV_16UC1 with the value in the low 12 bits.

#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>

namespace lfi {

enum class Mono12Packing { GigEVisionPacked, Pfnc };

// Bytes one image takes on the wire: ceil(width × height × 1.5).
std::size_t mono12PackedSize(int width, int height);

// Unpacks width × height pixels from `data` (at least mono12PackedSize bytes)
// into `out`, which is (re)allocated only if its size or type differ or it is
// not continuous (a view into a larger image).
void unpackMono12(const std::uint8_t* data, std::size_t size, int width, int height, Mono12Packing packing,
                  cv::Mat& out);

}  // namespace lfi
