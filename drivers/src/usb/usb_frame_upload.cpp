// SPDX-License-Identifier: Apache-2.0
// Frame upload for the usb: backend: UsbDisplay::buildFrame() lays out header and
// payload, sendFrame() sends them as asynchronous bulk OUT transfers, several in flight.

#include "usb_display_impl.h"

#include "lfi/core/error.h"

#include <libusb.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <vector>

namespace lfi {
namespace detail {
namespace {

using Clock = std::chrono::steady_clock;

// One bulk OUT transfer of a frame and the state its callback fills in.
struct Chunk {
  libusb_transfer* transfer = nullptr;
  bool submitted = false;
  bool done = false;
  bool cancelled = false;
  libusb_transfer_status status = LIBUSB_TRANSFER_COMPLETED;
  int actual = 0;
  int length = 0;
};

void LIBUSB_CALL onChunkDone(libusb_transfer* transfer) {
  auto* chunk = static_cast<Chunk*>(transfer->user_data);
  chunk->done = true;
  chunk->status = transfer->status;
  chunk->actual = transfer->actual_length;
}

}  // namespace

void UsbDisplay::buildFrame(const cv::Mat& panel, std::uint32_t sequence) {
  const std::size_t rowBytes = static_cast<std::size_t>(panel.cols) * panel.elemSize();
  const std::size_t payload = rowBytes * static_cast<std::size_t>(panel.rows);
  frame_.resize(proto::kFrameHeaderSize + payload);
  std::uint8_t* out = frame_.data() + proto::kFrameHeaderSize;
  for (int r = 0; r < panel.rows; ++r) std::memcpy(out + r * rowBytes, panel.ptr<std::uint8_t>(r), rowBytes);
  proto::FrameHeader header;
  header.sequence = sequence;
  header.format = format_;
  header.width = static_cast<std::uint16_t>(panel.cols);
  header.height = static_cast<std::uint16_t>(panel.rows);
  header.payloadSize = static_cast<std::uint32_t>(payload);
  header.payloadCrc = proto::crc32Of({out, payload});
  const std::vector<std::uint8_t> bytes = proto::encodeFrameHeader(header);
  std::memcpy(frame_.data(), bytes.data(), bytes.size());
}

// Sends frame_ as bulk transfers, several in flight; cancels the rest on the first failure.
BulkOutcome UsbDisplay::sendFrame(std::size_t& sent) {
  const std::size_t size = options_.transferSize_bytes;
  const std::size_t count = (frame_.size() + size - 1) / size;
  std::vector<Chunk> chunks(count);
  BulkOutcome outcome = BulkOutcome::Ok;
  bool outOfMemory = false;  // reported once the transfers in flight are drained, not while libusb holds `chunks`
  std::size_t next = 0, inFlight = 0;
  // A guard above libusb's own per-transfer timeouts, in case a cancellation never completes.
  auto deadline = Clock::now() + options_.transferTimeout * static_cast<int>(count + options_.transfersInFlight + 1) +
                  std::chrono::seconds(2);
  auto record = [&](BulkOutcome o) {
    if (outcome == BulkOutcome::Ok || o == BulkOutcome::NoDevice) outcome = o;
  };
  while (true) {
    while (outcome == BulkOutcome::Ok && next < count &&
           inFlight < static_cast<std::size_t>(options_.transfersInFlight)) {
      Chunk& c = chunks[next];
      c.length = static_cast<int>(std::min(size, frame_.size() - next * size));
      c.transfer = libusb_alloc_transfer(0);
      if (!c.transfer) {
        outOfMemory = true;
        record(BulkOutcome::Error);
        break;
      }
      // libusb times a transfer from its submission, and the device takes the queued ones in turn: a chunk
      // gets transferTimeout for itself and for each one queued before it.
      const auto timeout = options_.transferTimeout * static_cast<int>(inFlight + 1);
      libusb_fill_bulk_transfer(c.transfer, handle_, endpoint_, frame_.data() + next * size, c.length, onChunkDone, &c,
                                static_cast<unsigned>(timeout.count()));
      const int rc = libusb_submit_transfer(c.transfer);
      ++next;
      if (rc != 0) {
        c.done = true;
        record(rc == LIBUSB_ERROR_NO_DEVICE ? BulkOutcome::NoDevice
               : rc == LIBUSB_ERROR_PIPE    ? BulkOutcome::Stall
                                            : BulkOutcome::Error);
        break;
      }
      c.submitted = true;
      ++inFlight;
    }
    if (inFlight == 0 && (outcome != BulkOutcome::Ok || next == count)) break;
    timeval tv{0, 50'000};
    const int rc = libusb_handle_events_timeout_completed(ctx_, &tv, nullptr);
    if (rc == LIBUSB_ERROR_NO_DEVICE) record(BulkOutcome::NoDevice);
    for (Chunk& c : chunks) {
      if (!c.submitted || !c.done) continue;
      c.submitted = false;
      --inFlight;
      if (c.status == LIBUSB_TRANSFER_COMPLETED && c.actual == c.length) {
        sent += static_cast<std::size_t>(c.actual);
        continue;
      }
      switch (c.status) {
        case LIBUSB_TRANSFER_STALL:
          record(BulkOutcome::Stall);
          break;
        case LIBUSB_TRANSFER_TIMED_OUT:
          record(BulkOutcome::Timeout);
          break;
        case LIBUSB_TRANSFER_NO_DEVICE:
          record(BulkOutcome::NoDevice);
          break;
        case LIBUSB_TRANSFER_CANCELLED:                  // we cancelled it after another one failed, or the system did
          if (!c.cancelled) record(BulkOutcome::Error);  // (a hole in the frame: never PRESENT it)
          break;
        default:
          record(BulkOutcome::Error);
          break;
      }
    }
    if (outcome != BulkOutcome::Ok && inFlight > 0) {
      for (Chunk& c : chunks) {
        if (c.submitted && !c.done && !c.cancelled) {
          libusb_cancel_transfer(c.transfer);
          c.cancelled = true;
        }
      }
    }
    if (Clock::now() > deadline) {
      // The frame was not all sent in time (the host stalled, say): never PRESENT it. Transfers in flight are
      // cancelled above on the next turn and get a last second to come back.
      if (outcome == BulkOutcome::Ok && (next < count || inFlight > 0)) {
        record(BulkOutcome::Timeout);
        deadline = Clock::now() + std::chrono::seconds(1);
        continue;
      }
      if (inFlight > 0) {
        // Transfers that neither complete nor cancel: libusb still owns them, so they
        // (and the context) must not be freed; give the device up.
        for (Chunk& c : chunks) c.transfer = nullptr;
        handle_ = nullptr;
        ctx_ = nullptr;
        claimed_ = false;
        wedged_ = true;
        state_ = State::Closed;
        fail(Errc::Device,
             "{}: bulk OUT transfers neither completed nor cancelled within the deadline; the "
             "display is closed",
             name_);
      }
      break;
    }
  }
  for (Chunk& c : chunks)
    if (c.transfer) libusb_free_transfer(c.transfer);
  if (outcome == BulkOutcome::Ok && (next != count || sent != frame_.size()))  // (cannot happen: said, not PRESENTed)
    fail(Errc::Device, "{}: {} of the frame's {} bytes sent, reported complete (a defect in lfi)", name_, sent,
         frame_.size());
  if (outOfMemory) {
    resync_ = true;  // the device may hold the transfers sent before
    fail(Errc::Device, "{}: libusb_alloc_transfer failed (out of memory)", name_);
  }
  return outcome;
}

}  // namespace detail
}  // namespace lfi
