#pragma once
// Assertions shared by the test suites.

#include "lfi/core/error.h"
#include "lfi/core/geometry.h"

#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

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

inline void expectNear(const Vec3& actual, const Vec3& expected, double tol) {
  EXPECT_NEAR(actual.x, expected.x, tol);
  EXPECT_NEAR(actual.y, expected.y, tol);
  EXPECT_NEAR(actual.z, expected.z, tol);
}

}  // namespace lfi::testing_support
