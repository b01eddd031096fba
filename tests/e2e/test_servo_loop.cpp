// The servo step on the stepper variant (configs/sim-stepper, copied): run the circle in the
// real LinuxCNC, circana diagnose measures each axis' lag from the commanded and motor
// feedback columns, and circcomp says the lag is no gain to tune and gives the stepgen checks,
// no FF1. The servo loop closed on the pid sim mill (lags 1 / P, FF1 written, the mismatch
// and its ellipse gone on the rerun) is checked on the demo's runs (test_demo.cpp), which
// close it as the first of their rounds.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "scratch.hpp"

namespace fs = std::filesystem;
using circtest::testing::slurp_if_exists;
using nlohmann::json;

namespace {

constexpr double kPx = 30.0, kPy = 31.0;  // sim-servo.ini's [JOINT_0] P, [JOINT_1] P

int run(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class ServoLoop : public ::testing::Test {
 protected:
  void SetUp() override {
    if (geteuid() != 0 && !fs::exists("/usr/lib/linuxcnc/modules/circdrive.so")) {
      GTEST_SKIP() << "needs root (private namespaces) or circlog and circdrive installed";
    }
    scratch_ = std::make_unique<circtest::testing::ScratchDir>(
        std::string("circtest-e2e-servo-loop-") +
        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    out_ = scratch_->dir();
    // rtapi_app runs as nobody and binds its socket below this folder: mkdtemp's 0700 refuses it.
    fs::permissions(out_, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                              fs::perms::others_read | fs::perms::others_exec);
  }
  void TearDown() override {
    if (HasFailure() && scratch_) scratch_->keep();
  }
  // The configuration of INI's folder copied into the scratch folder, and circgen's D150 F1000.
  void copy_machine(const char* ini) {
    fs::copy(fs::path(ini).parent_path(), out_ / "machine");
    ini_ = (out_ / "machine" / fs::path(ini).filename()).string();
    ASSERT_EQ(run(std::string(CIRCGEN_PATH) + " --d 150 --f 1000 --ini " + ini_ + " -o " +
                  (out_ / "test.ngc").string()),
              0);
  }
  // Runs the program on the configuration as it is now; returns circana diagnose's JSON (kept
  // as NAME.json).
  json measure(const std::string& name) {
    const fs::path dir = out_ / name;
    const std::string cmd = std::string("CIRCTEST_BIN=") + CIRCTEST_BINARY_DIR + " " +
                            CIRCTEST_RUN_PATH + " --ini " + ini_ + " --program " +
                            (out_ / "test.ngc").string() + " --out " + dir.string() +
                            " --timeout 300 >" + (out_ / (name + ".log")).string() + " 2>&1";
    EXPECT_EQ(run(cmd), 0) << slurp_if_exists(out_ / (name + ".log"))
                           << slurp_if_exists(dir / "linuxcnc.log");
    const fs::path js = out_ / (name + ".json");
    EXPECT_EQ(run(std::string(CIRCANA_PATH) + " diagnose " + (dir / "trace.csv").string() +
                  " --json >" + js.string()),
              0);
    return json::parse(slurp_if_exists(js));
  }
  // circcomp COMMAND (plan, apply) of NAME.json with ARGS; its output in NAME-COMMAND.out.
  int circcomp(const std::string& command, const std::string& name, const std::string& args,
               std::string& out) {
    const fs::path o = out_ / (name + "-" + command + ".out");
    const int code =
        run(std::string(CIRCCOMP_PATH) + " " + command + " --ini " + ini_ + " " +
            (out_ / (name + ".json")).string() + " " + args + " >" + o.string() + " 2>&1");
    out = slurp_if_exists(o);
    return code;
  }
  static double num(const json& v) { return v.is_null() ? NAN : v.get<double>(); }

  std::unique_ptr<circtest::testing::ScratchDir> scratch_;
  fs::path out_;
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
