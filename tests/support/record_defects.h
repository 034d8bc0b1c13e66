// SPDX-License-Identifier: Apache-2.0
#pragma once
// The defects of an inspection record (its JSON, docs/inspection.md) as the centroids a test compares with
// a part's true defects (study_parts.h).

#include "study_parts.h"

#include <nlohmann/json.hpp>

namespace lfi::testing_support {

inline Centroids centroidsOf(const nlohmann::json& record) {
  Centroids found;
  for (const auto& d : record.at("defects"))
    found.emplace_back(d.at("centroid_mm").at(0).get<double>(), d.at("centroid_mm").at(1).get<double>());
  return found;
}

}  // namespace lfi::testing_support
