// SPDX-License-Identifier: Apache-2.0
#pragma once
// A GigE Vision stream's frames over loopback, tallied so that a test does
// not depend on the host's load. Loopback loses packets only when this host
// leaves the stream's receive buffer full (its stream thread stalled on a
// loaded machine); a frame then arrives incomplete, or not at all. A slow
// client (a loaded host, a sanitizer) also lets the buffer pool run dry, and
// frames are skipped as underruns. What a test holds without margin: every
// loss is one the backend reports (an incomplete frame counted as failed, a
// frame id skipped with an underrun or with packets reported missing). What
// it allows: at most as many frames incomplete as complete; a stream losing
// more is broken, loaded or not.

#include "gige_device_process.h"
#include "lfi/drivers/camera.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <optional>

namespace lfi::testing_support {

struct StreamTally {
  int complete = 0;
  int incomplete = 0;
  std::uint64_t lostIds = 0;  // block ids between two complete frames: incomplete, or never delivered
  std::optional<std::uint64_t> lastCompleteId;

  // Counts a grabbed frame; false for a timeout (the stream stopped delivering). Ids are counted between
  // complete frames only: an incomplete frame may come after a later complete one (it waited for resends).
  bool add(const Frame& frame) {
    if (frame.status == FrameStatus::Timeout) return false;
    if (frame.status == FrameStatus::Incomplete) {
      ++incomplete;
      return true;
    }
    ++complete;
    if (lastCompleteId) lostIds += missingBlockIds(*lastCompleteId, frame.frameId);
    lastCompleteId = frame.frameId;
    return true;
  }

  std::uint64_t lost() const { return std::max(lostIds, static_cast<std::uint64_t>(incomplete)); }

  // Whether to grab on for `wanted` complete frames: fewer so far, and fewer incomplete than wanted.
  bool wantsMore(int wanted) const { return complete < wanted && incomplete < wanted; }
};

// Every loss in `tally` is reported by `stats`, and the loss stays within the margin.
inline void expectLossesReported(const StreamTally& tally, const StreamStatistics& stats) {
  EXPECT_LE(tally.incomplete, tally.complete) << tally.incomplete << " frames incomplete for " << tally.complete;
  EXPECT_GE(stats.failed, static_cast<std::uint64_t>(tally.incomplete)) << "an incomplete frame not counted as failed";
  if (stats.missingPackets == 0) {
    EXPECT_LE(tally.lostIds, stats.underruns) << "frame ids skipped with neither an underrun nor a packet missing";
  }
  if (tally.lost() > 0)
    std::printf(
        "[ info     ] %llu frames lost (%d delivered incomplete) for %d complete: %llu underruns, "
        "%llu packets missing\n",
        static_cast<unsigned long long>(tally.lost()), tally.incomplete, tally.complete,
        static_cast<unsigned long long>(stats.underruns), static_cast<unsigned long long>(stats.missingPackets));
}

}  // namespace lfi::testing_support
