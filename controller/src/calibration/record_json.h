// SPDX-License-Identifier: Apache-2.0
#pragma once
// A measured value in a calibration record (lfi-calibration-record): the value,
// its standard and expanded uncertainties and its unit.

#include <nlohmann/json.hpp>

namespace lfi::detail {

inline nlohmann::json measured(double value, double sigma, double k, const char* unit) {
  return {{"value", value}, {"standard_uncertainty", sigma}, {"expanded_uncertainty", k * sigma}, {"unit", unit}};
}

}  // namespace lfi::detail
