// The servo step on the stepper variant (configs/sim-stepper, copied): run the circle in the
// real LinuxCNC, circana diagnose measures each axis' lag from the commanded and motor
// feedback columns, and circcomp says the lag is no gain to tune and gives the stepgen checks,
// no FF1. The servo loop closed on the pid sim mill (lags 1 / P, FF1 written, the mismatch
// and its ellipse gone on the rerun) is checked on the demo's runs (test_demo.cpp), which
// close it as the first of their rounds.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "linuxcnc_test.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;
using circtest::testing::slurp_if_exists;
using nlohmann::json;

namespace {

using circtest::testing::run_shell;

class ServoLoop : public circtest::testing::LinuxcncTest {
 protected:
  ServoLoop() : LinuxcncTest("servo-loop", {"circlog.so", "circdrive.so"}) {}
  // The configuration of INI's folder copied into the scratch folder, and circgen's D150 F1000.
  void copy_machine(const char* ini) {
    fs::copy(fs::path(ini).parent_path(), out_ / "machine");
    ini_ = (out_ / "machine" / fs::path(ini).filename()).string();
    ASSERT_EQ(run_shell(std::string(CIRCGEN_PATH) + " --d 150 --f 1000 --ini " + ini_ + " -o " +
                        (out_ / "test.ngc").string()),
              0);
  }
  // Runs the program on the configuration as it is now; returns circana diagnose's JSON (kept
  // as NAME.json).
  json measure(const std::string& name) {
    const fs::path dir = out_ / name;
    const auto r = circtest::testing::run_linuxcnc(CIRCTEST_RUN_PATH, CIRCTEST_BINARY_DIR,
                                                   {ini_, out_ / "test.ngc", dir});
    EXPECT_EQ(r.command.exit_code, 0) << r.log;
    return circtest::testing::circana_json(CIRCANA_PATH, "diagnose", dir / "trace.csv",
                                           out_ / (name + ".json"));
  }
  // circcomp COMMAND (plan, apply) of NAME.json with ARGS; its output in NAME-COMMAND.out.
  int circcomp(const std::string& command, const std::string& name, const std::string& args,
               std::string& out) {
    const fs::path o = out_ / (name + "-" + command + ".out");
    const int code =
        run_shell(std::string(CIRCCOMP_PATH) + " " + command + " --ini " + ini_ + " " +
                  (out_ / (name + ".json")).string() + " " + args + " >" + o.string() + " 2>&1");
    out = slurp_if_exists(o);
    return code;
  }
  static double num(const json& v) { return v.is_null() ? NAN : v.get<double>(); }

  std::string ini_;
};

}  // namespace

TEST_F(ServoLoop, StepperGetsTheStepgenChecksAndNoFf1) {
  copy_machine(CIRCTEST_STEPPER_INI);
  const json d = measure("before");
  ASSERT_EQ(d["axis_lag_source"]["X"], "feedback");
  EXPECT_LT(std::abs(num(d["axis_lag_ms"]["X"])), 3.0) << "stepgen follows within periods";
  std::string out;
  // All corrections: the backlash the diagnosis finds becomes [JOINT_0] BACKLASH, which
  // STEPGEN_MAXACCEL's 25 % headroom does not cover.
  ASSERT_EQ(circcomp("plan", "before", "", out), 0) << out;
  EXPECT_NE(out.find("X (joint 0) is a stepper (stepgen.0 in position mode, no pid): its lag is "
                     "the stepgen's timing, not a gain to tune"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("X stepgen: [JOINT_0] STEPGEN_MAXACCEL 625.0 is 1.25x [JOINT_0] "
                     "MAX_ACCELERATION 500.0: with backlash compensation the stepgen needs 2.0x"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("no FF1 or P proposed"), std::string::npos) << out;
  EXPECT_EQ(out.find("servo (joint"), std::string::npos) << "no FF1 change:\n" << out;
  EXPECT_EQ(out.find("FF1 ="), std::string::npos) << "no FF1 key written:\n" << out;
  // Servo alone (no backlash compensation planned): the stepper note, nothing to write.
  ASSERT_EQ(circcomp("plan", "before", "--only servo", out), 0) << out;
  EXPECT_NE(out.find("stepgen limits checked, fine"), std::string::npos) << out;
  EXPECT_EQ(out.find("# advice:"), std::string::npos) << out;
  EXPECT_EQ(out.find("+++"), std::string::npos) << "nothing written:\n" << out;
}
