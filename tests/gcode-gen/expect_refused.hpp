#pragma once
// The check of a circgen refusal, shared by the command-line tests.
#include <gtest/gtest.h>

#include <string>

#include "scratch.hpp"

namespace circtest::testing {

// circgen refused: exit `exit_code`, nothing on stdout, one line on stderr that starts with
// "circgen: error: " and holds `message`.
inline void expect_refused(const CommandResult& r, int exit_code, const std::string& message) {
  EXPECT_EQ(r.exit_code, exit_code) << r.err;
  EXPECT_TRUE(r.out.empty()) << "stdout: " << r.out.substr(0, 200);
  EXPECT_TRUE(r.err.starts_with("circgen: error: ")) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line expected: " << r.err;
  EXPECT_NE(r.err.find(message), std::string::npos) << "expected '" << message << "' in " << r.err;
}

}  // namespace circtest::testing
