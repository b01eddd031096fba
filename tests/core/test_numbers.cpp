// Number parsing and the option-value API every CLI shares: one message style.
#include <gtest/gtest.h>

#include <cmath>

#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "expect_error.hpp"

using namespace circtest;

TEST(Numbers, WholeTextOrNothing) {
  EXPECT_EQ(parse_number(" +1.5e2\t"), 150.0);
  EXPECT_FALSE(parse_number("150mm"));
  EXPECT_FALSE(parse_number(""));
  EXPECT_TRUE(std::isnan(*parse_number("nan")));
  EXPECT_FALSE(parse_finite("inf"));
}

TEST(OptionValues, NumberNamesTheOptionAndTheText) {
  EXPECT_DOUBLE_EQ(parse_option_number("--d", "150"), 150.0);
  EXPECT_DOUBLE_EQ(parse_option_number("--d", "+1.5e2"), 150.0);
  for (const char* bad : {"", "abc", "150mm", "1,5", "nan", "inf", "0x10"}) {
    SCOPED_TRACE(bad);
    EXPECT_ERROR(parse_option_number("--d", bad), ExitCode::usage,
                 std::string("--d: expected a number, got '") + bad + "'");
  }
  // Environment variables go through the same call, named as they are.
  EXPECT_ERROR(parse_option_number("SOURCE_DATE_EPOCH", "soon"), ExitCode::usage,
               "SOURCE_DATE_EPOCH: expected a number, got 'soon'");
}

TEST(OptionValues, Lists) {
  EXPECT_EQ(parse_option_list("--feeds", "100, 200,300"), (std::vector<double>{100, 200, 300}));
  EXPECT_ERROR(parse_option_list("--centre", "1,2", 3), ExitCode::usage,
               "--centre: expected 3 comma-separated numbers, got '1,2'");
  EXPECT_ERROR(parse_option_list("--centre", "1,y,3", 3), ExitCode::usage,
               "--centre: expected 3 comma-separated numbers, got '1,y,3'");
  EXPECT_ERROR(parse_option_list("--feeds", "300,,600"), ExitCode::usage,
               "--feeds: expected one or more comma-separated numbers, got '300,,600'");
}

TEST(OptionValues, Index) {
  EXPECT_EQ(parse_option_index("--marker", "3"), 3);
  EXPECT_EQ(parse_option_index("--marker", " 0 "), 0);
  for (const char* bad : {"1.5", "-1", "", "x", "99999999999"}) {
    SCOPED_TRACE(bad);
    EXPECT_ERROR(parse_option_index("--marker", bad), ExitCode::usage,
                 std::string("--marker: expected a non-negative integer, got '") + bad + "'");
  }
}

TEST(Strings, TrimAndJoin) {
  static_assert(trim(" \tab c\r\n") == "ab c");
  EXPECT_EQ(trim("   "), "");
  EXPECT_EQ(join(std::vector<std::string>{"x", "y", "z"}), "x,y,z");
  EXPECT_EQ(join(std::vector<std::string>{"a"}, ", "), "a");
  EXPECT_EQ(join(std::vector<std::string>{}), "");
}
