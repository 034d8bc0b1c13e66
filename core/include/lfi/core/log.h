// SPDX-License-Identifier: Apache-2.0
#pragma once
// One logging set-up for the whole project: spdlog's default logger writing to
// stderr, so that stdout stays free for the output of commands (tables, JSON).
// Libraries log through spdlog::info/warn/...; applications call initLogging()
// once. Tests leave it at the default (warnings and above).

#include <spdlog/spdlog.h>

namespace lfi {

// verbosity: -1 quiet (errors only), 0 normal (info), 1 debug, 2 trace.
void initLogging(int verbosity);

}  // namespace lfi
