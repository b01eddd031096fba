// circtest install's reading of a configuration: the channels it finds, the notes and the
// refusals, on configurations written the way pncconf and stepconf write them (the halcmd
// test, install-halcmd.sh, loads the result in LinuxCNC's HAL).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/session/hal_config.hpp"
#include "circtest/session/install.hpp"
#include "circtest/session/linuxcnc.hpp"
#include "scratch.hpp"
#include "session_steps.hpp"

namespace fs = std::filesystem;
using namespace circtest;
using namespace circtest::session;
using circtest::testing::ScratchDir;

namespace {

const fs::path kConfigs = fs::path(CIRCTEST_SOURCE_DIR) / "tests/session/configs";

// A copy of the configuration FOLDER in SCRATCH; its INI's path.
std::string copy_config(const ScratchDir& scratch, const std::string& folder,
                        const std::string& ini) {
  const fs::path to = scratch.dir() / folder;
  fs::copy(kConfigs / folder, to, fs::copy_options::recursive);
  return (to / ini).string();
}

InstallRequest request_for(const std::string& ini) {
  InstallRequest r;
  r.ini_path = ini;
  return r;
}

const InstallChannel* channel(const InstallPlan& plan, const std::string& column) {
  for (const auto& c : plan.channels) {
    if (c.column == column) return &c;
  }
  return nullptr;
}

}  // namespace

TEST(HalWiring, NetArrowsNameTheWriterAndLinesJoinOneSignal) {
  const IniDocument ini = IniDocument::parse("[JOINT_0]\nSCALE = 5\n");
  HalWiring w;
  read_hal_text(
      "net x-fb => pid.x.feedback\nnet x-fb <= hm2_5i25.0.encoder.00.position\n"
      "setp a.b [JOINT_0]SCALE\nnet y-fb stepgen.1.position-fb => joint.1.motor-pos-fb # c\n"
      "loadrt motmod num_dio=[JOINT_0]SCALE\n",
      "m.hal", ini, w);
  EXPECT_EQ(w.source_of("x-fb").value_or(""), "hm2_5i25.0.encoder.00.position");
  EXPECT_EQ(w.source_of("y-fb").value_or(""), "stepgen.1.position-fb");
  EXPECT_EQ(w.signal_of_pin.at("joint.1.motor-pos-fb"), "y-fb");
  ASSERT_EQ(w.load_args.at("motmod").size(), 1u);
  EXPECT_EQ(w.load_args.at("motmod")[0], "num_dio=5");
}

TEST(Install, PncconfServoJoinsItsSignalsAndTakesAFreeMarkerOutput) {
  ScratchDir scratch("session-install");
  const std::string ini = copy_config(scratch, "pncconf-servo", "servo.ini");
  const InstallPlan plan = plan_install(request_for(ini));
  ASSERT_EQ(plan.channels.size(), 7u);
  EXPECT_EQ(channel(plan, "x_cmd")->signal, "x-pos-cmd");
  EXPECT_EQ(channel(plan, "z_fb")->signal, "z-pos-fb");
  EXPECT_NE(channel(plan, "y_fb")->what.find("encoder (encoder.1.position)"), std::string::npos);
  // custom.hal has the coolant relay on motion.digital-out-00.
  EXPECT_EQ(plan.marker_output, 1);
  EXPECT_EQ(plan.segment_output, 0);
  EXPECT_TRUE(plan.notes.empty());
  ASSERT_EQ(plan.plan.files.size(), 2u);
  EXPECT_NE(plan.plan.files[0].after.find("HALFILE = custom.hal\nHALFILE = circtest.hal\n"),
            std::string::npos);
  EXPECT_NE(plan.plan.files[0].after.find(
                "COLUMNS = x_cmd,y_cmd,z_cmd,x_fb,y_fb,z_fb,servo_period\nMARKER_OUTPUT = 1\n"),
            std::string::npos);
  EXPECT_NE(plan.plan.files[1].after.find("net circtest-marker motion.digital-out-01 => "),
            std::string::npos);
}

TEST(Install, TheServoPeriodIsLoggedThroughConvU32Float) {
  ScratchDir scratch("session-install");
  const std::string ini = copy_config(scratch, "pncconf-servo", "servo.ini");
  const InstallPlan plan = plan_install(request_for(ini));
  const InstallChannel* period = channel(plan, "servo_period");
  ASSERT_NE(period, nullptr);
  EXPECT_EQ(period->pin, "circtest-servo-period.out");
  const std::string& hal = plan.plan.files[1].after;
  // Loaded under a name of its own, in the thread before circlog.0 (the same period's value).
  const auto conv = hal.find(
      "loadrt conv_u32_float names=circtest-servo-period\naddf circtest-servo-period "
      "servo-thread\nnet circtest-last-period motion.servo.last-period => "
      "circtest-servo-period.in\n");
  ASSERT_NE(conv, std::string::npos) << hal;
  EXPECT_LT(conv, hal.find("addf circlog.0 servo-thread"));
  EXPECT_NE(
      hal.find("net circtest-servo-period-float circtest-servo-period.out => circlog.0.in-06\n"),
      std::string::npos)
      << hal;

  // A signal of the configuration's on the pin is joined as it is.
  const std::string custom = (fs::path(ini).parent_path() / "custom.hal").string();
  circtest::testing::spit(
      custom, circtest::testing::slurp(custom) + "net servo-time motion.servo.last-period\n");
  const InstallPlan joined = plan_install(request_for(ini));
  EXPECT_NE(joined.plan.files[1].after.find("net servo-time => circtest-servo-period.in\n"),
            std::string::npos);
}

TEST(Install, AConfigurationLoadingConvU32FloatKeepsItsStartAndLogsNoPeriod) {
  ScratchDir scratch("session-install");
  const std::string ini = copy_config(scratch, "pncconf-servo", "servo.ini");
  const std::string custom = (fs::path(ini).parent_path() / "custom.hal").string();
  circtest::testing::spit(custom,
                          "loadrt conv_u32_float count=1\n" + circtest::testing::slurp(custom));
  const InstallPlan plan = plan_install(request_for(ini));
  EXPECT_EQ(channel(plan, "servo_period"), nullptr);
  EXPECT_EQ(plan.channels.size(), 6u);
  EXPECT_EQ(plan.plan.files[1].after.find("conv_u32_float"), std::string::npos);
  ASSERT_EQ(plan.notes.size(), 1u);
  EXPECT_NE(plan.notes[0].find("custom.hal:1 loads conv_u32_float already"), std::string::npos)
      << plan.notes[0];
  // The front end shows it among the notes.
  const auto r = circtest::testing::run_command({CIRCTEST_PATH, "install", "--ini", ini});
  EXPECT_NE(r.out.find("# note: custom.hal:1 loads conv_u32_float already"), std::string::npos)
      << r.out;
}

TEST(Install, StepperSaysFeedbackIsTheStepCount) {
  ScratchDir scratch("session-install");
  const std::string ini = copy_config(scratch, "stepconf-stepper", "stepper.ini");
  const InstallPlan plan = plan_install(request_for(ini));
  ASSERT_EQ(plan.notes.size(), 3u);
  EXPECT_NE(plan.notes[0].find("joint 0: a stepper: its feedback (stepgen.0.position-fb) is the "
                               "step count"),
            std::string::npos);
}

TEST(Install, MissingFeedbackIsRefusedNamingTheSetting) {
  ScratchDir scratch("session-install");
  const std::string ini = copy_config(scratch, "stepconf-stepper", "stepper.ini");
  const std::string hal = (fs::path(ini).parent_path() / "stepper.hal").string();
  std::string text = circtest::testing::slurp(hal);
  text.replace(text.find("net ypos-fb"), 11, "# net ypos-fb");
  circtest::testing::spit(hal, text);
  try {
    plan_install(request_for(ini));
    FAIL() << "expected a refusal";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("joint 1 (Y): joint.1.motor-pos-fb is on no signal in "
                                         "stepper.hal; name the pin that measures it: the "
                                         "feedback pin setting for joint 1"),
              std::string::npos)
        << e.what();
  }
  InstallRequest given = request_for(ini);
  given.feedback_pins[1] = "stepgen.1.position-fb";
  const InstallPlan plan = plan_install(given);
  EXPECT_EQ(channel(plan, "y_fb")->signal, "circtest-y-fb");
  EXPECT_EQ(channel(plan, "y_fb")->pin, "stepgen.1.position-fb");
}

TEST(Install, AConfigurationWithCirclogIsRefused) {
  const std::string ini = CIRCTEST_SOURCE_DIR "/configs/sim-servo/sim-servo.ini";
  try {
    plan_install(request_for(ini));
    FAIL() << "expected a refusal";
  } catch (const DataError& e) {
    EXPECT_EQ(e.file(), "circlog.hal");
    EXPECT_EQ(e.line(), 4u);
  }
}

// --- circtest run's checks of the running machine, before any motion ---

namespace {

MachineState ready_state(const std::string& ini) {
  MachineState s;
  s.task_state = "on";
  s.estop = false;
  s.homed = {true, true, true};
  s.interp_state = "idle";
  s.feed_override = 1.0;
  s.ini_filename = ini;
  return s;
}

std::string refusal(const MachineState& s, const std::string& ini) {
  try {
    require_ready(s, ini);
  } catch (const HalError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(RunChecks, EachStateThatKeepsTheTestFromStartingIsRefusedInOneLine) {
  const std::string ini = "/cfg/machine.ini";
  EXPECT_EQ(refusal(ready_state(ini), ini), "");
  MachineState s = ready_state(ini);
  s.ini_filename = "/cfg/other.ini";
  EXPECT_NE(refusal(s, ini).find("LinuxCNC runs /cfg/other.ini, not /cfg/machine.ini"),
            std::string::npos);
  s = ready_state(ini);
  s.estop = true;
  s.task_state = "estop";
  EXPECT_NE(refusal(s, ini).find("E-stop"), std::string::npos);
  s = ready_state(ini);
  s.task_state = "off";
  EXPECT_NE(refusal(s, ini).find("the machine is off"), std::string::npos);
  s = ready_state(ini);
  s.homed = {true, false, true};
  EXPECT_NE(refusal(s, ini).find("not homed (joint 1)"), std::string::npos);
  s = ready_state(ini);
  s.interp_state = "reading";
  EXPECT_NE(refusal(s, ini).find("a program is running"), std::string::npos);
  s = ready_state(ini);
  s.feed_override = 0.8;
  EXPECT_NE(refusal(s, ini).find("feed override at 80 %"), std::string::npos);
  s.feed_override = 1.2;
  EXPECT_NE(refusal(s, ini).find("feed override at 120 %"), std::string::npos);
}

TEST(Verify, WorseMeansBeyondTheRepeatabilityOfTwoRuns) {
  // G and H in mm: 5 % + 0.5 um of the figure before is what two runs differ by.
  EXPECT_FALSE(got_worse({0.0100, 0.0200}, {0.0100, 0.0205}));  // G +0.5 um: within
  EXPECT_TRUE(got_worse({0.0100, 0.0200}, {0.0100, 0.0216}));   // G +1.6 um: worse
  EXPECT_TRUE(got_worse({0.0100, 0.0200}, {0.0112, 0.0100}));   // H +1.2 um: worse
  EXPECT_FALSE(got_worse({0.0253, 0.0353}, {0.0105, 0.0126}));  // the e2e's corrections
  EXPECT_FALSE(got_worse({-1, -1}, {0.01, 0.01}));              // nothing to compare
}

// The verify's table gives each H and G its U (k = 2) from circana's JSON, and says when a
// document has none.
TEST(Verify, TableCarriesTheUOfEachFigure) {
  ScratchDir scratch("session-verify-u");
  const std::string with_u = scratch.path() + "/with.json";
  const std::string without_u = scratch.path() + "/without.json";
  circtest::testing::spit(with_u,
                          R"({"H": 0.0021, "U_H": 0.0014, "runs": [{"G": 0.0030, "U_G": 0.0011},
                              {"G": 0.0042, "U_G": 0.0013}]})");
  circtest::testing::spit(without_u, R"({"H": 0.0101, "runs": [{"G": 0.0202}]})");
  const Figures before = read_figures(without_u);
  const Figures after = read_figures(with_u);
  EXPECT_FALSE(before.u_g_mm.has_value());
  ASSERT_TRUE(after.u_g_mm.has_value());
  EXPECT_DOUBLE_EQ(*after.u_g_mm, 0.0013);  // the U of the largest G
  const std::string table = verify_table(before, after);
  EXPECT_NE(table.find("H          10.1 um  not known     2.1 um        1.4"), std::string::npos)
      << table;
  EXPECT_NE(table.find("G          20.2 um  not known     4.2 um        1.3"), std::string::npos)
      << table;
}

TEST(InstallCommand, WithoutYesAndWithoutATerminalNothingIsWritten) {
  ScratchDir scratch("session-install");
  const std::string ini = copy_config(scratch, "pncconf-servo", "servo.ini");
  const std::string before = circtest::testing::slurp(ini);
  // run_command gives the program /dev/null as standard input: no terminal to answer on.
  const auto r = circtest::testing::run_command({CIRCTEST_PATH, "install", "--ini", ini});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("+HALFILE = circtest.hal"), std::string::npos) << "the diff is shown";
  EXPECT_NE(r.out.find("circtest: nothing written"), std::string::npos) << r.out;
  EXPECT_EQ(circtest::testing::slurp(ini), before);
  EXPECT_FALSE(fs::exists(fs::path(ini).parent_path() / "circtest.hal"));
  EXPECT_FALSE(fs::exists(fs::path(ini).parent_path() / ".circcomp"));
  // With --yes it is written, and uninstall gives the INI back byte for byte.
  ASSERT_EQ(
      circtest::testing::run_command({CIRCTEST_PATH, "install", "--ini", ini, "--yes"}).exit_code,
      0);
  EXPECT_NE(circtest::testing::slurp(ini), before);
  ASSERT_EQ(circtest::testing::run_command({CIRCTEST_PATH, "uninstall", "--ini", ini}).exit_code,
            0);
  EXPECT_EQ(circtest::testing::slurp(ini), before);
  EXPECT_FALSE(fs::exists(fs::path(ini).parent_path() / "circtest.hal"));
}
