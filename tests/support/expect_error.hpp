#pragma once
// EXPECT_ERROR(statement, code, message): the statement throws a circtest::Error with that
// exit code whose what() contains `message`. One macro for every suite's error checks.
#include <gtest/gtest.h>

#include <string>

#include "circtest/core/error.hpp"

#define EXPECT_ERROR(statement, expected_code, expected_message)                               \
  do {                                                                                         \
    bool circtest_thrown_ = false;                                                             \
    try {                                                                                      \
      statement;                                                                               \
    } catch (const ::circtest::Error& circtest_error_) {                                       \
      circtest_thrown_ = true;                                                                 \
      EXPECT_EQ(circtest_error_.code(), (expected_code)) << circtest_error_.what();            \
      const std::string circtest_what_ = circtest_error_.what();                               \
      EXPECT_NE(circtest_what_.find(expected_message), std::string::npos)                      \
          << "message: " << circtest_what_ << "\nexpected to contain: " << (expected_message); \
    }                                                                                          \
    if (!circtest_thrown_) ADD_FAILURE() << #statement " threw no circtest::Error";            \
  } while (false)
