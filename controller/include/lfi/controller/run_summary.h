// SPDX-License-Identifier: Apache-2.0
#pragma once
// The summary page of an `lfi run`, rebuilt from its records file (JSON Lines),
// so that it never says more or less than the records: counts, yield, the
// defects' positions on the part as a heat map, and the latest parts. The
// page reloads itself every few seconds while the run goes on.

#include <filesystem>

namespace lfi {

struct RunCounts {
  long parts = 0, passed = 0, failed = 0, errors = 0;
};

// Reads `records` (a last line cut short by a crash is left out, with a
// warning) and writes `page` atomically. `live`: the page reloads itself.
RunCounts writeRunSummary(const std::filesystem::path& records, const std::filesystem::path& page, bool live);

}  // namespace lfi
