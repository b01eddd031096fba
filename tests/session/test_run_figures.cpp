// The figures of each finished run: the live copy cut after the run's last row, and the line
// said from circana's result JSON.
#include <gtest/gtest.h>

#include <string>

#include "session_steps.hpp"

using namespace circtest::session;

namespace {

// Run 1 (rows 1-2), the marker off between the runs (a row of segment 1, marker 0), run 2
// under way and its last row still being written.
const std::string kLive =
    "# plane: XY\n"
    "# sample_period_s: 0.001\n"
    "t,x_cmd,marker,segment\n"
    "0.001,1.0,1,1\n"
    "0.002,2.0,1,1\n"
    "0.003,3.0,0,1\n"
    "0.004,4.0,1,2\n"
    "0.005,5.0,1,2\n"
    "0.006,6.";

}  // namespace

TEST(RunFigures, TheLiveCopyIsCutAfterTheRunsLastRow) {
  EXPECT_EQ(trace_through_run(kLive, 1),
            "# plane: XY\n# sample_period_s: 0.001\nt,x_cmd,marker,segment\n"
            "0.001,1.0,1,1\n0.002,2.0,1,1\n");
  // Run 2 so far: its whole rows, not the one being written.
  const auto two = trace_through_run(kLive, 2);
  ASSERT_TRUE(two);
  EXPECT_TRUE(two->ends_with("0.004,4.0,1,2\n0.005,5.0,1,2\n")) << *two;
  EXPECT_FALSE(trace_through_run(kLive, 3));
  EXPECT_FALSE(trace_through_run("t,x_cmd\n0.001,1\n", 1)) << "no segment column";
}

TEST(RunFigures, TheLineSaysGAndHOnceThePairIsIn) {
  const std::string json = R"({"runs": [
      {"segment": 1, "G": 0.0123, "U_G": 0.0008},
      {"segment": 2, "G": 0.0119, "U_G": 0.0008}],
    "pairs": [{"runs": [0, 1], "H": 0.0253, "U_H": 0.0011}]})";
  EXPECT_EQ(run_figures_line(json, 1), "G 12.3 um (U 0.8 um), H 25.3 um (U 1.1 um)");
  const std::string one = R"({"runs": [{"segment": 1, "G": 0.0123, "U_G": null}], "pairs": []})";
  EXPECT_EQ(run_figures_line(one, 1), "G 12.3 um");
  EXPECT_FALSE(run_figures_line(one, 2));
  EXPECT_FALSE(run_figures_line("not json", 1));
}
