// circgen and circlog-record given numbers that size an arc, a table or a loop: each is
// range-checked before use and refused with exit 2 (usage) naming the option and its limit;
// a program header the recorder cannot account for is refused with exit 4 before any HAL
// work. Run on the real executables.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <string>
#include <vector>

#include "scratch.hpp"

namespace {

using namespace circtest::testing;  // ScratchDir, slurp, spit, run_command

struct Refusal {
  std::vector<std::string> args;
  int exit_code;
  std::string message;  // the whole error text after "<program>: error: "
  std::vector<std::string> env{"SOURCE_DATE_EPOCH=1700000000"};
};

void expect_refusal(const std::string& program, const std::string& name, const Refusal& r) {
  std::vector<std::string> argv{program};
  argv.insert(argv.end(), r.args.begin(), r.args.end());
  std::string shown;
  for (const auto& a : r.args) {
    shown += ' ';
    shown.append(a, 0, 40);
  }
  SCOPED_TRACE(name + shown);
  const CommandResult c = run_command(argv, r.env);
  EXPECT_EQ(c.exit_code, r.exit_code) << c.err;
  EXPECT_TRUE(c.out.empty()) << c.out.substr(0, 200);
  EXPECT_EQ(c.err, name + ": error: " + r.message + "\n");
}

const std::string kRunUp =
    ": the measured arc needs a run-up to reach the feed, M63 only takes effect with the next "
    "move, and a shorter arc can be written as a full circle";

std::string hundred_and_one_feeds() {
  std::string s = "100";
  for (int i = 0; i < 100; ++i) s += ",100";
  return s;
}

// Leads and arcs: no lead arc, measured arc or way back that the written digits would turn
// into a full circle (--lead 0.0001 once wrote full-circle leads, in ZX through the bottom).
TEST(HostileCircgen, LeadsAndArcsThatCannotBeWrittenAsTheirArcs) {
  const std::vector<Refusal> cases{
      {{"--plane", "ZX", "--d", "100", "--f", "500", "--arc", "180", "--lead", "0.0001"},
       2,
       "--lead: the lead arcs must be at least 1 deg, got 0.0001" + kRunUp},
      {{"--d", "1", "--f", "500", "--lead", "0.999"},
       2,
       "--lead: the lead arcs must be at least 1 deg, got 0.999" + kRunUp},
      {{"--d", "100", "--f", "500", "--lead", "1e-300"},
       2,
       "--lead: the lead arcs must be at least 1 deg, got 1e-300" + kRunUp},
      {{"--d", "100", "--f", "500", "--lead", "-5"},
       2,
       "--lead: the lead arcs must be at least 1 deg, got -5" + kRunUp},
      {{"--d", "100", "--f", "500", "--lead", "1e308"},
       2,
       "--lead: 1e+308 deg lead-in and lead-out arcs would overlap each other on a full circle "
       "(at most 180 deg)"},
      {{"--d", "100", "--f", "500", "--lead", "nan"}, 2, "--lead: expected a number, got 'nan'"},
      {{"--d", "100", "--f", "500", "--arc", "359.9998", "--lead", "89.9999"},
       2,
       "--lead: 89.9999 deg leads around a 180 deg arc leave 0.0002 deg of the circle between "
       "the lead-out end and the lead-in start, less than 1 deg: that arc cannot be written; use "
       "--lead 89.5 or less, or --lead 90 to close the circle"},
      {{"--d", "100", "--feeds", "300,600", "--dir", "ccw", "--lead", "179.9999"},
       2,
       "--lead: 179.9999 deg leads around a 360 deg arc leave 0.0002 deg of the circle between "
       "the lead-out end and the lead-in start, less than 1 deg: that arc cannot be written; use "
       "--lead 179.5 or less, or --lead 180 to close the circle"},
      {{"--d", "100", "--f", "500", "--arc", "359.9", "--lead", "1.2"},
       2,
       "--lead: 1.2 deg leads around a 357.5 deg arc leave 0.1 deg of the circle between the "
       "lead-out end and the lead-in start, less than 1 deg: that arc cannot be written; use "
       "--lead 1.25 to close the circle"},
      {{"--d", "100", "--f", "500", "--arc", "379.9999"},
       2,
       "--lead: 10 deg lead arcs around a 359.9999 deg arc would overlap each other (arc + 2 * "
       "lead = 379.9999 > 360 deg); use the data arc [--arc less 2 x --lead] 340 or less, or the "
       "data arc [--arc less 2 x --lead] 360"},
      {{"--d", "100", "--f", "500", "--arc", "360.5", "--lead", "1"},
       2,
       "--lead: 1 deg lead arcs around a 358.5 deg arc would overlap each other (arc + 2 * lead "
       "= 360.5 > 360 deg); use the data arc [--arc less 2 x --lead] 358 or less, or the data "
       "arc [--arc less 2 x --lead] 360"},
      {{"--d", "100", "--f", "500", "--arc", "109.9999"},
       2,
       "--arc: 109.9999 deg is the total angle travelled; less 2 x 10 deg overshoot (--lead) it "
       "leaves 89.9999 deg of data, and the data arc must be 90..360 deg (ISO 230-4 clause 3.1): "
       "give --arc 110..380"},
      {{"--d", "100", "--f", "500", "--start", "1e300"},
       2,
       "--start: start angle of 1e+300 deg is outside the plausible range -360..360 deg "
       "(docs/circgen.md)"},
  };
  for (const Refusal& r : cases) expect_refusal(CIRCGEN_PATH, "circgen", r);
}

// Sizes, feeds, counts, clearances and pauses.
TEST(HostileCircgen, SizesFeedsCountsAndPausesOutsideTheirRanges) {
  const std::vector<Refusal> cases{
      {{"--d", "0.5", "--f", "500"},
       2,
       "--d/--r: circle diameter of 0.5 mm is outside the plausible range 1..10000 mm "
       "(docs/circgen.md)"},
      {{"--r", "1e308", "--f", "500"},
       2,
       "--r: a radius of 1e308 is outside the plausible range 0.5..5000 mm"},
      {{"--inch", "--r", "1e308", "--f", "5"},
       2,
       "--r: a radius of 1e308 is outside the plausible range 0.01969..196.9 in"},
      {{"--inch", "--d", "1e6", "--f", "5"},
       2,
       "--d/--r: circle diameter of 1e+06 in is outside the plausible range 0.03937..393.7 in "
       "(docs/circgen.md)"},
      {{"--d", "100", "--f", "1e9"},
       2,
       "--f/--feeds: feed of 1000000000 mm/min is outside the plausible range 1..100000 mm/min "
       "(docs/circgen.md)"},
      {{"--d", "100", "--feeds", hundred_and_one_feeds()},
       2,
       "--f/--feeds: 101 feeds, at most 100 (one run pair each)"},
      {{"--d", "1", "--ref-d", "10000", "--ref-f", "1"},
       2,
       "--ref-f: the Annex C feed 1 * sqrt[1/10000] = 0.01 mm/min is below the plausible "
       "1..100000 mm/min"},
      {{"--d", "100", "--f", "500", "--dwell", "1e300"}, 2, "--dwell: must be 0..2 s, got 1e+300"},
      {{"--d", "100", "--f", "500", "--dwell", "-0.1"}, 2, "--dwell: must be 0..2 s, got -0.1"},
      {{"--d", "100", "--f", "500", "--safe-z", "1e12"},
       2,
       "--clearance: clearance position of 1000000000000 mm is outside the plausible range "
       "-100000..100000 mm (docs/circgen.md)"},
      {{"--d", "100", "--f", "500", "--centre", "1e300,0,0"},
       2,
       "--centre: position of 1e+300 mm is outside the plausible range -100000..100000 mm "
       "(docs/circgen.md)"},
      {{"--d", "100", "--f", "500", "--approach-feed", "1e-300"},
       2,
       "--approach-feed: approach feed of 1e-300 mm/min is outside the plausible range "
       "1..100000 mm/min (docs/circgen.md)"},
      {{"--d", "100", "--f", "500", "--instrument", "ballbar", "--feed-in", "1e300"},
       2,
       "--feed-in: the ballbar feed-in must be 0.5..3 mm, got 1e+300"},
      {{"--d", "100", "--f", "500", "--marker", "99999999999"},
       2,
       "--marker: expected a non-negative integer, got '99999999999'"},
      {{"--d", "100", "--f", "500", "--segment-out", "64"},
       2,
       "--segment-out: analog output must be 0..63, got 64"},
  };
  for (const Refusal& r : cases) expect_refusal(CIRCGEN_PATH, "circgen", r);
}

TEST(HostileCircgen, SourceDateEpochOutsideWholeSecondsToYear9999) {
  for (const std::string epoch : {"1e300", "-1", "1.5", "253402300800", "nan"}) {
    const std::string expected =
        epoch == "nan"
            ? "SOURCE_DATE_EPOCH: expected a number, got 'nan'"
            : "SOURCE_DATE_EPOCH: expected whole seconds since 1970 in 0..253402300799 (year "
              "9999), got '" +
                  epoch + "'";
    expect_refusal(CIRCGEN_PATH, "circgen",
                   {{"--d", "100", "--f", "500"}, 2, expected, {"SOURCE_DATE_EPOCH=" + epoch}});
  }
  const CommandResult last =
      run_command({CIRCGEN_PATH, "--d", "100", "--f", "500"}, {"SOURCE_DATE_EPOCH=253402300799"});
  EXPECT_EQ(last.exit_code, 0) << last.err;
  EXPECT_NE(last.out.find("(circtest: date: 9999-12-31T23:59:59Z)"), std::string::npos);
}

// The numbers --ini takes from a configuration size the velocity, acceleration and lead
// run-up checks: a zero or negative limit, an absurd LINEAR_UNITS or crossed soft limits are
// a broken file (exit 4 at its line), not a limit the test exceeds.
TEST(HostileCircgen, MachineNumbersThatCannotBeLimits) {
  ScratchDir dir;
  const std::string base =
      "[TRAJ]\nLINEAR_UNITS = mm\nMAX_LINEAR_VELOCITY = 50\n[AXIS_X]\nMIN_LIMIT = -200\n"
      "MAX_LIMIT = 200\nMAX_VELOCITY = 30\nMAX_ACCELERATION = 500\n";
  struct Edit {
    std::string from, to, message;
  };
  const std::vector<Edit> edits{
      {"MAX_ACCELERATION = 500", "MAX_ACCELERATION = 0",
       ":8: [AXIS_X] MAX_ACCELERATION: expected a positive number, got '0'"},
      {"MAX_VELOCITY = 30", "MAX_VELOCITY = -1",
       ":7: [AXIS_X] MAX_VELOCITY: expected a positive number, got '-1'"},
      {"MAX_LINEAR_VELOCITY = 50", "MAX_LINEAR_VELOCITY = 0",
       ":3: [TRAJ] MAX_LINEAR_VELOCITY: expected a positive number, got '0'"},
      {"LINEAR_UNITS = mm", "LINEAR_UNITS = 1e-300",
       ":2: [TRAJ] LINEAR_UNITS: expected a positive number of units per mm, 0.0001..10000, got "
       "'1e-300'"},
      {"MIN_LIMIT = -200", "MIN_LIMIT = 1e308",
       ":5: [AXIS_X] MIN_LIMIT = 1e308 is above MAX_LIMIT = 200"},
  };
  for (const Edit& e : edits) {
    std::string text = base;
    text.replace(text.find(e.from), e.from.size(), e.to);
    const std::string ini = dir.file("m.ini");
    spit(ini, text);
    expect_refusal(CIRCGEN_PATH, "circgen",
                   {{"--d", "100", "--f", "500", "--ini", ini}, 4, ini + e.message});
  }
}

// The parameter file as LinuxCNC reads it: a line it would read otherwise than it reads is
// refused at its line; a FIFO where a file is read is refused at once, never waited on; a
// clearance in a vertical circle's plane is refused naming the plane.
TEST(HostileCircgen, ParameterFilesFifosAndClearancesThatAreNotWhatTheySeem) {
  ScratchDir dir;
  const std::string ini = dir.file("m.ini");
  spit(ini,
       "[TRAJ]\nLINEAR_UNITS = mm\n[AXIS_X]\nMIN_LIMIT = -200\nMAX_LIMIT = 200\n"
       "[RS274NGC]\nPARAMETER_FILE = p.var\n");
  const std::string var = dir.file("p.var");
  struct Line {
    std::string text, message;
  };
  const std::vector<Line> lines{
      {"5221.0 180",
       ":2: '5221.0 180' is #5221 = 0 to LinuxCNC (it reads \"%d %lf\": a whole number, then a "
       "number, and ignores the rest); write the line as NUMBER VALUE"},
      {"5221 0x10", ":2: '5221 0x10' is #5221 = 16 to LinuxCNC"},
      {"5221-3", ":2: '5221-3' is #5221 = -3 to LinuxCNC"},
      {"5221 2e999", ":2: #5221: '2e999' is not a finite number"},
      {"-5 1", ":2: #-5: LinuxCNC refuses a parameter number outside 1..5601"},
      {std::string("5221 1\0 junk", 12), ":2: a NUL byte, where LinuxCNC's line ends"},
  };
  for (const Line& l : lines) {
    spit(var, "5220 1\n" + l.text + "\n");
    const CommandResult c = run_command({CIRCGEN_PATH, "--d", "100", "--f", "500", "--ini", ini},
                                        {"SOURCE_DATE_EPOCH=1700000000"});
    EXPECT_EQ(c.exit_code, 4) << c.err;
    EXPECT_TRUE(c.err.starts_with("circgen: error: " + var + l.message)) << c.err;
  }
  std::filesystem::remove(var);
  ASSERT_EQ(::mkfifo(var.c_str(), 0600), 0);
  const CommandResult fifo = run_command(
      {"/usr/bin/timeout", "20", CIRCGEN_PATH, "--d", "100", "--f", "500", "--ini", ini},
      {"SOURCE_DATE_EPOCH=1700000000"});
  EXPECT_EQ(fifo.exit_code, 3);
  EXPECT_EQ(fifo.err,
            "circgen: error: " + var + ": is a FIFO, expected a regular parameter file\n");
  expect_refusal(CIRCGEN_PATH, "circgen",
                 {{"--plane", "XY,YZ,ZX", "--centre", "50,50,0", "--clearance", "50",
                   "--instrument", "grid", "--d", "100", "--f", "500"},
                  2,
                  "--clearance: X 50 mm is the YZ circle's own plane (X 50 mm): the clearance in "
                  "YZ must be beside it, on either side"});
}

// circlog-record reads the program's announced runs before it looks for HAL: a header it
// could not account for is refused whether or not LinuxCNC runs.
TEST(HostileCirclogRecord, AnnouncedRunsAndWaitsAreCheckedBeforeRecording) {
  ScratchDir dir;
  spit(dir.file("dup.ngc"),
       "(circtest: units: mm)\n(circtest: segments: 1:CCW:F500,1:CW:F500)\nM2\n");
  spit(dir.file("bad.ngc"), "(circtest: segments: 1:CCW:F500,2:sideways:F500)\nM2\n");
  const std::string out = dir.file("t.csv");
  const std::vector<Refusal> cases{
      {{"-o", out, "--program", dir.file("dup.ngc"), "--until-idle", "2"},
       4,
       dir.file("dup.ngc") +
           ":2: segments: run 1 is announced twice: the recorder could not tell the runs apart"},
      {{"-o", out, "--program", dir.file("bad.ngc")},
       4,
       dir.file("bad.ngc") +
           ":1: segments: '2:sideways:F500' is not ID:DIRECTION:FFEED[:PLANE] (e.g. 1:CCW:F500:XY, "
           "ID a whole number from 1)"},
      {{"-o", out, "--until-idle", "1e300"},
       2,
       "--until-idle must be a number of seconds in 0..86400 (a day)"},
      {{"-o", out, "--until-idle", "2", "--run-wait", "0"},
       2,
       "--run-wait must be a number of seconds in (0, 86400] (a day)"},
      {{"-o", out, "--run-wait", "30"}, 2, "--run-wait is only used with --until-idle"},
      {{"-o", out, "--duration", "1e300"},
       2,
       "--duration must be a number of seconds in (0, 604800] (a week)"},
  };
  for (const Refusal& r : cases) expect_refusal(CIRCLOG_RECORD_PATH, "circlog-record", r);
  EXPECT_FALSE(std::filesystem::exists(out));
}

// A "program" that never ends its first line, or never reaches code, is not read without end;
// a device (/dev/zero) is not opened at all.
TEST(HostileCirclogRecord, AProgramWithoutEndIsRefused) {
  ScratchDir dir;
  spit(dir.file("blank.ngc"), std::string(20000, '\n'));
  spit(dir.file("long.ngc"), std::string(5000, '('));
  const std::string out = dir.file("t.csv");
  expect_refusal(CIRCLOG_RECORD_PATH, "circlog-record",
                 {{"-o", out, "--program", "/dev/zero"},
                  3,
                  "/dev/zero: is a character device, not a regular file"});
  expect_refusal(
      CIRCLOG_RECORD_PATH, "circlog-record",
      {{"-o", out, "--program", dir.file("long.ngc")},
       4,
       dir.file("long.ngc") + ":1: a line longer than 4096 bytes: not a G-code program"});
  expect_refusal(CIRCLOG_RECORD_PATH, "circlog-record",
                 {{"-o", out, "--program", dir.file("blank.ngc")},
                  4,
                  dir.file("blank.ngc") +
                      ":10001: more than 10000 lines before the first line of code: not a G-code "
                      "program header"});
}

}  // namespace
