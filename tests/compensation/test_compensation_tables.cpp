// circcomp's compensation tables on fixture configurations: a scale written as a table (the
// backlash moved into it), tables of LinuxCNC's types 0 and 1 merged, LinuxCNC's table rules,
// cyclic errors within its 256 entries and in machine coordinates from circana diagnose, and
// the bounds of a scale.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string>

#include "circtest/compensation/comp_table.hpp"
#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "compensation_test_support.hpp"

namespace fs = std::filesystem;
using namespace circtest;
using namespace circtest::compensation;
using namespace circtest::testing;

TEST(Compensation, ScaleCreatesATableWithBacklashMovedIntoIt) {
  Scratch s;
  const std::string text = machine();
  const std::string ini = s.write("m.ini", text);
  DiagnosisInput d = diag(0.002, ini);
  d.diagnosis.scale_ppm[0] = {20.0, 0.5};
  d.diagnosis.scale_ppm[1] = {0.0, 0.5};
  apply_plan(make_plan(ini, d, PlanOptions{}));
  const IniDocument doc = IniDocument::load(ini);
  EXPECT_EQ(doc.get("JOINT_0", "COMP_FILE"), "circtest-joint0.comp");
  EXPECT_EQ(doc.get("JOINT_0", "COMP_FILE_TYPE"), "1");
  EXPECT_EQ(doc.get("JOINT_0", "BACKLASH"), "0");
  EXPECT_NE(doc.render().find("# circcomp: backlash (0.008) is in circtest-joint0.comp"),
            std::string::npos);
  const CompTable t = parse_comp_table(s.read("circtest-joint0.comp"), 1, "t");
  ASSERT_EQ(t.entries.size(), 2u);
  // Truth: the machine moves the table to (1 + s) * motor, the motor gets x + trim; moving up
  // the old and the new play (0.008 + 0.002) are taken up by half of it each way.
  for (double x : {-300.0, -12.5, 0.0, 175.0, 300.0}) {
    const CompEntry e = t.at(x);
    EXPECT_NEAR((1 + 20e-6) * (x + e.forward_trim - 0.005), x, 1e-6) << x;
    EXPECT_NEAR((1 + 20e-6) * (x + e.reverse_trim + 0.005), x, 1e-6) << x;
  }
  EXPECT_TRUE(revert(ini));
  EXPECT_EQ(read_file(ini), text);
  EXPECT_FALSE(fs::exists(s.dir() / "circtest-joint0.comp"));
}

TEST(Compensation, ExistingTablesType0And1AreMergedInTheirType) {
  for (int type : {0, 1}) {
    Scratch s;
    // Nominal 0, 100, 200; type 0 gives actual positions, type 1 trims.
    const std::string table = type == 0 ? "0 0.001 -0.001\n100 99.999 100.002\n200 200 200\n"
                                        : "0 -0.001 0.001\n100 0.001 -0.002\n200 0 0\n";
    s.write("x.comp", table);
    const std::string ini = s.write(
        "m.ini", machine("trivkins", "BACKLASH = 0.5\nCOMP_FILE = x.comp\nCOMP_FILE_TYPE = " +
                                         std::to_string(type) + "\n"));
    const Plan plan = make_plan(ini, diag(0.004), only(Correction::backlash));
    ASSERT_EQ(plan.files.size(), 1u) << "the INI stays as it is";
    EXPECT_EQ(fs::path(plan.files[0].path).filename(), "x.comp");
    const CompTable before = parse_comp_table(table, type, "x");
    const CompTable after = parse_comp_table(plan.files[0].after, type, "x");
    ASSERT_EQ(after.entries.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
      EXPECT_NEAR(after.entries[i].forward_trim, before.entries[i].forward_trim + 0.002, 1e-9);
      EXPECT_NEAR(after.entries[i].reverse_trim, before.entries[i].reverse_trim - 0.002, 1e-9);
    }
    // BACKLASH is ignored by LinuxCNC with a table: left alone, and said so.
    bool said = false;
    for (const auto& n : plan.notes)
      said = said || n.find("BACKLASH = 0.5 has no effect") != std::string::npos;
    EXPECT_TRUE(said);
  }
}

TEST(Compensation, TableRulesOfLinuxcnc) {
  EXPECT_THROW(parse_comp_table("# a comment\n0 0 0\n", 1, "c"), ParseError);
  EXPECT_THROW(parse_comp_table("0 0 0\n0 0 0\n", 1, "c"), ParseError);
  EXPECT_THROW(parse_comp_table("0 0 0\n\n1 0 0\n", 1, "c"), ParseError);
  // fuzz_comp_table: a type-0 difference of two finite positions overflowing to inf.
  EXPECT_THROW(parse_comp_table("1e308 -1e308 0\n", 0, "c"), ParseError);
  // Written back at full precision: a value below 1e-9 and close nominals survive a rewrite.
  const CompTable fine = parse_comp_table("-500.00000333333 0.01 0\n-500.0000000001 5 1\n", 1, "c");
  const CompTable back = parse_comp_table(render_comp_table(fine), 1, "c");
  ASSERT_EQ(back.entries.size(), 2u);
  EXPECT_EQ(back.entries[0].nominal, -500.00000333333);
  EXPECT_EQ(back.entries[1].nominal, -500.0000000001);
  std::string big;
  for (int i = 0; i < 257; ++i) big += std::to_string(i) + " 0 0\n";
  try {
    parse_comp_table(big, 1, "c");
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), 257u);
  }
  EXPECT_EQ(parse_comp_table("0 0 0\n1 0.5 -0.5\n\n", 1, "c").at(0.5).forward_trim, 0.25);
  // fuzz_comp_table: trims of opposite sign near DBL_MAX interpolate to a finite value.
  const CompTable wide = parse_comp_table("01e30 1e308 0\n1e38 -1e308 0\n", 0, "c");
  EXPECT_TRUE(std::isfinite(wide.at(5e37).forward_trim));
  EXPECT_NEAR(wide.at(5e37).forward_trim / 1e308, 0.0, 0.01);
  // ... and nominals of opposite sign near DBL_MAX, whose span overflows.
  const CompTable span = parse_comp_table("-1e308 0 0\n1e308 0 1e308\n", 1, "c");
  EXPECT_DOUBLE_EQ(span.at(std::nextafter(1e308, 0.0)).reverse_trim, 1e308);
  EXPECT_DOUBLE_EQ(span.at(0.0).reverse_trim, 0.5e308);
  // A comment on top disables the table in LinuxCNC: circcomp refuses to merge into it.
  Scratch s;
  s.write("x.comp", "# measured 2024\n0 0 0\n");
  const std::string ini =
      s.write("m.ini", machine("trivkins", "COMP_FILE = x.comp\nCOMP_FILE_TYPE = 1\n"));
  try {
    make_plan(ini, diag(0.004), only(Correction::backlash));
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("ignores all of it"), std::string::npos) << e.what();
  }
}

TEST(Compensation, CyclicNeedsSixteenPointsAPitchWithin256) {
  Scratch s;
  DiagnosisInput d = diag(0.0);
  d.diagnosis.cyclic[0] = Cyclic{0.002, 5.0, 0.3, 1e-4, {}, {}};
  // 600 mm of travel at 5/16 mm spacing is 1921 points: not written, said why.
  const std::string wide = s.write("w.ini", machine("trivkins", ""));
  const Plan refused = make_plan(wide, d, only(Correction::cyclic));
  EXPECT_TRUE(refused.files.empty());
  bool said = false;
  for (const auto& n : refused.notes)
    said = said || n.find("more than LinuxCNC's 256") != std::string::npos;
  EXPECT_TRUE(said);
  // 50 mm of travel fits; the table cancels the error to the interpolation error.
  std::string narrow = machine("trivkins", "");
  narrow.replace(narrow.find("MIN_LIMIT = -300"), 16, "MIN_LIMIT = 0");
  narrow.replace(narrow.find("MAX_LIMIT = 300"), 15, "MAX_LIMIT = 50");
  const std::string ini = s.write("n.ini", narrow);
  const Plan plan = make_plan(ini, d, only(Correction::cyclic));
  const FileChange* table = nullptr;
  for (const auto& f : plan.files)
    if (f.path.ends_with(".comp")) table = &f;
  ASSERT_TRUE(table);
  const CompTable t = parse_comp_table(table->after, 1, "t");
  double worst = 0;
  for (double x = 0; x <= 50; x += 0.01) {
    const double motor = x + t.at(x).forward_trim;
    const double actual = motor + 0.002 * std::sin(2 * std::numbers::pi * motor / 5.0 + 0.3);
    worst = std::max(worst, std::fabs(actual - x));
  }
  EXPECT_LT(worst, 0.002 * 0.03);  // under 3 % of the amplitude left
}

// A scale beyond 500 ppm (docs/compensation.md) is refused without --force, naming the axis and
// value (sim-servo's D20 F2000 servo read as Y -646 ppm); 450 ppm is written.
TEST(Compensation, ScaleBeyondWhatMachinesShowIsRefused) {
  Scratch s;
  const std::string ini = s.write("m.ini", machine());
  DiagnosisInput servo = diag(0.0);
  servo.diagnosis.scale_ppm[1] = {-646.0, 5.0};
  EXPECT_THROW(
      {
        try {
          make_plan(ini, servo, only(Correction::scale));
        } catch (const DataError& e) {
          EXPECT_NE(std::string(e.what()).find("Y scale = -646.0 ppm is implausible (more than "
                                               "500.0 ppm)"),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      DataError);
  PlanOptions force = only(Correction::scale);
  force.force = true;
  EXPECT_NO_THROW(make_plan(ini, servo, force));
  servo.diagnosis.scale_ppm[1] = {450.0, 5.0};
  EXPECT_NO_THROW(make_plan(ini, servo, only(Correction::scale)));
  // Within its standard error (the loop's bound at the test's speed): not changed, the plan
  // goes on (backlash written), a note says why.
  DiagnosisInput loose = diag(0.002);
  loose.diagnosis.scale_ppm[0] = {-3.7, 14.3};
  const Plan plan = make_plan(ini, loose, {});
  EXPECT_FALSE(plan.files.empty());
  EXPECT_TRUE(std::any_of(plan.notes.begin(), plan.notes.end(), [](const std::string& n) {
    return n ==
           "X scale: -3.7 ppm is within its standard error of 14.3 ppm: not changed (a "
           "larger diameter or a lower feed measures it closer)";
  }));
}

#if defined(CIRCANA_PATH)
// The cyclic phase convention across the two programs: the test simulator puts
// A sin(2 pi x / pitch) on X in machine coordinates with the circle's centre far from 0, circana
// diagnose fits it, and the table circcomp plans must cancel it at machine positions (it
// would be off by 2 pi centre / pitch if either side measured x from the centre).
TEST(Compensation, CyclicPhaseIsInMachineCoordinatesFromDiagnoseToTable) {
  Scratch s;
  const std::string trace = (s.dir() / "cyc.csv").string();
  const std::string diagnosis = (s.dir() / "cyc.json").string();
  ASSERT_EQ(std::system((std::string(SIMTRACE_PATH) + " -o " + trace +
                         " --d 40 --f 1000 --cx 101.3 --cy 37.9 --kv-x 1000 --kv-y 1000"
                         " --cyclic-x 0.003 --pitch-x 5 --noise 0.0002 >/dev/null")
                            .c_str()),
            0);
  ASSERT_EQ(std::system((std::string(CIRCANA_PATH) + " diagnose " + trace +
                         " --pitch X=5 --json >" + diagnosis)
                            .c_str()),
            0);
  // X's travel short enough for 16 points a pitch within 256 entries.
  std::string text = machine("trivkins coordinates=XYZ", "");
  text.replace(text.find("MIN_LIMIT = -300\nMAX_LIMIT = 300"), 32,
               "MIN_LIMIT = 80\nMAX_LIMIT = 125");
  const std::string ini = s.write("m.ini", text);
  const Plan plan = make_plan(ini, read_diagnosis(diagnosis), only(Correction::cyclic));
  const FileChange* table = nullptr;
  for (const auto& f : plan.files) {
    if (f.path.ends_with("circtest-joint0.comp")) table = &f;
  }
  std::string notes;
  for (const auto& n : plan.notes) notes += n + "\n";
  ASSERT_TRUE(table) << notes;
  const CompTable t = parse_comp_table(table->after, 1, "t");
  double worst = 0;
  for (double x = 80; x <= 125; x += 0.01) {  // the circle's X range and beyond
    const double motor = x + t.at(x).forward_trim;
    const double actual = motor + 0.003 * std::sin(2 * std::numbers::pi * motor / 5.0);
    worst = std::max(worst, std::fabs(actual - x));
  }
  EXPECT_LT(worst, 0.003 * 0.05);  // under 5 % of the amplitude left
}
#endif
