// SPDX-License-Identifier: Apache-2.0
// A run's records read back for its summary (controller/inspection_record.h): any text, one JSON record a line.
#include "fuzz_input.h"

#include "lfi/controller/inspection_record.h"

#include <nlohmann/json.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view rest = lfi::fuzz::text(data, size);
  for (int line = 1; !rest.empty(); ++line) {
    const std::size_t end = std::min(rest.find('\n'), rest.size());
    const nlohmann::json j = nlohmann::json::parse(rest.substr(0, end), nullptr, false);
    rest.remove_prefix(std::min(end + 1, rest.size()));
    if (j.is_discarded()) continue;  // (a line that is not JSON: the summary's own check)
    lfi::fuzz::expectCleanRefusal([&] { lfi::readRecordSummary(j, "records.jsonl:" + std::to_string(line)); });
  }
  return 0;
}
