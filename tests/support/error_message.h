/// @file error_message.h
/// @brief The message of the aoscan::Error that a call throws, for the bad-input tests.
#pragma once

#include <functional>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "core/status.h"

namespace aoscan::testing {

/// What `f` throws as an aoscan::Error (its message), checking its exit code when `expected` is
/// given; a test failure and "" when `f` throws nothing.
inline std::string error_message(const std::function<void()>& f,
                                 std::optional<ExitCode> expected = std::nullopt) {
  try {
    f();
  } catch (const Error& e) {
    if (expected) {
      EXPECT_EQ(e.code(), *expected) << e.what();
    }
    return e.what();
  }
  ADD_FAILURE() << "no error thrown";
  return "";
}

}  // namespace aoscan::testing
