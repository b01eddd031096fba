// A following error mid-run found in the trace as LinuxCNC's motion finds it: synthetic traces
// of a P loop (the feedback lags the command by v / P) with a jam put in, against the limit
// max(MIN_FERROR, FERROR * |v| / MAX_VELOCITY) worked out by hand.
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/trace.hpp"
#include "scratch.hpp"
#include "session_steps.hpp"

using namespace circtest;
using namespace circtest::session;
using circtest::testing::ScratchDir;

namespace {

constexpr double kPeriodS = 0.001;
constexpr double kSpeed = 1000.0 / 60.0;  // F1000, mm/s
constexpr double kLag = kSpeed / 40.0;    // P 40 1/s: 0.4167 mm

// X moves at kSpeed with the lag kLag, Y stands; from row JAM on X's feedback stops (a jammed
// axis); a gap of GAP_S seconds in t after row GAP_ROW (the marker off between two runs).
std::string trace_text(std::size_t rows, std::size_t jam, std::size_t gap_row = 0,
                       double gap_s = 0) {
  std::ostringstream t;
  t.precision(12);
  t << "# sample_period_s: " << kPeriodS << "\n";
  t << "t,x_cmd,y_cmd,x_fb,y_fb\n";
  double fb_at_jam = 0;
  for (std::size_t i = 0; i < rows; ++i) {
    const double time = static_cast<double>(i) * kPeriodS + (gap_row && i > gap_row ? gap_s : 0);
    const double cmd = kSpeed * static_cast<double>(i) * kPeriodS;
    double fb = cmd - kLag;
    if (i == jam) fb_at_jam = fb;
    if (i >= jam) fb = fb_at_jam;
    t << time << "," << cmd << ",5," << fb << ",5\n";
  }
  return t.str();
}

std::vector<FerrorLimit> limits_of(const std::string& joint0) {
  ScratchDir dir;
  const std::string ini = dir.write("m.ini",
                                    "[KINS]\nJOINTS = 2\nKINEMATICS = trivkins coordinates=XY\n"
                                    "[JOINT_0]\n" +
                                        joint0 +
                                        "[JOINT_1]\nFERROR = 2\nMIN_FERROR = 0.5\n"
                                        "MAX_VELOCITY = 50\n");
  return ferror_limits(IniDocument::load(ini), ini);
}

}  // namespace

TEST(FollowingError, TheLagWithinTheLimitIsNone) {
  // At 16.67 mm/s the limit is max(0.5, 2 * 16.67 / 50) = 0.667 mm: the lag 0.417 is within.
  const auto limits = limits_of("FERROR = 2\nMIN_FERROR = 0.5\nMAX_VELOCITY = 50\n");
  EXPECT_FALSE(find_following_error(parse_trace(trace_text(400, 1000), "t.csv"), limits));
}

TEST(FollowingError, AJammedAxisIsFoundWhereItPassesTheLimit) {
  const auto limits = limits_of("FERROR = 2\nMIN_FERROR = 0.5\nMAX_VELOCITY = 50\n");
  // From row 100 the feedback stands: the error grows by 16.67 um a sample from 0.417 mm and
  // passes 0.667 mm 16 samples later (0.417 + 15 * 0.01667 = 0.667 is not over it).
  const auto e = find_following_error(parse_trace(trace_text(150, 100), "t.csv"), limits);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->joint, 0);
  EXPECT_EQ(e->axis, 'X');
  EXPECT_NEAR(e->limit, 2.0 * kSpeed / 50.0, 1e-9);
  // The worst sample is the last (the error keeps growing): row 149, file line 152 (after the
  // metadata and the header).
  EXPECT_NEAR(e->error, kLag + 49 * kSpeed * kPeriodS, 1e-9);
  EXPECT_EQ(e->line, 152u);
  EXPECT_NEAR(e->time_s, 149 * kPeriodS, 1e-9);
  const std::string line = following_error_line(*e, "trace.csv");
  EXPECT_NE(line.find("joint 0 (X): a following error, 1.2333 mm over its limit 0.6667"),
            std::string::npos)
      << line;
  EXPECT_NE(line.find("the test is incomplete"), std::string::npos) << line;
}

TEST(FollowingError, AFerrorBelowTheLagAtSpeedIsFoundAtOnce) {
  // FERROR 1 at 50 mm/s: 0.333 mm at 16.67 mm/s, MIN_FERROR 0.1: the lag 0.417 is over it.
  const auto limits = limits_of("FERROR = 1\nMIN_FERROR = 0.1\nMAX_VELOCITY = 50\n");
  const auto e = find_following_error(parse_trace(trace_text(50, 1000), "t.csv"), limits);
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->error, kLag, 1e-9);
  EXPECT_NEAR(e->limit, kSpeed / 50.0, 1e-9);
}

TEST(FollowingError, LinuxCNCsDefaultsWhereTheKeysAreMissing) {
  // FERROR 1, MIN_FERROR = FERROR, MAX_VELOCITY 1: the limit is 16.67 mm at 16.67 mm/s.
  const auto limits = limits_of("");
  ASSERT_EQ(limits.size(), 2u);
  EXPECT_EQ(limits[0].ferror, 1.0);
  EXPECT_EQ(limits[0].min_ferror, 1.0);
  EXPECT_EQ(limits[0].max_velocity, 1.0);
  EXPECT_FALSE(find_following_error(parse_trace(trace_text(150, 100), "t.csv"), limits));
  // MIN_FERROR defaults to the FERROR given.
  EXPECT_EQ(limits_of("FERROR = 0.3\n")[0].min_ferror, 0.3);
}

TEST(FollowingError, AGapBetweenRunsIsNoVelocity) {
  // The marker off for 2 s between two runs: the first sample after the gap has no velocity of
  // its own. Taken over the gap (0.0167 mm in 2 s) its limit would be MIN_FERROR 0.3, under
  // X's lag 0.417; at the feed the limit is 0.667.
  const auto limits = limits_of("FERROR = 2\nMIN_FERROR = 0.3\nMAX_VELOCITY = 50\n");
  EXPECT_FALSE(find_following_error(parse_trace(trace_text(200, 1000, 100, 2.0), "t.csv"), limits));
  // The same limits without the gap: within.
  EXPECT_FALSE(find_following_error(parse_trace(trace_text(200, 1000), "t.csv"), limits));
}

TEST(FollowingError, AValueThatIsNoNumberIsRefusedWithItsLine) {
  try {
    limits_of("FERROR = fast\n");
    FAIL() << "no ParseError";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("m.ini:5"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("[JOINT_0] FERROR = fast"), std::string::npos) << e.what();
  }
}
