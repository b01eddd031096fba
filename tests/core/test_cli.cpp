// The command-line helpers every program shares: the did-you-mean of an unknown option and
// the UTF-8 check of option values.
#include "circtest/core/cli.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "expect_error.hpp"

using namespace circtest;

TEST(Cli, EditDistanceCountsInsertionsDeletionsAndSubstitutions) {
  EXPECT_EQ(edit_distance("", ""), 0u);
  EXPECT_EQ(edit_distance("radius", "radius"), 0u);
  EXPECT_EQ(edit_distance("radus", "radius"), 1u);    // one left out
  EXPECT_EQ(edit_distance("raddius", "radius"), 1u);  // one too many
  EXPECT_EQ(edit_distance("radiys", "radius"), 1u);   // one wrong
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(edit_distance("", "abc"), 3u);
  EXPECT_EQ(edit_distance("abc", ""), 3u);
}

TEST(Cli, ClosestNameGuessesOnlyATypingSlip) {
  const std::vector<std::string> options = {"--radius", "--radius-tolerance", "--centre",
                                            "--machine", "--db"};
  EXPECT_EQ(closest_name("--radus", options), "--radius");
  EXPECT_EQ(closest_name("--center", options), "--centre");
  EXPECT_EQ(closest_name("--machien", options), "--machine");
  EXPECT_EQ(closest_name("--radius-tolerence", options), "--radius-tolerance");
  EXPECT_EQ(closest_name("--zzzzzzzz", options), "");
  EXPECT_EQ(closest_name("--colour", options), "");
  EXPECT_EQ(closest_name("x", std::vector<std::string>{}), "");
}

TEST(Cli, UnknownOptionMessage) {
  const std::vector<std::string> options = {"--radius", "--plane"};
  EXPECT_EQ(unknown_option_message("--radus", options),
            "unknown option --radus; did you mean --radius?");
  EXPECT_EQ(unknown_option_message("--frobnicate", options), "unknown option --frobnicate");
}

TEST(Cli, OptionValuesMustBeUtf8) {
  require_utf8_option("--operator", "J\xC3\xBCrgen");  // UTF-8: accepted
  EXPECT_ERROR(require_utf8_option("--operator", "J\xFCrgen"), ExitCode::usage,
               "--operator: not UTF-8 text (byte 0xFC at 2): give it in UTF-8");
}
