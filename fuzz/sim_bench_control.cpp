// SPDX-License-Identifier: Apache-2.0
// The request lines of `lfi sim-bench`'s control socket as the bench reads them (emulation/bench_control.h):
// any text, one request a line, each at most the 4096 bytes the socket takes. A request read must be one the
// bench can carry out: its words as sent (a part's scene), a packet loss 0..1.
#include "fuzz_input.h"

#include "lfi/emulation/bench_control.h"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using Action = lfi::emulation::BenchControlRequest::Action;
  std::string_view rest = lfi::fuzz::text(data, size);
  while (!rest.empty()) {
    const std::size_t end = std::min(rest.find('\n'), rest.size());
    const std::string line(rest.substr(0, std::min<std::size_t>(end, 4096)));
    rest.remove_prefix(std::min(end + 1, rest.size()));
    lfi::fuzz::expectCleanRefusal([&] {
      const lfi::emulation::BenchControlRequest r = lfi::emulation::parseBenchControlRequest(line);
      if (line.find(r.argument) == std::string::npos || (!r.argument.empty() && r.argument.back() == ' ')) std::abort();
      if (r.action == Action::PacketLoss && !(r.packetLoss >= 0 && r.packetLoss <= 1)) std::abort();
    });
  }
  return 0;
}
