// The README's main command, scripts/demo.sh, on the simulated servo mill (configs/sim-servo
// with a scale error on X and a cyclic error on Y added in its copy): its printout and
// summary.json against the errors injected in the machine's [SIM] section, and its claim that
// `circcomp revert --to as-found` gives the machine back as it was.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "linuxcnc_test.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;
using circtest::testing::run_command;
using circtest::testing::slurp_if_exists;
using nlohmann::json;

namespace {

// The demo's budget: a further apply round starts only when it ends within
// CIRCTEST_DEMO_BUDGET_S after the build (180 s for a user on an idle machine). The suite runs
// it beside two other LinuxCNC and the unit tests, where each run takes longer: its budget
// here is 400 s, so that the friction round this test checks always runs; the margin is a busy
// machine's evaluation time.
constexpr double kSuiteBudgetS = 400.0;
constexpr double kBudgetS = kSuiteBudgetS + 30.0;

class Demo : public circtest::testing::LinuxcncTest {
 protected:
  Demo() : LinuxcncTest("demo", {}) {}
  void SetUp() override {
    if (geteuid() != 0) GTEST_SKIP() << "needs root (the demo runs LinuxCNC in private namespaces)";
    LinuxcncTest::SetUp();
  }
  // [SIM] KEY of the demo's machine (circcomp never writes that section).
  double injected(const std::string& key) const {
    const auto r = run_command({CIRCTEST_INI_PATH, "get", ini(), "SIM", key});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return std::stod(r.out);
  }
  std::string ini() const { return (out_ / "machine" / "sim-servo.ini").string(); }
  // [JOINT_n] KEY of the machine as it arrives (the repository's sim-servo.ini).
  static double injected_joint(int joint, const std::string& key) {
    const auto r = run_command(
        {CIRCTEST_INI_PATH, "get", CIRCTEST_SERVO_INI, "JOINT_" + std::to_string(joint), key});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return std::stod(r.out);
  }
  // The row LABEL of summary.json: its values, one per run, before first.
  static std::vector<double> row(const json& summary, const std::string& label) {
    for (const auto& r : summary["rows"]) {
      if (r["label"] == label) {
        std::vector<double> v;
        for (const auto& x : r["values"]) v.push_back(x.is_null() ? NAN : x.get<double>());
        return v;
      }
    }
    ADD_FAILURE() << "summary.json has no row '" << label << "'";
    return {NAN, NAN};
  }

  // The servo loop the demo's first apply closes: the lags circana measures on the first run
  // from the commanded and motor feedback columns are 1 / P, circcomp writes FF1 into
  // [JOINT_n] FF1, and on the rerun the lag mismatch and the mismatch ellipse's part of G are
  // gone.
  void servo_loop_closed_in_round_1() {
    const json before = json::parse(slurp_if_exists(out_ / "diagnosis.json"));
    const json after = json::parse(slurp_if_exists(out_ / "after-diagnosis.json"));
    const double lx = 1e3 / injected_joint(0, "P"), ly = 1e3 / injected_joint(1, "P");
    ASSERT_EQ(before["axis_lag_source"]["X"], "feedback");
    const double lag_x = num(before["axis_lag_ms"]["X"]), lag_y = num(before["axis_lag_ms"]["Y"]);
    EXPECT_NEAR(lag_x, lx, 0.05 * lx) << "X lags 1 / P";
    EXPECT_NEAR(lag_y, ly, 0.05 * ly) << "Y lags 1 / P";
    const double mismatch_before = num(before["axis_lag_mismatch_ms"]);
    EXPECT_NEAR(mismatch_before, lx - ly, 0.05 * (lx - ly));
    ASSERT_EQ(before["servo_share"].size(), 1u);
    ASSERT_EQ(after["servo_share"].size(), 1u);
    const double share_before = num(before["servo_share"][0]["G_mm"]);
    const double ellipse_before = num(before["servo_mismatch_ms"]);
    const std::string plan = slurp_if_exists(out_ / "plan.diff");
    EXPECT_NE(plan.find("X servo (joint 0, pid.x): FF1 0.0 -> "), std::string::npos) << plan;
    const double mismatch_after = num(after["axis_lag_mismatch_ms"]);
    const double share_after = num(after["servo_share"][0]["G_mm"]);
    const double ellipse_after = num(after["servo_mismatch_ms"]);
    std::printf(
        "servo loop (first apply): lag X %.3f ms (1/P %.3f), Y %.3f ms (%.3f) -> X %.3f ms, Y %.3f "
        "ms; mismatch %.4f -> %.4f ms (feedback), %.4f -> %.4f ms (instrument ellipse); the "
        "ellipse's G %.2f -> %.2f um\n",
        lag_x, lx, lag_y, ly, num(after["axis_lag_ms"]["X"]), num(after["axis_lag_ms"]["Y"]),
        mismatch_before, mismatch_after, ellipse_before, ellipse_after, share_before * 1e3,
        share_after * 1e3);
    // FF1 takes the velocity part off both loops: the mismatch and its ellipse to a tenth.
    EXPECT_LT(std::abs(mismatch_after), 0.1 * std::abs(mismatch_before));
    EXPECT_LT(share_after, 0.1 * share_before);
    EXPECT_LT(std::abs(ellipse_after), 0.2 * std::abs(ellipse_before));
    EXPECT_LT(std::abs(num(after["axis_lag_ms"]["X"])), 0.1 * lx);
  }
  static double num(const json& v) { return v.is_null() ? NAN : v.get<double>(); }
};

}  // namespace

TEST_F(Demo, ClosesTheLoopOnTheServoMachineAndPrintsTheServoPerAxis) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto demo = run_command({"/bin/bash", CIRCTEST_DEMO_PATH, "--no-setup", out_.string()},
                                {std::string("CIRCTEST_BUILD_DIR=") + CIRCTEST_BINARY_DIR,
                                 "CIRCTEST_DEMO_BUDGET_S=" + std::to_string(int(kSuiteBudgetS))});
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(demo.exit_code, 0) << demo.out << demo.err;
  std::printf("demo: %.0f s\n%s", seconds, demo.out.substr(demo.out.find("before  ")).c_str());
  EXPECT_LT(seconds, kBudgetS);
  EXPECT_NE(demo.out.find("where the time went"), std::string::npos) << demo.out;
  // The servo lines per axis and the mismatch, from the diagnosis JSON.
  for (const char* line : {"servo: mean lag (ms)", "servo: mismatch (ms)", "servo: Kv (1/s)"}) {
    EXPECT_NE(demo.out.find(line), std::string::npos) << line << "\n" << demo.out;
  }
  for (const char* axis : {"X", "Y"}) {
    EXPECT_NE(demo.out.find(std::string("servo: lag ") + axis), std::string::npos) << demo.out;
  }

  const json summary = json::parse(slurp_if_exists(out_ / "summary.json"));
  ASSERT_GE(summary["runs"].size(), 2u);
  EXPECT_EQ(summary["runs"][0], "before");
  // The diagnosis of the first run saw what the machine's [SIM] injects ...
  const double backlash_um = injected("BACKLASH_X") * 1e3;
  const double scale_ppm = injected("SCALE_X") * 1e6;
  const double squareness_urad = injected("SQUARENESS_XY") * 1e6;
  ASSERT_GT(backlash_um, 1.0);
  ASSERT_GT(scale_ppm, 10.0);
  ASSERT_GT(squareness_urad, 10.0);
  EXPECT_NEAR(row(summary, "backlash X").front(), backlash_um, 1.0);
  EXPECT_NEAR(row(summary, "scale X").front(), scale_ppm, 5.0);
  EXPECT_NEAR(row(summary, "squareness").front(), squareness_urad, 5.0);
  const std::vector<double> mismatch = row(summary, "servo: mismatch");
  EXPECT_GT(mismatch.front(), 0.5) << "P 30/31 with FF1 = 0: X lags Y by about 1 ms";
  servo_loop_closed_in_round_1();
  // ... and the last run is within the limits.
  EXPECT_LT(std::fabs(row(summary, "backlash X").back()), 1.5);
  EXPECT_LT(std::fabs(row(summary, "backlash Y").back()), 1.5);
  EXPECT_LT(std::fabs(row(summary, "squareness").back()), 10.0);
  // The first apply closes geometry and servo (FF1); the second, planned from the rerun's
  // diagnosis, adds circfric's rising pulse for the spikes feed-forward leaves. The last run's
  // H and G are at most 30 % of the first's, and each spike of at least 2 um on the second
  // run is at least halved on the last.
  ASSERT_GE(summary["runs"].size(), 3u) << "the friction round did not run\n" << demo.out;
  EXPECT_LE(row(summary, "H").back(), 0.3 * row(summary, "H").front());
  EXPECT_LE(row(summary, "G worst").back(), 0.3 * row(summary, "G worst").front());
  for (const char* axis : {"X", "Y"}) {
    const std::vector<double> spike = row(summary, std::string("reversal spike ") + axis);
    ASSERT_GE(spike.size(), 3u);
    if (spike[1] >= 2.0) {
      EXPECT_LE(spike.back(), 0.5 * spike[1]) << axis;
    }
  }
  EXPECT_NE(demo.out.find("a rising pulse"), std::string::npos) << demo.out;
  const std::vector<double> geometric = row(summary, "  without servo and friction");
  EXPECT_LT(geometric.back(), 0.3 * geometric.front()) << "the geometric part of G is closed";
#ifdef CIRCTEST_HTML_REPORT_TEST
  // The report it hands over fits A4 portrait with the verdict on page 1: the report tests'
  // headless Chromium check, on this report.
  const auto a4 = run_command({CIRCTEST_HTML_REPORT_TEST, "--gtest_filter=*AGivenReportFitsA4*"},
                              {"CIRCTEST_REPORT_HTML=" + (out_ / "report.html").string()});
  EXPECT_EQ(a4.exit_code, 0) << a4.out << a4.err;
  EXPECT_NE(a4.out.find("[       OK ]"), std::string::npos) << a4.out;
#endif

  // `revert --to as-found` gives back the machine the demo measured first: the repository's
  // configuration with the demo's [SIM] additions, every other byte as it was.
  const auto revert = run_command({CIRCCOMP_PATH, "revert", "--ini", ini(), "--to", "as-found"});
  ASSERT_EQ(revert.exit_code, 0) << revert.out << revert.err;
  const fs::path repo = fs::path(CIRCTEST_SERVO_INI).parent_path();
  for (const char* key : {"SCALE_X", "CYCLIC_Y", "CYCLIC_PITCH_Y"}) {
    const auto value = run_command({CIRCTEST_INI_PATH, "get", CIRCTEST_SERVO_INI, "SIM", key});
    ASSERT_EQ(value.exit_code, 0);
    std::string v = value.out;
    while (!v.empty() && (v.back() == '\n' || v.back() == ' ')) v.pop_back();
    ASSERT_EQ(run_command({CIRCTEST_INI_PATH, "set", ini(), "SIM", key, v}).exit_code, 0);
  }
  EXPECT_EQ(slurp_if_exists(ini()), slurp_if_exists(CIRCTEST_SERVO_INI));
  for (const char* hal : {"sim-servo.hal", "geometry.hal", "circlog.hal"}) {
    EXPECT_EQ(slurp_if_exists(out_ / "machine" / hal), slurp_if_exists(repo / hal)) << hal;
  }
  for (const char* made : {"circtest-joint0.comp", "circtest-comp.hal", "circtest-fric.hal"}) {
    EXPECT_FALSE(fs::exists(out_ / "machine" / made)) << made;
  }
}
