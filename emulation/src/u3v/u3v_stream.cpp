// SPDX-License-Identifier: Apache-2.0
// The emulated USB3 Vision camera's stream (u3v_camera_impl.h): the frame
// thread that makes frames while the acquisition runs, and the stream
// endpoint's transfers (leader, payload, trailer) handed out to the URBs the
// host submits on bulk IN 0x82.

#include "u3v_camera_impl.h"

#include "u3v_registers.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <mutex>
#include <utility>
#include <vector>

namespace lfi::emulation {
namespace {

using namespace u3v;
using Clock = std::chrono::steady_clock;

constexpr std::uint32_t kLeaderMagic = 0x4C563355, kTrailerMagic = 0x54563355;  // "U3VL", "U3VT"
constexpr std::uint16_t kPayloadImage = 0x0001;

// The frame's pixels as the format lays them on the wire: Mono8 bytes, Mono12
// and Mono16 little-endian 16-bit words, Mono12p two pixels in three bytes
// (PFNC: the first pixel's 8 low bits, then its 4 high bits under the second's
// 4 low bits, then the second's 8 high bits).
std::vector<std::uint8_t> wireBytes(const cv::Mat& image, std::uint32_t format) {
  std::vector<std::uint8_t> out;
  if (format == kPfncMono8) {
    out.resize(image.total());
    for (int r = 0; r < image.rows; ++r)
      std::memcpy(out.data() + static_cast<std::size_t>(r) * image.cols, image.ptr(r), image.cols);
    return out;
  }
  if (format != kPfncMono12p) {
    out.resize(2 * image.total());
    for (int r = 0; r < image.rows; ++r) {
      const auto* in = image.ptr<std::uint16_t>(r);
      std::uint8_t* o = out.data() + 2 * static_cast<std::size_t>(r) * image.cols;
      for (int c = 0; c < image.cols; ++c) o[2 * c] = static_cast<std::uint8_t>(in[c]), o[2 * c + 1] = in[c] >> 8;
    }
    return out;
  }
  const std::size_t n = image.total();
  out.assign((n * 3 + 1) / 2, 0);
  const cv::Mat flat = image.isContinuous() ? image : image.clone();
  const auto* p = flat.ptr<std::uint16_t>(0);
  for (std::size_t i = 0; i < n; i += 2) {
    const unsigned a = p[i] & 0xfff, b = i + 1 < n ? p[i + 1] & 0xfff : 0;
    std::uint8_t* o = out.data() + i / 2 * 3;
    o[0] = static_cast<std::uint8_t>(a);
    o[1] = static_cast<std::uint8_t>(a >> 8 | (b & 0xf) << 4);
    if (i + 1 < n) o[2] = static_cast<std::uint8_t>(b >> 4);
  }
  return out;
}

std::optional<PixelFormat> lfiFormat(std::uint32_t pfnc) {
  switch (pfnc) {
    case kPfncMono8:
      return PixelFormat::Mono8;
    case kPfncMono12:
    case kPfncMono12p:
      return PixelFormat::Mono12;
    case kPfncMono16:
      return PixelFormat::Mono16;
    default:
      return std::nullopt;
  }
}

}  // namespace

void EmulatedU3vCamera::Impl::startAcquisition() {
  state.acquiring = true;
  pendingTriggers = 0;
  const std::uint32_t mode = reg(kRegAcquisitionMode);
  framesLeft = mode == kAcquisitionModeSingleFrame  ? 1
               : mode == kAcquisitionModeMultiFrame ? reg(kRegAcquisitionFrameCount)
                                                    : 0;
  wake.notify_all();
}

// The frame thread: a frame at each period while free running, or at each
// trigger, made by the filler outside the lock.
void EmulatedU3vCamera::Impl::runFrames() {
  std::unique_lock lock(node.mutex());
  Clock::time_point next = Clock::now();
  std::uint64_t blockId = 0;
  while (!stopThread) {
    if (!(state.acquiring && state.streamEnabled)) {
      wake.wait(lock);
      next = Clock::now();
      continue;
    }
    if (reg(kRegTriggerMode) == kTriggerModeOff) {
      const Clock::time_point now = Clock::now();
      if (now < next) {
        wake.wait_until(lock, next);
        continue;
      }
      const auto period = std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(1.0 / floatReg(kRegAcquisitionFrameRate)));
      next = std::max(next + period, now);  // (no burst to catch up after a stall)
    } else {
      if (pendingTriggers == 0) {
        wake.wait(lock);
        continue;
      }
      --pendingTriggers;
    }
    ServedFrameRequest request;
    request.frameId = ++blockId;
    request.offsetX_px = static_cast<int>(reg(kRegOffsetX));
    request.offsetY_px = static_cast<int>(reg(kRegOffsetY));
    request.width_px = static_cast<int>(reg(kRegWidth));
    request.height_px = static_cast<int>(reg(kRegHeight));
    request.binning = static_cast<int>(reg(kRegBinningHorizontal));
    request.pixelFormat = lfiFormat(reg(kRegPixelFormat));
    request.exposure_us = floatReg(kRegExposureTime);
    request.gain = floatReg(kRegGain);
    const std::uint32_t format = reg(kRegPixelFormat);
    if (framesLeft > 0 && --framesLeft == 0) state.acquiring = false;
    if (queuedFrames >= EmulatedU3vCamera::kQueuedFrames) {  // the host is not reading: this frame is lost
      ++state.framesDropped;
      continue;
    }
    const auto timestamp = static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count());
    lock.unlock();
    cv::Mat image = cv::Mat::zeros(request.height_px, request.width_px, format == kPfncMono8 ? CV_8UC1 : CV_16UC1);
    try {
      filler(request, image);
    } catch (const std::exception& e) {
      spdlog::warn("emulated USB3 Vision camera: frame {} goes out black: {}", request.frameId, e.what());
      image.setTo(0);
    }
    std::vector<std::uint8_t> payload = wireBytes(image, format);
    lock.lock();
    if (stopThread || !state.streamEnabled) continue;
    queueFrame(request, format, std::move(payload), timestamp);
  }
}

void EmulatedU3vCamera::Impl::queueFrame(const ServedFrameRequest& request, std::uint32_t format,
                                         std::vector<std::uint8_t> payload, std::uint64_t timestamp_ns) {
  Transfer leader;
  leader.bytes.assign(u3vusb::kLeaderSize, 0);
  std::uint8_t* l = leader.bytes.data();
  putU32(l, kLeaderMagic);
  putU16(l + 6, u3vusb::kLeaderSize);
  putU64(l + 8, request.frameId);
  putU16(l + 18, kPayloadImage);
  putU64(l + 20, timestamp_ns);
  putU32(l + 28, format);
  putU32(l + 32, static_cast<std::uint32_t>(request.width_px));
  putU32(l + 36, static_cast<std::uint32_t>(request.height_px));
  putU32(l + 40, static_cast<std::uint32_t>(request.offsetX_px));
  putU32(l + 44, static_cast<std::uint32_t>(request.offsetY_px));
  stream.push_back(std::move(leader));
  payload.resize(payload.size() - std::min(payload.size(), std::exchange(shortNext, 0)));
  // The payload in the transfers the host asked for in SIRM: PayloadTransferSize
  // each, the rest in the final transfer (one transfer if SIRM says nothing).
  const std::uint8_t* sirm = memory.at(kSirm).data();
  std::uint32_t chunk = 0;
  std::memcpy(&chunk, sirm + (kSirmPayloadTransferSize - kSirm), 4);
  if (chunk == 0) chunk = static_cast<std::uint32_t>(payload.size());
  for (std::size_t off = 0; off < payload.size(); off += chunk) {
    Transfer t;
    t.bytes.assign(payload.begin() + static_cast<std::ptrdiff_t>(off),
                   payload.begin() + static_cast<std::ptrdiff_t>(std::min(payload.size(), off + chunk)));
    stream.push_back(std::move(t));
  }
  Transfer trailer;
  trailer.bytes.assign(u3vusb::kTrailerSize, 0);
  std::uint8_t* t = trailer.bytes.data();
  putU32(t, std::exchange(corruptTrailerNext, false) ? 0 : kTrailerMagic);
  putU16(t + 6, u3vusb::kTrailerSize);
  putU64(t + 8, request.frameId);
  putU64(t + 20, payload.size());
  putU32(t + 28, static_cast<std::uint32_t>(request.height_px));
  trailer.endsFrame = true;
  stream.push_back(std::move(trailer));
  ++queuedFrames;
  ++state.framesSent;
  state.lastFrameId = request.frameId;
  deliverStream();
}

// The device sends each transfer in packets of kMaxPacket bytes, the last one
// short (or a zero-length packet). A URB completes when a short packet ends the
// transfer in it, or when it is full; the transfer's next packets go to the next
// URB. A packet that does not fit the room left in a URB overflows it (babble):
// the URB fails with -EOVERFLOW holding what fitted, the rest of that packet is lost.
bool EmulatedU3vCamera::Impl::fillStream(Urb& u) {
  constexpr std::size_t kMaxPacket = 1024;  // SuperSpeed bulk
  if (streamHalted || stallAll) {
    u.status = -EPIPE;
    u.actualLength = 0;
    return true;
  }
  if (stream.empty()) return false;
  Transfer& t = stream.front();
  const std::size_t room = static_cast<std::size_t>(u.length()), left = t.bytes.size() - t.sent;
  const std::size_t fits = left <= room ? left : room / kMaxPacket * kMaxPacket;  // whole packets
  const bool overflow = left > room && room % kMaxPacket != 0;
  const std::size_t n = overflow ? room : fits;
  std::memcpy(u.bytes(), t.bytes.data() + t.sent, n);
  u.status = overflow ? -EOVERFLOW : 0;
  u.actualLength = static_cast<int>(n);
  t.sent += overflow ? std::min(left, (n / kMaxPacket + 1) * kMaxPacket) : n;
  if (t.sent == t.bytes.size()) {
    if (t.endsFrame) --queuedFrames;
    stream.pop_front();
  }
  return true;
}

void EmulatedU3vCamera::Impl::deliverStream() {
  while (Urb* u = node.oldestHeld(u3vusb::kStreamIn)) {
    if (!fillStream(*u)) return;
    node.complete(u);
  }
}

}  // namespace lfi::emulation
