// Whether a missing tool or input (a Vulkan device, Xvfb, Sponza, the
// PostgreSQL server, Chromium) fails a test instead of skipping it: under CI
// (CI=true) and under scripts/test.sh (TALLY_TEST_STRICT=1), which install
// everything the suite needs, so that a local run with a tool missing fails
// as CI would instead of passing green. Elsewhere (a bare `ctest` in a
// checkout without them) such a test skips, saying what is missing.
//
// A device that lacks a feature (64-bit atomics, timestamps) still skips: that
// is a property of the device, not a missing install.
#pragma once

#include <cstdlib>
#include <string_view>

#include <gtest/gtest.h>

namespace tally::test {

inline bool strictTests() {
  const char* ci = std::getenv("CI");
  const char* strict = std::getenv("TALLY_TEST_STRICT");
  return (ci != nullptr && std::string_view(ci) == "true") ||
         (strict != nullptr && std::string_view(strict) == "1");
}

}  // namespace tally::test

// Skips the current test with `why`, or fails it where tests are strict.
#define TALLY_SKIP_UNLESS_STRICT(why)                                      \
  do {                                                                     \
    if (::tally::test::strictTests()) {                                    \
      FAIL() << why << " (required where CI=true or TALLY_TEST_STRICT=1)"; \
    } else {                                                               \
      GTEST_SKIP() << why;                                                 \
    }                                                                      \
  } while (0)
