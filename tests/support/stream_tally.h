// SPDX-License-Identifier: Apache-2.0
#pragma once
// A GigE Vision stream's frames over loopback with every loss accounted for,
// so that a test fails for a loss lfi or Aravis made and not for one the
// host's load made. With no loss injected, a frame is lost in one of three
// ways, each counted where it happens:
// - an underrun: no buffer was free when its packets came (a slow client).
//   Aravis counts each such packet (StreamStatistics::underruns): a frame id
//   skipped so is exactly P underruns, P the packets of a frame
//   (gvspPacketsPerFrame). A frame whose first packets found no buffer and a
//   later one did comes incomplete without its leader (so with the stale id of
//   its buffer's earlier frame), after 1 to P − 1 underruns.
// - a drop by this host's kernel (host_drops.h): a receive buffer full.
// - the device pausing mid-frame (its own process starved) longer than Aravis
//   waits for a frame's packets: the frame comes incomplete with its leader,
//   and the next one at least kDevicePause_ns later by the device's clock.
// S the ids skipped between complete frames, Il the frames delivered
// incomplete without their leader, If those with it and no device pause, U
// the underruns and K the host's drops, a test holds:
// - at every complete frame after a loss, for the frames until it: a frame
//   incomplete with its leader lost a packet that only the kernel can have
//   dropped, If <= K; every packet lost is an underrun or a drop by the host,
//   P·S + Il + If <= U + K; every incomplete frame is counted failed.
// - at the end, at a cut where nothing was in flight (U and K read, and the
//   next frame one the device made after the read): every underrun is a packet
//   of a frame skipped or delivered without its leader,
//   U <= P·S + (P − 1)·Il, and P·S + Il + If <= U + K at the read. With no
//   frame incomplete and no drop by the host, U = P·S: a frame id skipped is
//   exactly an underrun. (A client that lags behind the device reads again
//   after each frame; if no read is a cut before the buffers' worth of frames
//   in flight at the first one have come, the first complete frame after them,
//   which the device made after the first read, is one for the first
//   inequality.)
// No margin: a frame lost that nothing counted fails the test at the next
// complete frame, however loaded the host.

#include "gige_device_process.h"
#include "host_drops.h"
#include "lfi/drivers/camera.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace lfi::testing_support {

// Aravis 0.8 closes a frame as incomplete when none of its missing packets
// has come for 100 ms (ARV_GV_STREAM_FRAME_RETENTION_US_DEFAULT); with a
// packet socket, packets already received may wait 5 ms more for the kernel
// to hand over their block (the ring's tp_retire_blk_tov). A device that
// paused mid-frame so sends the rest of the frame, and then the next frame, at
// least 95 ms after the frame's start.
inline constexpr std::uint64_t kDevicePause_ns = 95'000'000;

// GVSP packets of a frame of `payload` bytes in packets of `packetSize` bytes:
// a leader, the payload in blocks of the packet size less its IP, UDP and GVSP
// headers (20 + 8 + 8 bytes), a trailer. What the device sends, and what
// Aravis expects and counts underruns in.
inline std::uint64_t gvspPacketsPerFrame(std::uint64_t payload, std::uint64_t packetSize) {
  const std::uint64_t block = packetSize - 36;
  return 2 + (payload + block - 1) / block;
}

// The forward distance from block id `from` to `to` (16 bits, 0 unused): 1 for the next id.
inline std::uint64_t blockIdsAfter(std::uint64_t from, std::uint64_t to) {
  return missingBlockIds(from, to) + (to == from ? 0 : 1);
}

class StreamLedger {
 public:
  // For `camera` streaming into `bufferCount` buffers (0: a ledger that is not close()d); `drops` counts the
  // host's drops since before the stream started. (P is read from the device now, as later its reads would delay
  // the test while frames come; without buffers when first needed.)
  StreamLedger(Camera& camera, int bufferCount, HostDrops& drops)
      : camera_(camera),
        buffers_(bufferCount),
        drops_(drops),
        packets_(bufferCount > 0 ? packetsPerFrame(camera) : 0) {}

  // Counts a grabbed frame. False for a timeout or a loss nothing accounts for (a test failure is recorded).
  bool add(const Frame& frame) {
    if (!ok_) return false;
    if (frame.status == FrameStatus::Timeout) {
      ADD_FAILURE() << "no frame within the grab's timeout after " << complete_ << " complete and " << incomplete_
                    << " incomplete";
      return ok_ = false;
    }
    ++passed_;
    if (frame.status == FrameStatus::Incomplete) {
      ++incomplete_;
      pending_.push_back({frame.frameId, frame.timestamp_ns});
      return true;
    }
    ++complete_;
    const bool lost = !pending_.empty() || (last_ && blockIdsAfter(last_->id, frame.frameId) != 1);
    if (last_) {
      closeGap(frame);
    } else {
      // Before the first complete frame no id is known: an incomplete frame there is accounted for like one without
      // its leader, or as a device pause if it has its id (the id just before) and the pause shows; the ids
      // skipped among them are not known either, so the underruns until now are left out of the count at the
      // cut. (Without such frames none precedes the first frame: a stream starts with its buffers free.)
      for (const Seen& f : pending_) {
        if (f.id != 0 && f.timestamp != 0 && blockIdsAfter(f.id, frame.frameId) == 1 &&
            frame.timestamp_ns >= f.timestamp + kDevicePause_ns)
          ++paused_;
        else
          ++withoutLeader_;
      }
      if (!pending_.empty()) underrunsBefore_ = camera_.statistics().underruns;
    }
    pending_.clear();
    last_ = Seen{frame.frameId, frame.timestamp_ns};
    if (lost) checkAccounted(camera_.statistics(), drops_.count(), "at frame " + std::to_string(frame.frameId));
    return ok_;
  }

  // Whether to grab on for `wanted` complete frames. (A stream that keeps losing frames the host accounts for
  // ends when it has gone through its 65535 block ids: past them a gap can no longer be told from one 65535 longer.)
  bool wantsMore(int wanted) const {
    if (ok_ && complete_ < wanted && passed_ + skipped_ >= 65535) {
      ADD_FAILURE() << "no " << wanted << " complete frames in a whole round of block ids: " << summary();
      return false;
    }
    return ok_ && complete_ < wanted;
  }

  bool ok() const { return ok_; }
  int complete() const { return complete_; }
  int incomplete() const { return incomplete_; }
  std::uint64_t skipped() const { return skipped_; }  // ids never delivered, between complete frames

  // Ends the tally: grabs on to a cut (handing each frame to `onFrame`) and checks the underruns and the host's
  // drops read there against the frames lost before it. After the last grab of the test's own.
  void close(const std::function<void(const Frame&)>& onFrame = {}) {
    if (!ok_) return;
    // A cut: the underruns and the host's drops read, and the next frame made after the read (the device's clock
    // is this host's real-time clock: Aravis's fake camera, and `lfi serve-camera` on it, stamp a frame when
    // they make it); else read again, and at the frame after the buffers' worth after the first read, which the
    // device made after it, check what holds with frames in flight.
    const Read first = readNow();
    Read read = first;
    Frame frame;
    bool quiet = false;  // nothing in flight at the read
    for (int deliveries = 1;; ++deliveries) {
      camera_.grabInto(frame, std::chrono::seconds(2));
      if (!add(frame)) return;
      if (onFrame) onFrame(frame);
      quiet = frame.status == FrameStatus::Complete && frame.timestamp_ns > read.at;
      // (Frames in flight at the first read hold buffers and come first: at most one per buffer.)
      if (quiet || (frame.status == FrameStatus::Complete && deliveries > buffers_)) break;
      read = readNow();
    }
    if (!quiet) read = first;
    const std::uint64_t p = packets_;
    EXPECT_LE(read.underruns - std::min(read.underruns, underrunsBefore_), p * skipped_ + (p - 1) * withoutLeader_)
        << "underruns counted for packets of frames that came whole (" << p << " packets a frame): " << summary();
    if (quiet) {
      EXPECT_LE(p * skipped_ + withoutLeader_ + withLeader_, read.underruns + read.drops)
          << "packets lost that neither an underrun nor a drop by the host accounts for at the read (" << p
          << " packets a frame; host: " << drops_.describe() << "): " << summary();
    }
    EXPECT_GE(camera_.statistics().failed, static_cast<std::uint64_t>(incomplete_))
        << "an incomplete frame not counted as failed";
    if (skipped_ + incomplete_ + read.underruns + read.drops > 0)
      std::printf("[ info     ] %s; %llu underruns of %llu packets a frame, %llu packets dropped by the host (%s)%s\n",
                  summary().c_str(), static_cast<unsigned long long>(read.underruns),
                  static_cast<unsigned long long>(p), static_cast<unsigned long long>(read.drops),
                  drops_.describe().c_str(), quiet ? "" : "; frames were in flight at every read");
  }

  std::string summary() const {
    return std::to_string(complete_) + " complete, " + std::to_string(skipped_) + " ids skipped, " +
           std::to_string(incomplete_) + " incomplete (" + std::to_string(withoutLeader_) + " without their leader, " +
           std::to_string(paused_) + " after a device pause, " + std::to_string(withLeader_) + " other)";
  }

 private:
  struct Seen {
    std::uint64_t id;
    std::uint64_t timestamp;
  };

  struct Read {
    std::uint64_t underruns, drops;
    std::uint64_t at;  // ns of this host's real-time clock, after both
  };

  Read readNow() {
    Read read;
    read.underruns = camera_.statistics().underruns;
    read.drops = drops_.count();
    read.at = static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
            .count());
    return read;
  }

  // The frames between the last complete one and `frame`, the next: which came with their leader (their ids
  // follow each other and the last one's, and precede `frame`'s: Aravis delivers frames in the order of their
  // ids, and one without its leader keeps the id of its buffer's earlier frame), and which ids never came.
  void closeGap(const Frame& frame) {
    const std::uint64_t gap = blockIdsAfter(last_->id, frame.frameId) - 1;
    if (pending_.size() > gap) {
      ADD_FAILURE() << pending_.size() << " incomplete frames between ids " << last_->id << " and " << frame.frameId;
      ok_ = false;
      return;
    }
    skipped_ += gap - pending_.size();
    std::vector<bool> leader(pending_.size(), false);
    std::uint64_t previous = last_->id;
    for (std::size_t i = 0; i < pending_.size(); ++i) {
      const std::uint64_t id = pending_[i].id;
      const std::uint64_t after = blockIdsAfter(previous, id);
      leader[i] = id != 0 && after >= 1 && after <= gap && blockIdsAfter(id, frame.frameId) >= 1 &&
                  blockIdsAfter(id, frame.frameId) <= gap;
      if (leader[i]) previous = id;
    }
    for (std::size_t i = 0; i < pending_.size(); ++i) {
      if (!leader[i]) {
        ++withoutLeader_;
        continue;
      }
      // The device paused if the very next frame came that much later.
      Seen next{frame.frameId, frame.timestamp_ns};
      for (std::size_t j = i + 1; j < pending_.size(); ++j)
        if (leader[j]) {
          next = pending_[j];
          break;
        }
      if (blockIdsAfter(pending_[i].id, next.id) == 1 && next.timestamp >= pending_[i].timestamp + kDevicePause_ns)
        ++paused_;
      else
        ++withLeader_;
    }
  }

  void checkAccounted(const StreamStatistics& stats, std::uint64_t drops, const std::string& where) {
    EXPECT_GE(stats.failed, static_cast<std::uint64_t>(incomplete_)) << "an incomplete frame not counted as failed";
    if (withLeader_ > drops) {
      ADD_FAILURE() << where << ": " << withLeader_
                    << " frames incomplete with their leader (packets lost after the frame started, which only the "
                       "host can have dropped, or a device pause) and "
                    << drops << " packets dropped by the host (" << drops_.describe() << "): " << summary();
      ok_ = false;
      return;
    }
    if (packets_ == 0 && skipped_ > 0) packets_ = packetsPerFrame(camera_);
    const std::uint64_t p = packets_;
    if (p * skipped_ + withoutLeader_ + withLeader_ > stats.underruns + drops) {
      ADD_FAILURE() << where << ": packets lost that neither an underrun nor a drop by the host accounts for: "
                    << stats.underruns << " underruns and " << drops << " packets dropped by the host ("
                    << drops_.describe() << ") for " << summary() << " (" << p << " packets a frame)";
      ok_ = false;
    }
  }

  // P, from the device's payload and the packet size negotiated at start().
  static std::uint64_t packetsPerFrame(Camera& camera) {
    return gvspPacketsPerFrame(static_cast<std::uint64_t>(camera.getIntegerFeature("PayloadSize")),
                               static_cast<std::uint64_t>(camera.getIntegerFeature("GevSCPSPacketSize")));
  }

  Camera& camera_;
  int buffers_;
  HostDrops& drops_;
  bool ok_ = true;
  int complete_ = 0, incomplete_ = 0;
  std::uint64_t skipped_ = 0, withoutLeader_ = 0, withLeader_ = 0, paused_ = 0;
  std::uint64_t passed_ = 0;           // frames delivered
  std::uint64_t underrunsBefore_ = 0;  // when incomplete frames came first: the underruns at the first complete one
  std::uint64_t packets_;              // P (0: not read yet)
  std::optional<Seen> last_;           // the last complete frame
  std::vector<Seen> pending_;          // incomplete frames since
};

}  // namespace lfi::testing_support
