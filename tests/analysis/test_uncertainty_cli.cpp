// circana analyze's uncertainty and --limits as a user runs them: U beside each result (the
// diagnosis' measured G too), the ISO 14253-1 verdicts and their exit code, and the refusals
// of bad budget inputs.
#include <gtest/gtest.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "circana_cli_fixture.hpp"

namespace {

// circana analyze on one simulated trace (4 um of backlash on X).
class UncertaintyCli : public CircanaCli {
 protected:
  void SetUp() override {
    trace_ = (dir_ / "t.csv").string();
    ASSERT_EQ(simtrace("-o " + trace_ + " --d 100 --f 2000 --backlash-x 0.004 --period 0.004"), 0);
  }
  CommandResult circana(const std::string& args) { return run("analyze " + trace_ + " " + args); }
  // circana analyze ARGS --json expected to succeed, parsed (null when it does not).
  nlohmann::json circana_json(const std::string& args) {
    return run_json("analyze " + trace_ + " " + args + " --json");
  }
  std::string trace_;
};

TEST_F(UncertaintyCli, LimitsAreJudgedWithTheUncertainty) {
  const auto j = circana_json("");
  ASSERT_FALSE(j.is_null());
  const double g = std::max(j["runs"][0]["G"].get<double>(), j["runs"][1]["G"].get<double>());
  const double u = j["runs"][0]["U_G"].get<double>();
  ASSERT_GT(u, 0.0);
  // A limit between G and G + U: not decided, exit 9, the rule printed.
  CommandResult r = circana("--limits G=" + std::to_string(g + u / 2));
  EXPECT_EQ(r.exit_code, 9) << r.err;
  EXPECT_NE(r.out.find("pass when value + U <= limit, fail when value - U > limit"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("not decided: within the uncertainty"), std::string::npos) << r.out;
  // Above G + U: a pass, exit 0.
  r = circana("--limits G=" + std::to_string(g + 1.05 * u) + " --json");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const auto v = nlohmann::json::parse(r.out)["verdicts"];
  EXPECT_EQ(v["items"][0]["decision"], "pass");
  EXPECT_TRUE(v["pass"].get<bool>());
  // Below G - U: a fail.
  r = circana("--limits G=" + std::to_string(g - 1.05 * u));
  EXPECT_EQ(r.exit_code, 9);
  EXPECT_NE(r.out.find(": fail"), std::string::npos) << r.out;
}

TEST_F(UncertaintyCli, StatedInputsEnterTheBudget) {
  const auto j = circana_json("--instrument-profile ballbar --uncertainty repeat-G=0.002");
  ASSERT_FALSE(j.is_null());
  EXPECT_EQ(j["uncertainty"]["profile"], "ballbar");
  // 2 um of repeatability dominates U_G: 2 x 0.002 and a little more.
  EXPECT_NEAR(j["runs"][0]["U_G"].get<double>(), 0.004, 0.0002);
}

// Without temperatures recorded over the test the drift is the stated rate over the run's
// time: a larger rate, a larger U_G (the note names the assumption).
TEST_F(UncertaintyCli, AssumedDriftRateEntersTheBudget) {
  const auto j = circana_json("--uncertainty drift-rate=100,repeat-G=0");
  ASSERT_FALSE(j.is_null());
  const double run_s = j["uncertainty"]["measured"]["run_s"].get<double>();
  bool found = false;
  for (const auto& c : j["uncertainty"]["contributions"]) {
    if (c["name"] != "thermal drift within a run") continue;
    found = true;
    EXPECT_EQ(c["source"], "stated assumption");
    // R a dT: 50 mm x 11.5e-6/K x 100 K/h over the run.
    EXPECT_NEAR(c["value_mm"].get<double>(), 50.0 * 11.5e-6 * 100.0 * run_s / 3600.0, 1e-9);
    EXPECT_NE(c["note"].get<std::string>().find("100 K/h"), std::string::npos) << c["note"];
  }
  EXPECT_TRUE(found);
  EXPECT_NEAR(run_s, 3.14159 * 100.0 / (2000.0 / 60.0), 0.05);
}

// The measured G the diagnosis gives the residual's share against carries the U_G that circana
// analyze states for the same trace: in the diagnosis JSON, its text and analyze's summary.
TEST_F(UncertaintyCli, TheDiagnosisMeasuredGCarriesTheEvaluationsU) {
  const auto analyzed = circana_json("");
  ASSERT_FALSE(analyzed.is_null());
  const double u_g = analyzed["runs"][0]["U_G"].get<double>();
  ASSERT_GT(u_g, 0.0);
  const auto diagnosed = run_json("diagnose " + trace_ + " --json");
  ASSERT_FALSE(diagnosed.is_null());
  EXPECT_EQ(diagnosed["version"], "1.5");
  EXPECT_NEAR(diagnosed["residual"]["measured_G_U_mm"].get<double>(), u_g, 1e-12);
  char shown[64];
  std::snprintf(shown, sizeof shown, ", U = %.2f um (k = 2))", u_g * 1e3);
  const CommandResult text = run("diagnose " + trace_);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("of the measured G "), std::string::npos) << text.out;
  EXPECT_NE(text.out.find(shown), std::string::npos) << shown << "\n" << text.out;
  const CommandResult summary = circana("");
  EXPECT_NE(summary.out.find(shown), std::string::npos) << shown << "\n" << summary.out;
}

// A test set: each plane's measured G with its own plane's U_G.
TEST_F(UncertaintyCli, EachPlaneOfASetCarriesItsOwnU) {
  const std::string set = (dir_ / "set.csv").string();
  ASSERT_EQ(simtrace("-o " + set + " --set XY,ZX --d 100 --backlash-x 0.004 --period 0.004"), 0);
  const auto analyzed = run_json("analyze " + set + " --json");
  const auto diagnosed = run_json("diagnose " + set + " --json");
  ASSERT_FALSE(analyzed.is_null() || diagnosed.is_null());
  ASSERT_EQ(analyzed["planes"].size(), 2u);
  const auto& planes = diagnosed["test_set"]["diagnoses"];
  ASSERT_EQ(planes.size(), 2u) << diagnosed.dump(1);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_NEAR(planes[k]["residual"]["measured_G_U_mm"].get<double>(),
                analyzed["planes"][k]["runs"][0]["U_G"].get<double>(), 1e-12)
        << k;
  }
}

TEST_F(UncertaintyCli, BadInputsAreRefused) {
  for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
           {"--uncertainty foo=1", "--uncertainty: expected KEY=VALUE items"},
           {"--uncertainty calibration=5", "--uncertainty calibration: expected a length in mm"},
           {"--uncertainty drift-rate=500",
            "--uncertainty drift-rate: expected a drift in K per hour from 0 to 100"},
           {"--instrument-profile laser", "--instrument-profile: expected auto, ballbar"},
           {"--limits backlash=0.01", "--limits of circana analyze: H, G and F only"}}) {
    const CommandResult r = circana(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_EQ(r.out, "") << args;
    EXPECT_EQ(r.err.rfind("circana: error: " + message, 0), 0u) << args << "\n" << r.err;
  }
}

}  // namespace
