// The servo-mismatch sign from the simulator's known loop gains through the whole chain:
// diagnose's number and words, its JSON, and circcomp's advice all name the same lagging axis
// (docs/diagnosis.md: servo_mismatch_ms = 1/Kv_A - 1/Kv_B, positive when A lags).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/plan.hpp"
#include "machine_sim.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;
using namespace circtest;

namespace {

struct Case {
  double kv_x, kv_y;
  const char* words;   // diagnose's text
  const char* advice;  // circcomp's
};

class ServoSign : public ::testing::TestWithParam<Case> {};

TEST_P(ServoSign, DiagnoseAndCirccompNameTheAxisWithTheLowerGain) {
  const Case& c = GetParam();
  sim::MachineModel m;
  m.x.kv_per_s = c.kv_x;
  m.y.kv_per_s = c.kv_y;
  sim::CircleProgram p;
  p.radius_mm = 50.0;
  p.feed_mm_per_min = 2000.0;
  const Diagnosis d = diagnose(sim::simulate(m, p));
  ASSERT_TRUE(d.servo_mismatch_ms.value);
  const double expected = (1.0 / c.kv_x - 1.0 / c.kv_y) * 1e3;
  EXPECT_NEAR(*d.servo_mismatch_ms.value, expected, 0.05);
  EXPECT_NE(text_report(d).find(c.words), std::string::npos) << text_report(d);

  const circtest::testing::ScratchDir scratch("circtest-servo-sign");
  const fs::path dir = scratch.dir();
  const std::string ini = (dir / "m.ini").string();
  std::ofstream(ini) << "[TRAJ]\nCOORDINATES = X Y Z\nLINEAR_UNITS = mm\n[KINS]\nKINEMATICS = "
                        "trivkins coordinates=XYZ\nJOINTS = 3\n[JOINT_0]\nTYPE = LINEAR\n"
                        "MIN_LIMIT = -300\nMAX_LIMIT = 300\n[JOINT_1]\nTYPE = LINEAR\nMIN_LIMIT = "
                        "-300\nMAX_LIMIT = "
                        "300\n[JOINT_2]\nTYPE = LINEAR\nMIN_LIMIT = -300\nMAX_LIMIT = 300\n";
  const compensation::DiagnosisInput in =
      compensation::parse_diagnosis(to_json(d).dump(), "diagnosis.json");
  ASSERT_TRUE(in.diagnosis.servo_mismatch_ms.value);
  EXPECT_DOUBLE_EQ(*in.diagnosis.servo_mismatch_ms.value, *d.servo_mismatch_ms.value);
  compensation::PlanOptions o;
  o.only = {};     // the servo advice only: no table or BACKLASH written
  o.force = true;  // no provenance in a simulated trace
  const compensation::Plan plan = compensation::make_plan(ini, in, o);
  std::string advice;
  for (const auto& a : plan.advice) advice += a + "\n";
  EXPECT_NE(advice.find(c.advice), std::string::npos) << advice;
}

INSTANTIATE_TEST_SUITE_P(
    Both, ServoSign,
    ::testing::Values(Case{30.0, 33.0, "X lags Y by 3.0", "X lags Y by 3.03 ms"},
                      Case{33.0, 30.0, "Y lags X by 3.0", "Y lags X by 3.03 ms"}));

}  // namespace
