// The progress a session shows while the program runs: run k of n and the share of its path,
// from the program's header (runs, radius, arc, feeds), against the arc length at the feed.
#include <gtest/gtest.h>

#include <filesystem>
#include <numbers>
#include <sstream>
#include <string>

#include "scratch.hpp"
#include "session_steps.hpp"

namespace fs = std::filesystem;
using namespace circtest::session;
using circtest::testing::ScratchDir;

namespace {

// A program header as circgen writes it (the lines the progress reads), no moves.
std::string program(const ScratchDir& scratch, const std::string& header) {
  const fs::path p = scratch.dir() / "program.ngc";
  circtest::testing::spit(p, header + "M2\n");
  return p.string();
}

const std::string kOnePlane =
    "(circtest: plane: XY)\n(circtest: units: mm)\n(circtest: radius_mm: 50)\n"
    "(circtest: arc_deg: 360)\n(circtest: lead_deg: 10)\n"
    "(circtest: segments: 1:CCW:F1000:XY,2:CW:F500:XY)\n";

}  // namespace

TEST(RunProgress, TheShareOfThePathIsTheTimeAgainstTheArcAtItsFeed) {
  ScratchDir scratch("session-progress");
  std::ostringstream out;
  RunProgress progress(program(scratch, kOnePlane), out, nullptr, 0.0);
  // Run 1: the circle of 100 mm at F1000: pi * 100 / (1000 / 60) = 18.85 s.
  const double run1_s = std::numbers::pi * 100.0 / (1000.0 / 60.0);
  progress.started(1, 100.0);
  EXPECT_EQ(progress.status(100.0 + 0.475 * run1_s), "XY run 1 of 2 (CCW F1000): 47 % of the path");
  EXPECT_EQ(progress.status(100.0 + 2 * run1_s), "XY run 1 of 2 (CCW F1000): 99 % of the path")
      << "below 100 until LinuxCNC says the arc ended";
  progress.ended(100.0 + run1_s);
  // Run 2 at F500 takes twice as long.
  progress.started(2, 200.0);
  EXPECT_EQ(progress.status(200.0 + 0.505 * run1_s), "XY run 2 of 2 (CW F500): 25 % of the path");
}

TEST(RunProgress, WithoutATerminalPlainLinesAtEachQuarter) {
  ScratchDir scratch("session-progress");
  std::ostringstream out;
  RunProgress progress(program(scratch, kOnePlane), out, nullptr, 0.0);
  const double run1_s = std::numbers::pi * 100.0 / (1000.0 / 60.0);
  progress.started(1, 0.0);
  progress.update(0.1 * run1_s);
  progress.update(0.26 * run1_s);
  progress.update(0.3 * run1_s);
  progress.update(0.8 * run1_s);  // 50 and 75 passed: the last quarter reached is said once
  progress.update(0.9 * run1_s);
  progress.ended(19.0);
  EXPECT_EQ(out.str(),
            "circtest: XY run 1 of 2 (CCW F1000): recording\n"
            "circtest: XY run 1 of 2 (CCW F1000): 25 % of the path\n"
            "circtest: XY run 1 of 2 (CCW F1000): 75 % of the path\n"
            "circtest: XY run 1 of 2 (CCW F1000): recorded (19.0 s)\n");
}

TEST(RunProgress, ATestSetsRunsNameTheirPlaneAndInchFeedsAreConverted) {
  ScratchDir scratch("session-progress");
  std::ostringstream out;
  RunProgress set(program(scratch,
                          "(circtest: plane: XY,YZ)\n(circtest: units: inch)\n"
                          "(circtest: radius_mm: 50.8)\n(circtest: arc_deg: 180)\n"
                          "(circtest: lead_deg: 10)\n"
                          "(circtest: segments: 1:CCW:F40:XY,2:CCW:F40:YZ)\n"),
                  out, nullptr, 0.0);
  // YZ: half of the circle of 101.6 mm at 40 in/min = 1016 mm/min: 9.42 s.
  const double yz_s = std::numbers::pi * 50.8 / (40 * 25.4 / 60.0);
  set.started(2, 0.0);
  EXPECT_EQ(set.status(0.5 * yz_s + 0.01), "YZ run 2 of 2 (CCW F40): 50 % of the path");
  // A run the header does not announce is shown by its number.
  set.started(7, 0.0);
  EXPECT_EQ(set.status(1.0), "run 7: recording");
  // Planes that differ in their arcs: the header states no arc_deg, no share is guessed.
  std::ostringstream out2;
  RunProgress differ(program(scratch,
                             "(circtest: units: mm)\n(circtest: radius_mm: 50)\n"
                             "(circtest: arc_deg_XY: 360)\n(circtest: arc_deg_YZ: 180)\n"
                             "(circtest: segments: 1:CCW:F1000:XY,2:CCW:F1000:YZ)\n"),
                     out2, nullptr, 0.0);
  differ.started(1, 0.0);
  EXPECT_EQ(differ.status(5.0), "XY run 1 of 2 (CCW F1000): recording");
}
