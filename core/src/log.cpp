// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace lfi {

void initLogging(int verbosity) {
  auto logger = spdlog::stderr_color_mt("lfi");
  logger->set_pattern("%^%l%$: %v");
  spdlog::level::level_enum level = spdlog::level::info;
  if (verbosity < 0) level = spdlog::level::err;
  if (verbosity == 1) level = spdlog::level::debug;
  if (verbosity >= 2) level = spdlog::level::trace;
  logger->set_level(level);
  spdlog::set_default_logger(std::move(logger));
}

}  // namespace lfi
