// SPDX-License-Identifier: Apache-2.0
// A run's summary page rebuilt from its records (controller/run_summary.h, writeRunSummary): any text as the
// records file, one JSON record a line (a last line cut short is left out). The counts must add up: every part
// passed, failed or not inspected, and no more parts than lines.
#include "fuzz_input.h"

#include "lfi/controller/run_summary.h"

#include <algorithm>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const auto records = lfi::fuzz::writeInput("records.jsonl", data + 1, size - 1);
  const auto page = lfi::fuzz::folder() / "summary.html";
  lfi::fuzz::expectCleanRefusal([&] {
    const lfi::RunCounts c = lfi::writeRunSummary(records, page, data[0] & 1);
    const auto lines = std::count(data + 1, data + size, '\n') + 1;
    if (c.parts != c.passed + c.failed + c.errors || c.passed < 0 || c.failed < 0 || c.errors < 0 || c.parts > lines)
      std::abort();
  });
  return 0;
}
