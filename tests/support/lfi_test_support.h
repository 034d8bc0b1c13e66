// SPDX-License-Identifier: Apache-2.0
#pragma once
// Assertions shared by the test suites.

#include "lfi/core/error.h"
#include "lfi/core/geometry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <vector>

// A test that needs a tool this machine lacks skips, with `message`; where
// LFI_NO_SKIPS is set (.ci/run, whose machine has what scripts/install-deps.sh
// installs) it fails instead, so that a missing tool cannot leave CI green.
#define LFI_SKIP_WITHOUT_TOOL(message)                             \
  do {                                                             \
    if (std::getenv("LFI_NO_SKIPS") != nullptr) FAIL() << message; \
    GTEST_SKIP() << message;                                       \
  } while (0)

namespace lfi::testing_support {

// Passes when `f` throws lfi::Error with `code` and a message that contains every fragment.
inline ::testing::AssertionResult throwsError(const std::function<void()>& f, Errc code,
                                              const std::vector<std::string>& fragments) {
  try {
    f();
  } catch (const lfi::Error& e) {
    if (e.code() != code)
      return ::testing::AssertionFailure() << "code '" << lfi::toString(e.code()) << "', expected '"
                                           << lfi::toString(code) << "' (message: " << e.what() << ")";
    for (const std::string& fragment : fragments)
      if (std::string(e.what()).find(fragment) == std::string::npos)
        return ::testing::AssertionFailure() << "message '" << e.what() << "' does not contain '" << fragment << "'";
    return ::testing::AssertionSuccess();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "threw a non-lfi exception: " << e.what();
  }
  return ::testing::AssertionFailure() << "did not throw";
}

// One random edit of a file's bytes, of the kinds fuzzing found damaging: a
// byte changed, a bit flipped, the end cut off, a few bytes repeated, or a
// whole line repeated elsewhere (in a text header: a second 'element face').
// Never leaves the bytes empty.
inline void damage(std::string& bytes, std::mt19937& rng) {
  auto at = [&] { return std::uniform_int_distribution<size_t>(0, bytes.size() - 1)(rng); };
  switch (rng() % 5) {
    case 0:
      bytes[at()] = static_cast<char>(rng());
      break;
    case 1:
      bytes[at()] ^= static_cast<char>(1u << (rng() % 8));
      break;
    case 2:
      bytes.resize(at());
      break;
    case 3: {
      const size_t start = bytes.rfind('\n', at()), from = start == std::string::npos ? 0 : start + 1;
      const size_t end = bytes.find('\n', from);
      const std::string line = bytes.substr(from, end == std::string::npos ? std::string::npos : end - from + 1);
      const size_t to = bytes.find('\n', at());
      bytes.insert(to == std::string::npos ? bytes.size() : to + 1, line);
      break;
    }
    default: {
      const size_t from = at(), length = std::min<size_t>(1 + rng() % 16, bytes.size() - from);
      bytes.insert(at(), bytes.substr(from, length));
    }
  }
  if (bytes.empty()) bytes = "p";
}

inline void expectNear(const Vec3& actual, const Vec3& expected, double tol) {
  EXPECT_NEAR(actual.x, expected.x, tol);
  EXPECT_NEAR(actual.y, expected.y, tol);
  EXPECT_NEAR(actual.z, expected.z, tol);
}

}  // namespace lfi::testing_support
