// circgen's command line: each bad input gives one error line, the documented exit code and
// nothing on stdout; --ini refuses a test beyond the machine, naming the limit.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <string>
#include <vector>

#include "expect_refused.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

struct BadCase {
  std::string name;
  std::vector<std::string> args;
  int exit_code;
  std::string message;  // must appear in the error line
};

std::vector<BadCase> option_cases() {
  return {
      {"negative_diameter",
       {"--d", "-150", "--f", "300"},
       2,
       "--d: the circle must be larger than 0"},
      {"zero_diameter", {"--d", "0", "--f", "300"}, 2, "--d: the circle must be larger than 0"},
      {"zero_radius", {"--r", "0", "--f", "300"}, 2, "--r: the circle must be larger than 0"},
      {"zero_feed", {"--d", "150", "--f", "0"}, 2, "--f: a feed must be positive"},
      {"negative_feed_in_sweep",
       {"--d", "150", "--feeds", "300,-600"},
       2,
       "--feeds: a feed must be positive"},
      {"arc_too_short",
       {"--d", "150", "--f", "300", "--arc", "45"},
       2,
       "--arc: 45 deg is the total angle travelled; less 2 x 10 deg overshoot (--lead) it leaves "
       "25 deg of data, and the data arc must be 90..360 deg (ISO 230-4 clause 3.1): give --arc "
       "110..380"},
      {"arc_too_long",
       {"--d", "150", "--f", "300", "--arc", "400"},
       2,
       "leaves 380 deg of data, and the data arc must be 90..360 deg"},
      {"unknown_plane",
       {"--d", "150", "--f", "300", "--plane", "AB"},
       2,
       "--plane: 'AB' is not XY, YZ or ZX"},
      {"xz_is_not_zx",
       {"--d", "150", "--f", "300", "--plane", "XZ"},
       2,
       "--plane: 'XZ' is not XY, YZ or ZX"},
      {"malformed_diameter", {"--d", "15O", "--f", "300"}, 2, "--d: expected a number, got '15O'"},
      // Boost.Program_options' error text loops for ever on its own placeholders (fuzzer).
      {"option_placeholder",
       {"--d", "150", "--x%original_token%"},
       2,
       "argument 3: '%original_token%' is not accepted in an argument"},
      {"malformed_feed", {"--d", "150", "--f", "fast"}, 2, "--f: expected a number, got 'fast'"},
      {"empty_sweep_entry",
       {"--d", "150", "--feeds", "300,,600"},
       2,
       "--feeds: expected one or more comma-separated numbers, got '300,,600'"},
      {"centre_two_values",
       {"--d", "150", "--f", "300", "--centre", "1,2"},
       2,
       "--centre: expected 3 comma-separated numbers, got '1,2'"},
      {"centre_malformed",
       {"--d", "150", "--f", "300", "--centre", "1,y,3"},
       2,
       "--centre: expected 3 comma-separated numbers, got '1,y,3'"},
      {"lead_overlap_partial",
       {"--d", "150", "--f", "300", "--arc", "370", "--lead", "50"},
       2,
       "--lead: 50 deg lead arcs around a 270 deg arc would overlap"},
      {"lead_overlap_full",
       {"--d", "150", "--f", "300", "--lead", "200"},
       2,
       "would overlap each other on a full circle"},
      {"lead_zero",
       {"--d", "150", "--f", "300", "--lead", "0"},
       2,
       "--lead: the lead arcs must be at least 1 deg, got 0"},
      {"bad_direction",
       {"--d", "150", "--f", "300", "--dir", "up"},
       2,
       "--dir: 'up' is not both, ccw or cw"},
      {"no_feed", {"--d", "150"}, 2, "missing --f"},
      {"no_size", {"--f", "300"}, 2, "missing --d"},
      {"two_feed_sources",
       {"--d", "150", "--f", "300", "--feeds", "300,600"},
       2,
       "give one of --f, --feeds or --ref-d/--ref-f"},
      {"annex_c_half",
       {"--d", "125", "--ref-d", "100"},
       2,
       "Annex C needs both --ref-d D2 and --ref-f V2"},
      {"annex_c_bad_reference",
       {"--d", "125", "--ref-d", "0", "--ref-f", "500"},
       2,
       "--ref-d: the reference diameter must be positive"},
      {"unknown_option", {"--d", "150", "--f", "300", "--fast"}, 2, "unknown option --fast"},
      {"bad_marker",
       {"--d", "150", "--f", "300", "--marker", "-1"},
       2,
       "--marker: expected a non-negative integer, got '-1'"},
      {"marker_out_of_range",
       {"--d", "150", "--f", "300", "--marker", "64"},
       2,
       "--marker: digital output must be 0..63"},
      {"long_dwell", {"--d", "150", "--f", "300", "--dwell", "5"}, 2, "--dwell: must be 0..2 s"},
      {"unknown_instrument",
       {"--d", "150", "--f", "300", "--instrument", "laser"},
       2,
       "--instrument: 'laser' is not encoder, grid or ballbar"},
      {"approach_faster_than_test",
       {"--d", "150", "--f", "300", "--approach-feed", "400"},
       2,
       "--approach-feed: 400 mm/min is above the test feed 300 mm/min"},
      {"approach_zero",
       {"--d", "150", "--f", "300", "--approach-feed", "0"},
       2,
       "--approach-feed: must be positive"},
      {"ballbar_radius_too_small",
       {"--d", "80", "--f", "300", "--instrument", "ballbar"},
       2,
       "radius 40 mm is outside the 50..600 mm"},
      {"ballbar_radius_too_large",
       {"--d", "1300", "--f", "300", "--instrument", "ballbar"},
       2,
       "radius 650 mm is outside the 50..600 mm"},
      {"ballbar_feed_too_high",
       {"--d", "200", "--feeds", "1000,12000", "--instrument", "ballbar"},
       2,
       "feed 12000 mm/min is above the 10000 mm/min"},
      {"ballbar_feed_in_too_long",
       {"--d", "200", "--f", "1000", "--instrument", "ballbar", "--feed-in", "5"},
       2,
       "--feed-in: the ballbar feed-in must be 0.5..3 mm, got 5"},
      {"bad_work_offset",
       {"--d", "150", "--f", "300", "--work-offset", "G53"},
       2,
       "--work-offset: 'G53' is not G54..G59, G59.1, G59.2 or G59.3"},
      {"tool_zero",
       {"--d", "150", "--f", "300", "--tool", "0"},
       2,
       "--tool: the tool number for G43 H must be 1 or more"},
      {"feed_in_without_ballbar",
       {"--d", "200", "--f", "1000", "--feed-in", "1"},
       2,
       "--feed-in is only used with --instrument ballbar"},
  };
}

// Numbers no program word can carry: each refused naming its option, instead of writing Xinf,
// X-nan, a 309-digit feed or arcs of radius 0.
std::vector<BadCase> number_range_cases() {
  return {
      {"huge_diameter",
       {"--d", "1e308", "--f", "300"},
       2,
       "--d/--r: circle diameter of 1e+308 mm is outside the plausible range 1..10000 mm"},
      {"huge_diameter_in_inch",
       {"--d", "1e307", "--f", "30", "--inch"},
       2,
       "--d/--r: circle diameter of inf in is outside the plausible range 0.03937..393.7 in"},
      {"huge_centre_in_inch",
       {"--d", "6", "--f", "30", "--inch", "--centre", "0,0,-5e3"},
       2,
       "--centre: position of -5000 in is outside the plausible range -3937..3937 in"},
      {"tiny_diameter",
       {"--d", "1e-300", "--f", "300"},
       2,
       "--d/--r: circle diameter of 1e-300 mm is outside the plausible range 1..10000 mm"},
      {"huge_start",
       {"--d", "150", "--f", "300", "--start", "1e308"},
       2,
       "--start: start angle of 1e+308 deg is outside the plausible range -360..360 deg"},
      {"huge_centre",
       {"--d", "150", "--f", "300", "--centre", "1e308,0,0"},
       2,
       "--centre: position of 1e+308 mm is outside the plausible range -100000..100000 mm"},
      {"huge_safe_z",
       {"--d", "150", "--f", "300", "--safe-z", "1e308"},
       2,
       "--clearance: clearance position of 1e+308 mm is outside the plausible range"},
      {"huge_feed",
       {"--d", "150", "--f", "1e308"},
       2,
       "--f/--feeds: feed of 1e+308 mm/min is outside the plausible range 1..100000 mm/min"},
      {"huge_feed_in_sweep",
       {"--d", "150", "--feeds", "300,1e6"},
       2,
       "--f/--feeds: feed of 1000000 mm/min is outside the plausible range"},
      {"huge_offset",
       {"--d", "150", "--f", "300", "--ini", "/nonexistent.ini", "--offset", "0,-1e308,0"},
       2,
       "--offset: work offset of -1e+308 mm is outside the plausible range"},
      {"tiny_reference_diameter",
       {"--d", "150", "--ref-d", "1e-300", "--ref-f", "100"},
       2,
       "--ref-d: Annex C reference diameter of 1e-300 mm is outside the plausible range"},
      {"annex_c_feed_too_high",
       {"--d", "10000", "--ref-d", "1", "--ref-f", "100000"},
       2,
       "--ref-f: the Annex C feed 100000 * sqrt[10000/1] = 10000000 mm/min is above"},
  };
}

// Test sets, the clearance, the floor and the ballbar's lengths.
std::vector<BadCase> set_and_instrument_cases() {
  return {
      {"set_without_clearance",
       {"--d", "100", "--f", "500", "--plane", "XY,ZX"},
       2,
       "--plane XY,ZX: a test set moves from plane to plane between its pauses; give --clearance "
       "(one position on the normal axes, or one per plane)"},
      {"set_plane_twice",
       {"--d", "100", "--f", "500", "--plane", "XY,YZ,XY", "--clearance", "50"},
       2,
       "--plane: XY is given twice in 'XY,YZ,XY'"},
      {"set_plane_unknown",
       {"--d", "100", "--f", "500", "--plane", "XY,XZ", "--clearance", "50"},
       2,
       "--plane: 'XZ' is not XY, YZ or ZX (for G18 use ZX"},
      {"set_plane_empty",
       {"--d", "100", "--f", "500", "--plane", "XY,", "--clearance", "50"},
       2,
       "--plane: '' is not XY, YZ or ZX"},
      {"set_clearance_count",
       {"--d", "100", "--f", "500", "--plane", "XY,YZ", "--clearance", "50,60,70"},
       2,
       "--clearance: 3 positions for 2 planes: give one, or one per plane"},
      {"clearance_and_safe_z",
       {"--d", "100", "--f", "500", "--clearance", "50", "--safe-z", "50"},
       2,
       "give --clearance or its alias --safe-z, not both"},
      {"clearance_below_an_xy_circle",
       {"--d", "100", "--f", "500", "--centre", "0,0,10", "--clearance", "10"},
       2,
       "--clearance: Z 10 mm is not above the circle's height Z 10 mm: the clearance in XY must "
       "be above it"},
      {"floor_above_the_path",
       {"--d", "300", "--f", "500", "--plane", "YZ", "--instrument", "ballbar", "--floor", "-40"},
       6,
       "--floor -40: the path in YZ reaches Z -51.816051714 mm (work offset), 11.816051714 mm "
       "below that floor"},
      {"floor_in_a_set",
       {"--d", "200", "--f", "500", "--plane", "XY,ZX", "--clearance", "50", "--floor", "-99"},
       6,
       "--floor -99: the path in ZX reaches Z -100 mm (work offset), 1 mm below that floor"},
      {"floor_not_finite", {"--d", "200", "--f", "500", "--floor", "inf"}, 2, "--floor"},
      {"ballbar_length_not_in_profile",
       {"--d", "150", "--f", "500", "--instrument", "ballbar"},
       2,
       "--instrument ballbar: radius 75 mm is not a length of the ballbar profile (50,100,150,300 "
       "mm); test at one of them, or give the bar's lengths with --ballbar-lengths"},
      {"ballbar_lengths_without_ballbar",
       {"--d", "150", "--f", "500", "--ballbar-lengths", "75"},
       2,
       "--ballbar-lengths is only used with --instrument ballbar"},
      {"ballbar_length_implausible",
       {"--d", "150", "--f", "500", "--instrument", "ballbar", "--ballbar-lengths", "75,1e9"},
       2,
       "--ballbar-lengths: a bar length of 1000000000 mm is outside 50..600 mm"},
  };
}

std::vector<BadCase> usage_cases() {
  std::vector<BadCase> cases = option_cases();
  for (BadCase& c : number_range_cases()) cases.push_back(std::move(c));
  for (BadCase& c : set_and_instrument_cases()) cases.push_back(std::move(c));
  return cases;
}

// A ballbar's radius is one of its profile's lengths: 75 mm with a profile that lists it.
TEST(CircgenCli, BallbarLengthsFromTheProfile) {
  const CommandResult r = run_circgen(
      {"--d", "150", "--f", "500", "--instrument", "ballbar", "--ballbar-lengths", "75,150"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  // A diameter in inch to 4 decimals is the 100 mm bar.
  EXPECT_EQ(
      run_circgen({"--inch", "--d", "7.874", "--f", "20", "--instrument", "ballbar"}).exit_code, 0);
}

// Inch feeds keep three decimals: the default approach feed 200 mm/min is F7.874, not F7.9.
TEST(CircgenCli, InchFeedsKeepTheirPrecision) {
  const CommandResult r =
      run_circgen({"--inch", "--d", "7.874", "--f", "40", "--instrument", "ballbar"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(" F7.874 (feed-in 0.05906)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("F7.9"), std::string::npos);
  EXPECT_NE(r.out.find("(circtest: approach_feed_in_per_min: 7.874)"), std::string::npos);
  // The smallest plausible feed, 1 mm/min, keeps a word that is not F0.
  const CommandResult slow = run_circgen({"--inch", "--d", "6", "--f", "0.04"});
  ASSERT_EQ(slow.exit_code, 0) << slow.err;
  EXPECT_NE(slow.out.find(" F0.04 (lead-in)"), std::string::npos);
}

// The header of a vertical-plane ballbar test: data arc, total arc, overshoot, lowest point.
TEST(CircgenCli, HeaderStatesTheArcsAndTheLowestPoint) {
  const CommandResult r = run_circgen({"--d", "300", "--f", "500", "--plane", "ZX", "--instrument",
                                       "ballbar", "--offset", "0,0,-300"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* line :
       {"(circtest: arc_deg: 180)", "(circtest: arc_total_deg: 220)", "(circtest: lead_deg: 20)",
        "(circtest: lowest_z_mm: -51.816051714)", "(circtest: lowest_z_machine_mm: -351.816051714)",
        "(circtest: safe_axis: y)", "(circtest: safe_mm: 50)"}) {
    EXPECT_NE(r.out.find(line), std::string::npos) << line;
  }
}

class CircgenCliBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(CircgenCliBadInput, OneLineErrorExitCodeNothingOnStdout) {
  const BadCase& c = GetParam();
  expect_refused(run_circgen(c.args), c.exit_code, c.message);
}

INSTANTIATE_TEST_SUITE_P(Usage, CircgenCliBadInput, ::testing::ValuesIn(usage_cases()),
                         [](const ::testing::TestParamInfo<BadCase>& p) { return p.param.name; });

const char* kMachineIni = R"(# a small mill, mm
[EMC]
MACHINE = test mill

[TRAJ]
LINEAR_UNITS = mm
MAX_LINEAR_VELOCITY = 50

[AXIS_X]
MIN_LIMIT = -200
MAX_LIMIT = 200
MAX_VELOCITY = 30
MAX_ACCELERATION = 500

[AXIS_Y]
MIN_LIMIT = -200
MAX_LIMIT = 200
MAX_VELOCITY = 30
MAX_ACCELERATION = 500

[AXIS_Z]
MIN_LIMIT = -100
MAX_LIMIT = 10
MAX_VELOCITY = 20
MAX_ACCELERATION = 300
)";

class CircgenCliIni : public ::testing::Test {
 protected:
  void SetUp() override { spit(ini(), kMachineIni); }
  std::string ini() const { return dir_.file("machine.ini"); }
  CommandResult run(std::vector<std::string> args) {
    args.push_back("--ini");
    args.push_back(ini());
    return run_circgen(args);
  }
  ScratchDir dir_;
};

TEST_F(CircgenCliIni, AcceptsATestWithinTheLimitsAndSaysSoInTheHeader) {
  const CommandResult r = run({"--d", "150", "--f", "300", "--safe-z", "5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("(circtest: ini: " + ini() + ")"), std::string::npos);
  EXPECT_NE(r.out.find("(circtest: ini_checked: soft limits,velocity,acceleration,lead run-up)"),
            std::string::npos);
}

// Without a parameter file (LinuxCNC's default rs274ngc.var beside the INI) or --offset the
// origin is not known: said on stderr and in the header, checked as machine zero.
TEST_F(CircgenCliIni, AnUnknownWorkOffsetIsSaidNotAssumedSilently) {
  const CommandResult r = run({"--d", "150", "--f", "300"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "circgen: warning: the work offset's origin is not known (no parameter file " +
                       dir_.file("rs274ngc.var") +
                       ", no --offset): the path is checked as if it were machine zero\n");
  EXPECT_NE(r.out.find("(circtest: work_offset_origin_source: not known: no parameter file "),
            std::string::npos);
  EXPECT_EQ(r.out.find("centre_machine_mm"), std::string::npos);
}

// [RS274NGC] PARAMETER_FILE: G55's origin at #5241..#5243 (LinuxCNC's interp_array.cc), in
// the INI's units, beside the INI.
TEST_F(CircgenCliIni, TheParameterFileGivesTheWorkOffsetTheProgramUses) {
  spit(ini(), std::string(kMachineIni) + "\n[RS274NGC]\nPARAMETER_FILE = m.var\n");
  spit(dir_.file("m.var"),
       "5220\t1.000000\n5221\t0.000000\n5222\t0\n5223\t-20\n5241\t-180.000000\n5242\t0\n"
       "5243\t0\n");
  expect_refused(run({"--d", "150", "--f", "300", "--work-offset", "G55"}), 6,
                 "X = -255 mm in machine coordinates, below [AXIS_X] MIN_LIMIT = -200");
  const CommandResult g54 = run({"--d", "150", "--f", "300", "--work-offset", "G54"});
  ASSERT_EQ(g54.exit_code, 0) << g54.err;
  EXPECT_TRUE(g54.err.empty()) << g54.err;
  EXPECT_NE(g54.out.find("(circtest: work_offset_origin_source: G54 #5221..#5223 in " +
                         dir_.file("m.var") + ")"),
            std::string::npos)
      << g54.out.substr(0, 3000);
  EXPECT_NE(g54.out.find("(circtest: centre_machine_mm: 0,0,-20)"), std::string::npos);
  EXPECT_NE(g54.out.find("(circtest: lowest_z_machine_mm: -20)"), std::string::npos);
  // Inherited: the system selected when the file was saved (#5220), with a warning.
  spit(dir_.file("m.var"), "5220 2\n5241 -180\n");
  const CommandResult inherited = run({"--d", "150", "--f", "300"});
  EXPECT_EQ(inherited.exit_code, 6);
  EXPECT_NE(inherited.err.find("X = -255 mm"), std::string::npos) << inherited.err;
  spit(dir_.file("m.var"), "5220 2\n5241 -10\n");
  const CommandResult warned = run({"--d", "150", "--f", "300"});
  ASSERT_EQ(warned.exit_code, 0) << warned.err;
  EXPECT_NE(warned.err.find("the program inherits the work offset; the path is checked in G55"),
            std::string::npos)
      << warned.err;
  // G92 in effect (#5210) moves every system.
  spit(dir_.file("m.var"), "5210 1\n5211 -180\n");
  expect_refused(run({"--d", "150", "--f", "300", "--work-offset", "G54"}), 6, "X = -255 mm");
}

TEST_F(CircgenCliIni, ParameterFileRefusals) {
  spit(ini(), std::string(kMachineIni) + "\n[RS274NGC]\nPARAMETER_FILE = m.var\n");
  spit(dir_.file("m.var"), "5241 -180\n5221 0\n");
  expect_refused(run({"--d", "150", "--f", "300", "--work-offset", "G55"}), 4,
                 dir_.file("m.var") +
                     ":2: #5221 after #5241: LinuxCNC refuses a parameter file whose numbers are "
                     "not increasing");
  spit(dir_.file("m.var"), "5241 nan\n");
  expect_refused(run({"--d", "150", "--f", "300", "--work-offset", "G55"}), 4,
                 dir_.file("m.var") + ":1: #5241: 'nan' is not a finite number");
  spit(dir_.file("m.var"), "5241 -10\n5250 30\n");
  expect_refused(run({"--d", "150", "--f", "300", "--work-offset", "G55"}), 5,
                 "G55 has an XY rotation of 30 deg (#5250): circgen cannot check the path in a "
                 "rotated work offset");
  expect_refused(run({"--d", "150", "--f", "300", "--work-offset", "G54", "--offset", "5,0,0"}), 2,
                 "--offset 5,0,0 mm disagrees with G54 #5221..#5223 in " + dir_.file("m.var") +
                     " = 0,0,0 mm: give the origin that is right, or drop --offset");
}

// circtest gives the origin the running LinuxCNC uses: after a touch-off the parameter file
// (written when LinuxCNC exits) still holds the old one; the path is checked from --offset.
TEST_F(CircgenCliIni, OffsetFromLinuxcncIsCheckedOverAnOlderParameterFile) {
  spit(ini(), std::string(kMachineIni) + "\n[RS274NGC]\nPARAMETER_FILE = m.var\n");
  spit(dir_.file("m.var"), "5220 1\n5221 0\n");
  const CommandResult ok =
      run({"--d", "150", "--f", "300", "--offset", "5,0,0", "--offset-from-linuxcnc"});
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.err.find("--offset 5,0,0 mm (the origin the running LinuxCNC uses) differs from "
                        "G54 #5221..#5223 in " +
                        dir_.file("m.var") + " = 0,0,0 mm, which LinuxCNC writes when it exits"),
            std::string::npos)
      << ok.err;
  EXPECT_NE(ok.out.find("work_offset_origin_machine_mm: 5,0,0"), std::string::npos) << ok.out;
  // The path from --offset, not from the file: X -255 is beyond MIN_LIMIT -200.
  expect_refused(
      run({"--d", "150", "--f", "300", "--offset", "-180,0,0", "--offset-from-linuxcnc"}), 6,
      "X = -255 mm in machine coordinates, below [AXIS_X] MIN_LIMIT = -200");
}

TEST_F(CircgenCliIni, RefusesACircleBeyondMaxLimit) {
  expect_refused(run({"--d", "150", "--f", "300", "--centre", "150,0,0"}), 6,
                 "X = 225 mm in machine coordinates, above [AXIS_X] MAX_LIMIT = 200");
}

TEST_F(CircgenCliIni, WorkOffsetMovesTheCircleInMachineCoordinates) {
  expect_refused(run({"--d", "150", "--f", "300", "--offset", "-180,0,0"}), 6,
                 "X = -255 mm in machine coordinates, below [AXIS_X] MIN_LIMIT = -200");
  // Only the arcs count, not the centre: a partial arc on the +X side of a circle centred
  // 240 mm into the -X side stays clear of the -200 limit, the full circle does not.
  const CommandResult ok = run({"--d", "150", "--f", "300", "--offset", "-240,0,0", "--arc", "110",
                                "--start", "-45", "--lead", "10"});
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  expect_refused(run({"--d", "150", "--f", "300", "--offset", "-240,0,0"}), 6, "MIN_LIMIT = -200");
}

TEST_F(CircgenCliIni, RefusesAClearanceAboveTheZLimit) {
  expect_refused(run({"--d", "150", "--f", "300", "--safe-z", "20"}), 6,
                 "Z = 20 mm in machine coordinates, above [AXIS_Z] MAX_LIMIT = 10");
}

TEST_F(CircgenCliIni, RefusesAFeedAboveMaxVelocity) {
  expect_refused(run({"--d", "150", "--f", "2400"}), 6,
                 "feed 2400 mm/min = 40 mm/s exceeds [AXIS_X] MAX_VELOCITY = 30");
  // The fastest feed of a sweep counts.
  expect_refused(run({"--d", "150", "--feeds", "300,1200,2400"}), 6, "MAX_VELOCITY = 30");
}

TEST_F(CircgenCliIni, RefusesACentripetalAccelerationAboveMaxAcceleration) {
  // 1200 mm/min = 20 mm/s on R 0.5 mm: 800 mm/s^2 > 500.
  expect_refused(run({"--d", "1", "--f", "1200", "--lead", "90"}), 6,
                 "centripetal acceleration V^2/R = 800 mm/s^2 at F1200 on R0.5 mm exceeds "
                 "[AXIS_X] MAX_ACCELERATION = 500");
  // R 0.85 mm: 470.6 mm/s^2, under 500 but above the planner's 0.866 * 500 = 433 on arcs.
  expect_refused(run({"--d", "1.7", "--f", "1200", "--lead", "90"}), 6,
                 "that LinuxCNC's planner allows on an arc");
}

TEST_F(CircgenCliIni, RefusesALeadInTooShortToReachTheFeed) {
  // 25 mm/s with about 496 mm/s^2 tangential needs 0.63 mm; 1 deg on R 10 is 0.17 mm.
  expect_refused(run({"--d", "20", "--f", "1500", "--lead", "1"}), 6, "use --lead 4 or more");
  EXPECT_EQ(run({"--d", "20", "--f", "1500", "--lead", "4"}).exit_code, 0);
}

TEST_F(CircgenCliIni, ParseErrorsNameFileAndLine) {
  std::string text = kMachineIni;
  text.replace(text.find("MAX_LIMIT = 10"), 14, "MAX_LIMIT = ten");
  spit(ini(), text);
  expect_refused(run({"--d", "150", "--f", "300"}), 4,
                 ini() + ":23: [AXIS_Z] MAX_LIMIT: 'ten' is not a number");
  text = kMachineIni;
  text.replace(text.find("LINEAR_UNITS = mm"), 17, "LINEAR_UNITS = furlong");
  spit(ini(), text);
  expect_refused(run({"--d", "150", "--f", "300"}), 4, "LINEAR_UNITS: unknown unit 'furlong'");
}

// LinuxCNC 2.9 starts these, so circgen reads them: a line without '=' (ignored), a
// continuation line, LINEAR_UNITS as units per mm, sections from an #INCLUDEd file.
TEST_F(CircgenCliIni, ReadsWhatLinuxcncReads) {
  std::string text = kMachineIni;
  text.insert(text.find("[TRAJ]"), "[APPLICATIONS]\nthis is not a key\nAPP = a \\\n   b\n");
  text.replace(text.find("LINEAR_UNITS = mm"), 17, "LINEAR_UNITS = 1.0");
  spit(ini(), text);
  EXPECT_EQ(run({"--d", "150", "--f", "300"}).exit_code, 0);
  expect_refused(run({"--d", "450", "--f", "300"}), 6, "MIN_LIMIT = -200");
  // 0.03937 units per mm is inch: the 200 unit X limit is 5080 mm.
  text.replace(text.find("LINEAR_UNITS = 1.0"), 18, "LINEAR_UNITS = 0.03937007874");
  spit(ini(), text);
  const auto r = run({"--d", "450", "--f", "300"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  // The [AXIS_Z] section in an included file.
  text = kMachineIni;
  const auto z = text.find("[AXIS_Z]");
  spit(dir_.file("axis_z.inc"), text.substr(z));
  spit(ini(), text.substr(0, z) + "#INCLUDE axis_z.inc\n");
  EXPECT_EQ(run({"--d", "150", "--f", "300"}).exit_code, 0);
  text.replace(text.find("MAX_LIMIT = 10"), 14, "MAX_LIMIT = ten");
  spit(dir_.file("axis_z.inc"), text.substr(z));
  expect_refused(run({"--d", "150", "--f", "300"}), 4,
                 dir_.file("axis_z.inc") + ":3: [AXIS_Z] MAX_LIMIT: 'ten' is not a number");
}

TEST_F(CircgenCliIni, MissingAxisSectionIsAnError) {
  std::string text = kMachineIni;
  text.resize(text.find("[AXIS_Z]"));
  spit(ini(), text);
  expect_refused(run({"--d", "150", "--f", "300"}), 4, "no [AXIS_Z] section");
}

TEST_F(CircgenCliIni, MissingFileIsAnIoError) {
  expect_refused(run_circgen({"--d", "150", "--f", "300", "--ini", dir_.file("nope.ini")}), 3,
                 dir_.file("nope.ini"));
}

TEST_F(CircgenCliIni, InchMachineLimitsAreConverted) {
  std::string text = kMachineIni;
  text.replace(text.find("LINEAR_UNITS = mm"), 17, "LINEAR_UNITS = inch");
  spit(ini(), text);  // limits now 200 inch etc.; 2 inch/s velocity limit is 30 inch/s
  EXPECT_EQ(run({"--d", "150", "--f", "300"}).exit_code, 0);
  text.replace(text.find("MAX_LIMIT = 200"), 15, "MAX_LIMIT = 5");
  spit(ini(), text);
  expect_refused(run({"--d", "300", "--f", "300"}), 6,
                 "X = 5.905511811 inch in machine coordinates, above [AXIS_X] MAX_LIMIT = 5");
}

TEST_F(CircgenCliIni, BallbarFeedInStartCountsForTheSoftLimits) {
  // R 199 reaches X 199 on the circle; the feed-in starts 1.5 mm further out, at 200.5.
  EXPECT_EQ(run({"--d", "398", "--f", "300"}).exit_code, 0);
  expect_refused(
      run({"--d", "398", "--f", "300", "--instrument", "ballbar", "--ballbar-lengths", "199"}), 6,
      "X = -200.5 mm in machine coordinates, below [AXIS_X] MIN_LIMIT = -200");
}

TEST_F(CircgenCliIni, MarkerAndSegmentOutputsAgainstTheMotionModule) {
  std::string text = kMachineIni;
  text += "\n[HAL]\nHALFILE = LIB:basic_sim.tcl\nHALFILE = missing.hal\nHALFILE = machine.hal\n";
  spit(ini(), text);
  spit(dir_.file("machine.hal"), "loadrt trivkins\nloadrt motmod num_joints=3 num_dio=2\n");
  const CommandResult ok = run({"--d", "150", "--f", "300", "--marker", "1", "--segment-out", "3"});
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.out.find("lead run-up,motion outputs)"), std::string::npos);
  expect_refused(run({"--d", "150", "--f", "300", "--marker", "2"}), 6,
                 "--marker 2: the motion module loaded at " + dir_.file("machine.hal") +
                     ":2 has num_dio=2 (M62/M63 P0..P1)");
  expect_refused(run({"--d", "150", "--f", "300", "--segment-out", "4"}), 6,
                 "has num_aio=4 (M67 E0..E3)");
  // Without a HAL file that loads the module there is nothing to check against.
  spit(dir_.file("machine.hal"), "loadrt trivkins\n");
  const CommandResult unchecked = run({"--d", "150", "--f", "300", "--marker", "9"});
  ASSERT_EQ(unchecked.exit_code, 0) << unchecked.err;
  EXPECT_EQ(unchecked.out.find("motion outputs"), std::string::npos);
}

TEST(CircgenCli, HeaderStatesInheritedOffsetsAndTheCentreInMachineCoordinates) {
  const CommandResult r =
      run_circgen({"--d", "150", "--f", "300", "--centre", "10,20,-5", "--offset", "100,-50,-200"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("(circtest: work_offset: inherited, not set by the program)"),
            std::string::npos);
  EXPECT_NE(r.out.find("(circtest: tool_length_offset: inherited, not set by the program)"),
            std::string::npos);
  EXPECT_NE(r.out.find("(circtest: centre_machine_mm: 110,-30,-205)"), std::string::npos);
  EXPECT_EQ(run_circgen({"--d", "150", "--f", "300"}).out.find("centre_machine_mm"),
            std::string::npos);
}

TEST(CircgenCli, WarnsWhenAVerticalArcPassesBelowTheCentre) {
  // ZX: +Z is 0 deg, the bottom 180 deg. 200 deg in all (180 deg of data) from 90 with 10 deg
  // leads covers 80..280.
  const CommandResult below =
      run_circgen({"--plane", "ZX", "--d", "150", "--f", "300", "--arc", "200", "--start", "90"});
  ASSERT_EQ(below.exit_code, 0) << below.err;
  EXPECT_TRUE(below.err.starts_with("circgen: warning: the 180 deg arc")) << below.err;
  EXPECT_NE(below.err.find("passes below the centre in ZX"), std::string::npos);
  EXPECT_FALSE(below.out.empty());
  // Without --start the partial arc is centred on top: no warning, and the start says so.
  const CommandResult top =
      run_circgen({"--plane", "ZX", "--d", "150", "--f", "300", "--arc", "200"});
  EXPECT_TRUE(top.err.empty()) << top.err;
  EXPECT_NE(top.out.find("(circtest: start_deg: 270)"), std::string::npos);
  const CommandResult yz =
      run_circgen({"--plane", "YZ", "--d", "150", "--f", "300", "--arc", "140"});
  EXPECT_TRUE(yz.err.empty()) << yz.err;
  EXPECT_NE(yz.out.find("(circtest: start_deg: 30)"), std::string::npos);
  // A ballbar in a vertical plane defaults to 180 deg of data with 20 deg overshoots on top.
  const CommandResult bar =
      run_circgen({"--plane", "YZ", "--d", "200", "--f", "500", "--instrument", "ballbar"});
  ASSERT_EQ(bar.exit_code, 0) << bar.err;
  EXPECT_TRUE(bar.err.empty()) << bar.err;
  EXPECT_NE(bar.out.find("(circtest: arc_deg: 180)"), std::string::npos);
  EXPECT_NE(bar.out.find("(circtest: start_deg: 0)"), std::string::npos);
  EXPECT_NE(bar.out.find("(circtest: lead_deg: 20)"), std::string::npos);
  // A full circle with a ballbar in a vertical plane goes through the bottom: warned.
  const CommandResult full = run_circgen(
      {"--plane", "YZ", "--d", "200", "--f", "500", "--instrument", "ballbar", "--arc", "400"});
  EXPECT_EQ(full.exit_code, 0);
  EXPECT_NE(full.err.find("passes below the centre in YZ"), std::string::npos) << full.err;
  // XY has no below.
  EXPECT_TRUE(
      run_circgen({"--d", "150", "--f", "300", "--arc", "180", "--start", "90"}).err.empty());
}

TEST(CircgenCli, OutputFileIsWrittenAndStdoutStaysEmpty) {
  ScratchDir dir;
  const CommandResult r = run_circgen({"--d", "150", "--f", "300", "-o", dir.file("t.ngc")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.out.empty());
  const std::string file = slurp(dir.file("t.ngc"));
  EXPECT_EQ(file, run_circgen({"--d", "150", "--f", "300"}).out);
}

TEST(CircgenCli, UnwritableOutputIsAnIoError) {
  expect_refused(run_circgen({"--d", "150", "--f", "300", "-o", "/nonexistent-dir/t.ngc"}), 3,
                 "/nonexistent-dir/t.ngc");
}

TEST(CircgenCli, OutputThatIsNotARegularFileIsRefusedAndKept) {
  ScratchDir dir;
  const std::string fifo = dir.file("fifo.ngc");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  expect_refused(run_circgen({"--d", "150", "--f", "300", "-o", fifo}), 3,
                 fifo + ": is a FIFO, not a regular file; refusing to replace it");
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  expect_refused(run_circgen({"--d", "150", "--f", "300", "-o", dir.path()}), 3,
                 dir.path() + ": is a directory, not a regular file");
  expect_refused(run_circgen({"--d", "150", "--f", "300", "-o", "/dev/full"}), 3,
                 "/dev/full: is a character device, not a regular file");
  EXPECT_TRUE(std::filesystem::is_character_file("/dev/full"));
  // A symbolic link to a program: the program is replaced, the link stays.
  spit(dir.file("real.ngc"), "old\n");
  std::filesystem::create_symlink("real.ngc", dir.file("link.ngc"));
  ASSERT_EQ(run_circgen({"--d", "150", "--f", "300", "-o", dir.file("link.ngc")}).exit_code, 0);
  EXPECT_TRUE(std::filesystem::is_symlink(dir.file("link.ngc")));
  EXPECT_EQ(slurp(dir.file("real.ngc")), run_circgen({"--d", "150", "--f", "300"}).out);
}

TEST(CircgenCli, HelpAndVersionGoToStdout) {
  const CommandResult help = run_circgen({"--help"});
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("--ref-f"), std::string::npos);
  const CommandResult version = run_circgen({"--version"});
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_TRUE(version.out.starts_with("circgen "));
}

}  // namespace
}  // namespace circtest::testing
