// circtest::gcode pieces on their own: Annex C, run planning, header keys.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "circtest/circgen/commands.hpp"
#include "circtest/core/error.hpp"
#include "circtest/gcode/annex_c.hpp"
#include "circtest/gcode/generator.hpp"
#include "circtest/gcode/machine_limits.hpp"
#include "circtest/gcode/plausible_ranges.hpp"

namespace circtest {
namespace {

std::string header_value(const TestProgram& p, const std::string& key) {
  for (const auto& [k, v] : p.header)
    if (k == key) return v;
  return "<absent>";
}

TEST(AnnexC, StandardExampleGivesF559) {
  const AnnexCNote note = annex_c_note(125, 100, 500, LengthUnit::mm);
  EXPECT_NEAR(note.scaled_feed_exact, 500 * std::sqrt(1.25), 1e-12);
  EXPECT_DOUBLE_EQ(note.scaled_feed, 559.0);
  // Same acceleration V^2/R for both tests, to the rounding of the feed.
  EXPECT_NEAR(note.scaled_feed_exact * note.scaled_feed_exact / 62.5, 500.0 * 500.0 / 50.0, 1e-9);
  EXPECT_NEAR(annex_c_note(5, 4, 20, LengthUnit::inch).scaled_feed, 22.4, 1e-12);
  EXPECT_THROW(annex_c_feed(125, -1, 500), UsageError);
}

// The library's refusals name the setting by its own word; circgen's words are its options.
TEST(AnnexC, RefusalsNameTheSettingInTheFrontEndsWords) {
  auto message = [](auto&& call) {
    try {
      call();
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message([] { annex_c_feed(125, -1, 500); }),
            "reference_diameter: the reference diameter must be positive, got -1");
  EXPECT_EQ(message([] { annex_c_feed(125, -1, 500, circgen_option_words); }),
            "--ref-d: the reference diameter must be positive, got -1");
  EXPECT_EQ(message([] { annex_c_note(125, 100, 5e6, LengthUnit::mm); }).substr(0, 16),
            "reference_feed: ");
  EXPECT_EQ(message([] { check_plausible(plausible::lead, 200.0); }),
            "lead_deg: lead arc of 200 deg is outside the plausible range 1..180 deg "
            "(docs/circgen.md)");
  EXPECT_EQ(
      message([] { check_plausible(plausible::lead, 200.0, circgen_option_words); }).substr(0, 8),
      "--lead: ");
}

TEST(AnnexC, HeaderShowsTheComputation) {
  CircleTestSpec spec;
  spec.radius_mm = 62.5;
  spec.annex_c = annex_c_note(125, 100, 500, LengthUnit::mm);
  spec.feeds_mm_per_min = {spec.annex_c->scaled_feed};
  const TestProgram p = generate_test_program(spec);
  EXPECT_EQ(header_value(p, "annex_c"),
            "V1 = V2 * sqrt[D1/D2] = 500 * sqrt[125/100] = 559.017 -> F559");
  EXPECT_EQ(header_value(p, "feed_mm_per_min"), "559");
}

TEST(ProgramPlan, SweepGivesOneCcwCwPairPerFeedWithIdsFromOne) {
  CircleTestSpec spec;
  spec.radius_mm = 50;
  spec.feeds_mm_per_min = {100, 1000};
  spec.arc_deg = 120;
  spec.start_deg = 30;
  spec.lead_deg = 5;
  const auto runs = plan_runs(spec);
  ASSERT_EQ(runs.size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(runs[i].segment_id, i + 1);
  EXPECT_EQ(runs[0].direction, Direction::CCW);
  EXPECT_EQ(runs[1].direction, Direction::CW);
  EXPECT_DOUBLE_EQ(runs[0].start_deg, 30);
  EXPECT_DOUBLE_EQ(runs[1].start_deg, 150);  // the CW run starts at the far end
  EXPECT_DOUBLE_EQ(runs[3].feed_mm_per_min, 1000);
  const TestProgram p = generate_test_program(spec);
  EXPECT_EQ(header_value(p, "segments"), "1:CCW:F100:XY,2:CW:F100:XY,3:CCW:F1000:XY,4:CW:F1000:XY");
  EXPECT_EQ(header_value(p, "feed_mm_per_min"), "<absent>");  // a sweep has no single feed
  EXPECT_EQ(header_value(p, "feeds_mm_per_min"), "100,1000");
}

TEST(ProgramHeader, InchProgramStillReportsMillimetres) {
  CircleTestSpec spec;
  spec.units = LengthUnit::inch;
  spec.radius_mm = 2 * kMmPerInch;
  spec.feeds_mm_per_min = {20 * kMmPerInch};
  spec.centre_mm = {1.5 * kMmPerInch, 0, -0.25 * kMmPerInch};
  spec.plane = Plane::YZ;
  const TestProgram p = generate_test_program(spec);
  EXPECT_EQ(header_value(p, "units"), "inch");
  EXPECT_EQ(header_value(p, "diameter_mm"), "101.6");
  EXPECT_EQ(header_value(p, "diameter_in"), "4");
  EXPECT_EQ(header_value(p, "centre_mm"), "38.1,0,-6.35");
  EXPECT_EQ(header_value(p, "centre_in"), "1.5,0,-0.25");
  EXPECT_EQ(header_value(p, "feed_mm_per_min"), "508");
  EXPECT_EQ(header_value(p, "feed_in_per_min"), "20");
  EXPECT_EQ(header_value(p, "direction_labels"), "YZ,ZY");
  EXPECT_NE(p.text.find("G20 G19"), std::string::npos);
  // Every header entry is a comment line the recorder can copy as "# key: value".
  for (const auto& [k, v] : p.header) {
    EXPECT_NE(p.text.find("(circtest: " + k + ": " + v + ")\n"), std::string::npos) << k;
  }
}

TEST(MachineLimits, FirstOccurrenceWinsAndUnitsConvert) {
  const MachineLimits m = parse_machine_limits(
      "[TRAJ]\nLINEAR_UNITS = inch\n[AXIS_X]\nMAX_LIMIT = 10\nMAX_LIMIT = 20\n[AXIS_Y]\n", "m.ini");
  EXPECT_DOUBLE_EQ(*m.axes[0].max_limit_mm, 254.0);
  EXPECT_TRUE(m.axes[1].present);
  EXPECT_FALSE(m.axes[1].max_limit_mm.has_value());
  EXPECT_FALSE(m.axes[2].present);
}

}  // namespace
}  // namespace circtest

namespace circtest {
namespace {

TEST(MotionOutputs, FindsTheMotionModuleLineWithItsCounts) {
  MachineLimits ini = parse_machine_limits(
      "[EMCMOT]\nEMCMOT = motmod\nSERVO_PERIOD = 1000000\n[CIRCTEST]\nDIO = 8\n[HAL]\n"
      "HALFILE = a.hal\nHALFILE = b.hal\n",
      "m.ini");
  EXPECT_EQ(ini.hal_files, (std::vector<std::string>{"a.hal", "b.hal"}));
  const auto found = find_motion_outputs(
      "# the machine\nloadrt trivkins\nloadrt [EMCMOT]EMCMOT servo_period_nsec=[EMCMOT]SERVO_PERIOD"
      " \\\n   num_joints=3 num_dio=[CIRCTEST]DIO # eight bits\nloadrt motmod num_dio=2\n",
      "a.hal", ini);
  ASSERT_TRUE(found);
  EXPECT_EQ(found->num_dio, 8);  // through the INI substitution, on the continued line
  EXPECT_EQ(found->num_aio, 4);  // motmod's default
  EXPECT_EQ(found->where, "a.hal:3");
  EXPECT_FALSE(find_motion_outputs("loadrt circlog channels=8\n# loadrt motmod\n", "b.hal", ini));
  try {
    find_motion_outputs("\nloadrt motmod num_aio=four\n", "c.hal", ini);
    FAIL() << "no error";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("c.hal:2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("num_aio='four'"), std::string::npos) << e.what();
  }
}

TEST(MotionOutputs, RefusesOutputsTheModuleDoesNotHave) {
  // Without MAX_VELOCITY LinuxCNC gives an axis 1 unit/s: state generous ones.
  std::string ini;
  for (const char* axis : {"X", "Y", "Z"}) {
    ini += std::string("[AXIS_") + axis + "]\nMAX_VELOCITY = 100\nMAX_ACCELERATION = 5000\n";
  }
  MachineLimits limits = parse_machine_limits(ini, "m.ini");
  limits.motion_outputs = MotionOutputs{2, 1, "m.hal:5"};
  CircleTestSpec spec;
  spec.radius_mm = 50;
  spec.feeds_mm_per_min = {500};
  spec.marker_output = 1;
  const auto checks = check_against_machine(spec, limits, {0, 0, 0});
  EXPECT_EQ(checks.back(), "motion outputs");
  spec.marker_output = 2;
  EXPECT_THROW(check_against_machine(spec, limits, {0, 0, 0}), LimitError);
  spec.marker_output = 0;
  spec.segment_output = 1;
  try {
    check_against_machine(spec, limits, {0, 0, 0});
    FAIL() << "no error";
  } catch (const LimitError& e) {
    // The library names the spec's field; circgen words it as its option.
    EXPECT_NE(std::string(e.what()).find("segment_output 1: the motion module loaded at m.hal:5 "
                                         "has num_aio=1"),
              std::string::npos)
        << e.what();
    EXPECT_EQ(std::string(e.what()).find("--"), std::string::npos) << e.what();
  }
  try {
    check_against_machine(spec, limits, {0, 0, 0}, circgen_option_words);
    FAIL() << "no error";
  } catch (const LimitError& e) {
    EXPECT_NE(std::string(e.what()).find("--segment-out 1: the motion module loaded at m.hal:5 "
                                         "has num_aio=1"),
              std::string::npos)
        << e.what();
  }
}

// circgen's command on its own: what it writes is exactly the generated program, the
// warnings go to the error stream, and a refused specification writes nothing.
TEST(Commands, RunGenerateWritesTheProgramAndItsWarnings) {
  GenerateRequest request;
  CircleTestSpec spec;
  spec.radius_mm = 100.0;
  spec.feeds_mm_per_min = {500.0};
  spec.plane = Plane::ZX;
  spec.instrument = Instrument::ballbar;
  spec.arc_deg = 360.0;
  request.planes = {spec};
  const std::vector<std::string> warnings = program_warnings(spec);
  ASSERT_FALSE(warnings.empty());  // a ballbar's full circle in ZX passes below the centre
  const std::string program = generate_test_program(spec).text;
  std::ostringstream out, err;
  EXPECT_EQ(run_generate(request, out, err), 0);
  EXPECT_EQ(out.str(), program);
  // The same warnings, circgen naming its option where the library names the spec's field.
  std::string expected_err;
  for (std::string w : warnings) {
    const auto at = w.find("drop start_deg");
    ASSERT_NE(at, std::string::npos) << w;
    expected_err += "circgen: warning: " + w.replace(at, 14, "drop --start") + "\n";
  }
  EXPECT_EQ(err.str(), expected_err);

  request.planes.front().radius_mm = 0.0;
  std::ostringstream none;
  EXPECT_THROW(run_generate(request, none, err), UsageError);
  EXPECT_EQ(none.str(), "");
}

// Library text names no command-line option: validate() and program_warnings()
// used as a library name the spec's fields; circgen words them as its options (test_cli.cpp
// holds those messages).
TEST(Commands, LibraryRefusalsNameTheSpecFieldsNotOptions) {
  auto refusal = [](auto change) -> std::string {
    CircleTestSpec spec;
    spec.radius_mm = 50.0;
    spec.feeds_mm_per_min = {500.0};
    change(spec);
    try {
      validate(spec);
    } catch (const UsageError& e) {
      return e.what();
    }
    return "no refusal";
  };
  const std::string texts[] = {
      refusal([](CircleTestSpec& s) { s.radius_mm = 0.0; }),
      refusal([](CircleTestSpec& s) { s.feeds_mm_per_min.clear(); }),
      refusal([](CircleTestSpec& s) { s.arc_deg = 270.0, s.lead_deg = 50.0; }),
      refusal([](CircleTestSpec& s) { s.directions.clear(); }),
      refusal([](CircleTestSpec& s) { s.dwell_s = -1.0; }),
      refusal([](CircleTestSpec& s) { s.instrument = Instrument::ballbar, s.radius_mm = 5000.0; }),
  };
  EXPECT_EQ(texts[0], "radius_mm: the circle must have a positive size, got radius 0");
  EXPECT_EQ(texts[1], "no feed: give feeds_mm_per_min");
  EXPECT_NE(texts[2].find("lead_deg: 50 deg lead arcs around a 270 deg arc would overlap each "
                          "other (arc + 2 * lead = 370 > 360 deg); use lead_deg 45 or less"),
            std::string::npos)
      << texts[2];
  EXPECT_EQ(texts[3], "directions: no direction");
  EXPECT_NE(texts[4].find("dwell_s: must be 0.."), std::string::npos) << texts[4];
  EXPECT_NE(texts[5].find("instrument ballbar: radius 5000 mm"), std::string::npos) << texts[5];
  for (const auto& t : texts) EXPECT_EQ(t.find("--"), std::string::npos) << t;
}

}  // namespace
}  // namespace circtest
