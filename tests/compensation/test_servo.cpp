// circcomp's servo step (compensation/src/plan/servo.cpp) on pncconf-style configurations
// (tests/compensation/data): FF1 written into the [JOINT_n] keys the HAL reads, the variants
// pncconf and the stock configurations use (pid.x / pid.0, an FF1 setp missing, literal
// gains), P where FF1 alone cannot match, the bounds, the refusals naming file and line, the
// stepgen checks of a stepper, and apply + revert leaving the configuration byte-identical.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/compensation/plan_json.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "expect_error.hpp"
#include "plan_test_support.hpp"

namespace fs = std::filesystem;
using namespace circtest;
using namespace circtest::compensation;
using circtest::testing::all;
using circtest::testing::file_of;
using circtest::testing::has_text;

namespace {

// A copy of one fixture configuration (tests/compensation/data) in a scratch folder.
struct Config : circtest::testing::ConfigCopy {
  std::string name;
  explicit Config(const std::string& fixture)
      : ConfigCopy(DATA_DIR, fixture, "servo"), name(fixture) {}
  // Replaces every FROM in FILE by TO (at least one).
  void edit(const std::string& file, const std::string& from, const std::string& to) const {
    std::string text = read(file);
    std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    for (; at != std::string::npos; at = text.find(from, at + to.size())) {
      text.replace(at, from.size(), to);
    }
    write(file, text);
  }
};

// A diagnosis with the lags of X and Y (ms, standard error 0.01 ms), measured from the motor
// feedback, and the mismatch the instrument saw.
DiagnosisInput lags(std::optional<double> x_ms, std::optional<double> y_ms) {
  DiagnosisInput d;
  d.source = "d.json";
  d.diagnosis.plane = Plane::XY;
  d.diagnosis.axes = {'X', 'Y'};
  d.diagnosis.axis_lag[0].lag_ms = {x_ms, 0.01};
  d.diagnosis.axis_lag[1].lag_ms = {y_ms, 0.01};
  d.diagnosis.axis_lag[0].source = x_ms ? "feedback" : "";
  d.diagnosis.axis_lag[1].source = y_ms ? "feedback" : "";
  if (x_ms && y_ms) d.diagnosis.servo_mismatch_ms = {*x_ms - *y_ms, 0.01};
  return d;
}

PlanOptions servo_only() {
  PlanOptions o;
  o.only = {Correction::servo};
  o.servo_requested = true;
  return o;
}

double number(const IniDocument& ini, const char* section, const char* key) {
  const auto v = ini.get(section, key);
  return v ? std::stod(*v) : std::nan("");
}

// The 1-based number of the line of TEXT that holds WORDS.
std::size_t line_of(const std::string& text, const std::string& words) {
  const std::size_t at = text.find(words);
  return at == std::string::npos ? 0 : 1 + std::count(text.begin(), text.begin() + at, '\n');
}

// X lags 34 ms at P 30, Y 32.5 ms at P 31, FF1 0: the drive constants lag * P + FF1 are 1.02
// and 1.0075; the target is the smallest lag both reach with FF1 <= 1: (1.02 - 1) / 30.
constexpr double kLagX = 34.0, kLagY = 32.5;
const double kTarget = (kLagX * 1e-3 * 30 - 1.0) / 30;
const double kFf1Y = kLagY * 1e-3 * 31 - 31 * kTarget;

TEST(Servo, PncconfFf1GoesIntoTheJointKeys) {
  Config c("pncconf-servo");
  const Plan plan = make_plan(c.ini, lags(kLagX, kLagY), PlanOptions{});
  ASSERT_EQ(plan.files.size(), 1u) << all(plan.notes);
  const FileChange* ini = file_of(plan, "pncconf-servo.ini");
  ASSERT_NE(ini, nullptr);
  const IniDocument after = IniDocument::parse(ini->after);
  EXPECT_NEAR(number(after, "JOINT_0", "FF1"), 1.0, 1e-6);
  EXPECT_NEAR(number(after, "JOINT_1", "FF1"), kFf1Y, 1e-6);
  EXPECT_EQ(after.get("JOINT_0", "P"), "30.0");  // P kept where FF1 matches
  EXPECT_EQ(after.get("JOINT_1", "P"), "31.0");
  EXPECT_EQ(after.get("JOINT_2", "FF1"), "0.0");  // Z is not in the plane
  EXPECT_TRUE(has_text(plan.changes,
                       "X servo (joint 0, pid.x): FF1 0.0 -> 1.0 at [JOINT_0] FF1, "
                       "P 30.0 kept; lag 34.00 -> 0.67 ms"))
      << all(plan.changes);
  EXPECT_TRUE(has_text(plan.changes, "Y servo (joint 1, pid.y)")) << all(plan.changes);
  EXPECT_FALSE(has_text(plan.advice, "servo mismatch"));  // proposed, not advised
  // Only the two FF1 lines change.
  const std::string diff = unified_diff(plan);
  EXPECT_NE(diff.find("-FF1 = 0.0\n+FF1 = 1.0\n"), std::string::npos) << diff;
  std::size_t removed = 0;
  for (std::size_t at = diff.find("\n-"); at != std::string::npos; at = diff.find("\n-", at + 1)) {
    removed += diff.compare(at, 5, "\n--- ") != 0;
  }
  EXPECT_EQ(removed, 2u) << diff;
}

TEST(Servo, NumberedPidWithoutFf1SetpGetsOneAfterPgain) {
  Config c("pncconf-servo");
  // The hm2-servo sample's style: pid.0, pid.1, pid.2 from num_chan, no FF1 in HAL or INI.
  c.edit("pncconf-servo.hal", "loadrt pid names=pid.x,pid.y,pid.z", "loadrt pid num_chan=3");
  for (const auto& [from, to] :
       {std::pair{"pid.x.", "pid.0."}, {"pid.y.", "pid.1."}, {"pid.z.", "pid.2."}}) {
    c.edit("pncconf-servo.hal", from, to);
  }
  for (const char* j : {"0", "1", "2"}) {
    c.edit("pncconf-servo.hal",
           std::string("setp   pid.") + j + ".FF1       [JOINT_" + j + "]FF1\n", "");
  }
  c.edit("pncconf-servo.ini", "FF1 = 0.0\n", "");
  const Plan plan = make_plan(c.ini, lags(kLagX, kLagY), servo_only());
  const FileChange* hal = file_of(plan, "pncconf-servo.hal");
  ASSERT_NE(hal, nullptr) << all(plan.notes);
  EXPECT_NE(hal->after.find("setp   pid.0.Pgain     [JOINT_0]P\nsetp pid.0.FF1 [JOINT_0]FF1\n"),
            std::string::npos)
      << hal->after;
  EXPECT_NE(hal->after.find("setp   pid.1.Pgain     [JOINT_1]P\nsetp pid.1.FF1 [JOINT_1]FF1\n"),
            std::string::npos);
  EXPECT_EQ(hal->after.find("pid.2.FF1"), std::string::npos);
  const IniDocument after = IniDocument::parse(file_of(plan, "pncconf-servo.ini")->after);
  EXPECT_NEAR(number(after, "JOINT_0", "FF1"), 1.0, 1e-6);
  EXPECT_NEAR(number(after, "JOINT_1", "FF1"), kFf1Y, 1e-6);
  // Lines added, none removed.
  const std::string diff = unified_diff(plan);
  for (std::size_t at = diff.find("\n-"); at != std::string::npos; at = diff.find("\n-", at + 1)) {
    EXPECT_EQ(diff.compare(at, 5, "\n--- "), 0) << diff;
  }
}

TEST(Servo, LiteralGainIsEditedInPlaceAndRevertedByteIdentical) {
  Config c("pncconf-servo");
  c.edit("pncconf-servo.hal", "setp   pid.y.FF1       [JOINT_1]FF1",
         "setp   pid.y.FF1       0.0   # tuned by hand");
  const auto before = c.files();
  const Plan plan = make_plan(c.ini, lags(kLagX, kLagY), servo_only());
  const FileChange* hal = file_of(plan, "pncconf-servo.hal");
  ASSERT_NE(hal, nullptr) << all(plan.notes);
  std::string expected = before.at("pncconf-servo.hal");
  const std::string line = "setp   pid.y.FF1       0.0   # tuned by hand";
  const std::string head = "setp   pid.y.FF1       ";
  const std::size_t at = hal->after.find(head) + head.size();
  const std::string value = hal->after.substr(at, hal->after.find(' ', at) - at);
  EXPECT_NEAR(std::stod(value), kFf1Y, 1e-6);
  expected.replace(expected.find(line), line.size(),
                   "setp   pid.y.FF1       " + value + "   # tuned by hand");
  EXPECT_EQ(hal->after, expected);  // the value only; spacing and comment kept
  EXPECT_TRUE(has_text(
      plan.changes,
      "pncconf-servo.hal:" + std::to_string(line_of(expected, "pid.y.FF1")) + " (setp pid.y.FF1)"))
      << all(plan.changes);
  apply_plan(plan);
  EXPECT_NE(c.read("pncconf-servo.hal"), before.at("pncconf-servo.hal"));
  ASSERT_TRUE(revert(c.ini));
  auto now = c.files();
  EXPECT_EQ(now, before);
}

TEST(Servo, HalKeyMissingInTheIniIsRefusedNamingTheHalLine) {
  Config c("pncconf-servo");
  std::string ini = c.read("pncconf-servo.ini");
  const std::size_t j1 = ini.find("[JOINT_1]");
  ini.erase(ini.find("FF1 = 0.0\n", j1), 10);
  c.write("pncconf-servo.ini", ini);
  const std::string hal = c.read("pncconf-servo.hal");
  const std::size_t line = line_of(hal, "setp   pid.y.FF1");
  EXPECT_ERROR(make_plan(c.ini, lags(kLagX, kLagY), servo_only()), ExitCode::data,
               c.path("pncconf-servo.hal") + ":" + std::to_string(line) +
                   ": setp pid.y.FF1 [JOINT_1]FF1: the INI has no [JOINT_1] FF1");
  // Not asked for by name: a note, and the other corrections go on.
  const Plan plan = make_plan(c.ini, lags(kLagX, kLagY), PlanOptions{});
  EXPECT_TRUE(has_text(plan.notes, "servo gains not planned:")) << all(plan.notes);
  EXPECT_TRUE(plan.files.empty());
}

// What decides between a refusal and a note is the kind of error, not the file it names: a
// diagnosis whose source names the configuration's own HAL file (or INI) still has a
// configuration the servo step cannot take skipped with a note, and an implausible lag is
// refused whatever the diagnosis names.
TEST(Servo, ConfigurationErrorIsANoteWhateverTheDiagnosisNames) {
  Config c("pncconf-servo");
  std::string ini = c.read("pncconf-servo.ini");
  const std::size_t j1 = ini.find("[JOINT_1]");
  ini.erase(ini.find("FF1 = 0.0\n", j1), 10);
  c.write("pncconf-servo.ini", ini);
  for (const std::string& source : {c.path("pncconf-servo.hal"), c.ini}) {
    DiagnosisInput d = lags(kLagX, kLagY);
    d.source = source;
    const Plan plan = make_plan(c.ini, d, PlanOptions{});
    EXPECT_TRUE(has_text(plan.notes, "servo gains not planned:")) << source << all(plan.notes);
    EXPECT_TRUE(has_text(plan.notes, "the INI has no [JOINT_1] FF1")) << all(plan.notes);
    EXPECT_TRUE(plan.files.empty());
    EXPECT_ERROR(make_plan(c.ini, d, servo_only()), ExitCode::data,
                 "setp pid.y.FF1 [JOINT_1]FF1: the INI has no [JOINT_1] FF1");
  }
  for (const std::string& source : {std::string(), c.path("pncconf-servo.hal")}) {
    DiagnosisInput d = lags(2e4, kLagY);
    d.source = source;
    EXPECT_ERROR(make_plan(c.ini, d, PlanOptions{}), ExitCode::data,
                 "X servo lag = 20000 ms is implausible (more than 10000 ms)");
  }
}

TEST(Servo, GainNeitherNumberNorKeyIsRefused) {
  Config c("pncconf-servo");
  c.edit("pncconf-servo.hal", "setp   pid.x.FF1       [JOINT_0]FF1",
         "setp   pid.x.FF1       [JOINT_0]FF1*2");
  const std::size_t line = line_of(c.read("pncconf-servo.hal"), "pid.x.FF1 ");
  EXPECT_ERROR(make_plan(c.ini, lags(kLagX, kLagY), servo_only()), ExitCode::data,
               "pncconf-servo.hal:" + std::to_string(line) +
                   ": setp pid.x.FF1 [JOINT_0]FF1*2: neither a number nor one [SECTION]KEY");
}

TEST(Servo, GainOnASignalIsRefused) {
  Config c("pncconf-servo");
  c.edit("pncconf-servo.hal", "setp   pid.x.FF1       [JOINT_0]FF1",
         "net x-ff1 pid.x.FF1 <= ff1-knob.out");
  const std::size_t line = line_of(c.read("pncconf-servo.hal"), "net x-ff1");
  EXPECT_ERROR(make_plan(c.ini, lags(kLagX, kLagY), servo_only()), ExitCode::data,
               "pncconf-servo.hal:" + std::to_string(line) + ": pid.x.FF1 is on signal x-ff1");
}

TEST(Servo, PIsRaisedWhereFf1AloneCannotMatch) {
  Config c("pncconf-servo");
  // X's drive gives half the speed asked for: lag * P + FF1 = 2.1. FF1 <= 1 leaves it 36.7 ms,
  // more than Y lags with FF1 = 0 (32.26 ms): X's P goes up, Y keeps FF1 0.
  const double lag_y = 1e3 / 31;
  const Plan plan = make_plan(c.ini, lags(70.0, lag_y), servo_only());
  const IniDocument after = IniDocument::parse(file_of(plan, "pncconf-servo.ini")->after);
  const double target = lag_y * 1e-3;
  EXPECT_NEAR(number(after, "JOINT_0", "P"), 1.1 / target, 1e-4);
  EXPECT_NEAR(number(after, "JOINT_0", "FF1"), 1.0, 1e-6);
  EXPECT_EQ(after.get("JOINT_1", "P"), "31.0");
  EXPECT_EQ(after.get("JOINT_1", "FF1"), "0.0");  // unchanged (the line stays)
  EXPECT_TRUE(has_text(plan.changes, ", P 30.0 -> 34.1")) << all(plan.changes);
}

TEST(Servo, BoundsRefuseTheProposalAsAdvice) {
  Config c("pncconf-servo");
  // X would need P 62 (2.07x): outside 0.5x..2x. Nothing written, advice says why.
  const Plan plan = make_plan(c.ini, lags(100.0, 1e3 / 31), servo_only());
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(has_text(plan.advice, "cannot match the lags (joint 0 would need P 62."))
      << all(plan.advice);
  EXPECT_TRUE(has_text(plan.advice, "outside 0.5x..2x")) << all(plan.advice);
  // A servo period of 20 ms: the raised gain is beyond the sampled loop's margin.
  c.edit("pncconf-servo.ini", "SERVO_PERIOD = 1000000", "SERVO_PERIOD = 20000000");
  const Plan slow = make_plan(c.ini, lags(70.0, 1e3 / 31), servo_only());
  EXPECT_TRUE(slow.files.empty());
  EXPECT_TRUE(has_text(slow.advice, "more than 0.25 / the servo period (0.02 s) allows"))
      << all(slow.advice);
}

TEST(Servo, FerrorBelowTheNewFollowingErrorIsRefused) {
  Config c("pncconf-servo");
  // The new lag (32.26 ms after raising X's P) at 166.67 mm/s is 5.4 mm: above FERROR 5.
  std::string ini = c.read("pncconf-servo.ini");
  ini.replace(ini.find("FERROR = 10.0"), 13, "FERROR = 5.0");
  c.write("pncconf-servo.ini", ini);
  const std::size_t line = line_of(ini, "FERROR = 5.0");
  EXPECT_ERROR(make_plan(c.ini, lags(70.0, 1e3 / 31), servo_only()), ExitCode::data,
               "pncconf-servo.ini:" + std::to_string(line) +
                   ": [JOINT_0] FERROR 5.0 (MIN_FERROR 0.5): the proposed lag of 32.26 ms");
}

TEST(Servo, ImplausibleLagIsRefusedAndNothingNonFiniteIsWritten) {
  Config c("pncconf-servo");
  EXPECT_ERROR(make_plan(c.ini, lags(1e300, 32.5), PlanOptions{}), ExitCode::data,
               "d.json: X servo lag = ");
  EXPECT_ERROR(make_plan(c.ini, lags(33.0, 2e4), PlanOptions{}), ExitCode::data,
               "Y servo lag = 20000 ms is implausible (more than 10000 ms)");
  // A lag within the bound but a P of 1e-300: whatever comes out is finite or advice.
  c.edit("pncconf-servo.ini", "P = 30.0", "P = 1e-300");
  const Plan plan = make_plan(c.ini, lags(9000.0, 32.5), servo_only());
  for (const auto& f : plan.files) {
    EXPECT_EQ(f.after.find("nan"), std::string::npos) << f.after;
    EXPECT_EQ(f.after.find("inf"), std::string::npos) << f.after;
  }
}

TEST(Servo, NoPerAxisLagKeepsTheMismatchAdvice) {
  Config c("pncconf-servo");
  DiagnosisInput d = lags(std::nullopt, std::nullopt);
  d.diagnosis.servo_mismatch_ms = {1.0, 0.01};
  const Plan plan = make_plan(c.ini, d, PlanOptions{});
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(has_text(plan.notes, "the diagnosis has no lag of axis X")) << all(plan.notes);
  EXPECT_TRUE(has_text(plan.advice, "servo mismatch: X lags Y by 1.00 ms")) << all(plan.advice);
}

TEST(Servo, StockStepperGetsTheStepperNoteAndNoAlarm) {
  Config c("pncconf-stepper");
  // A stepper lags by about a servo period against its feedback: no gain to tune.
  const Plan plan = make_plan(c.ini, lags(1.0, 1.0), PlanOptions{});
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(plan.advice.empty()) << all(plan.advice);
  EXPECT_TRUE(has_text(plan.notes,
                       "X (joint 0) is a stepper (stepgen.0 in position mode, no pid): its lag "
                       "is the stepgen's timing, not a gain to tune; stepgen limits checked, fine"))
      << all(plan.notes);
  EXPECT_FALSE(has_text(plan.changes, "FF1"));
}

TEST(Servo, StepperWithBacklashNeedsStepgenHeadroom) {
  Config c("pncconf-stepper");
  std::string ini = c.read("pncconf-stepper.ini");
  ini.replace(ini.find("BACKLASH = 0.000"), 16, "BACKLASH = 0.020");
  c.write("pncconf-stepper.ini", ini);
  const Plan plan = make_plan(c.ini, lags(1.0, 1.0), servo_only());
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(has_text(plan.advice,
                       "X stepgen: [JOINT_0] STEPGEN_MAXACCEL 520.0 is 1.04x [JOINT_0] "
                       "MAX_ACCELERATION 500.0: with backlash compensation the stepgen needs 2.0x"))
      << all(plan.advice);
  EXPECT_FALSE(has_text(plan.advice, "Y stepgen"));  // Y has no backlash compensation
  EXPECT_TRUE(has_text(plan.advice, "X (joint 0) is a stepper")) << all(plan.advice);
}

TEST(Servo, StockHalFromTheLibraryIsNotRead) {
  Config c("pncconf-stepper");
  // The stock configurations load core_stepper.hal from LinuxCNC's HAL library.
  c.edit("pncconf-stepper.ini", "HALFILE = pncconf-stepper.hal", "HALFILE = core_stepper.hal");
  const Plan plan = make_plan(c.ini, lags(1.0, 1.0), PlanOptions{});
  EXPECT_TRUE(plan.advice.empty()) << all(plan.advice);
  EXPECT_TRUE(has_text(plan.notes,
                       "servo: no pid or stepgen in the HAL files read (; not read: "
                       "core_stepper.hal) closes the loop of joint 0, joint 1"))
      << all(plan.notes);
}

TEST(Servo, CirccompPlanRefusalExitsWithFive) {
  Config c("pncconf-servo");
  c.edit("pncconf-servo.hal", "setp   pid.x.FF1       [JOINT_0]FF1",
         "setp   pid.x.FF1       [JOINT_0]FF1*2");
  const std::string json = c.path("d.json");
  c.write("d.json",
          R"({"schema": "circtest.diagnosis/1", "version": "1.1", "units": "mm", "plane": "XY",
              "axis_lag_ms": {"X": 34.0, "Y": 32.5},
              "axis_lag_source": {"X": "feedback", "Y": "feedback"}})");
  const std::string cmd = std::string(CIRCCOMP_PATH) + " plan --only servo --ini " + c.ini + " " +
                          json + " > " + c.path("out") + " 2> " + c.path("err");
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 5);
  EXPECT_NE(c.read("err").find("neither a number nor one [SECTION]KEY"), std::string::npos)
      << c.read("err");
}

}  // namespace

// Gains and spikes in one diagnosis: the gains now, the friction after a rerun. circfric's
// step 1 divides the spike by the share of the pulse the measured lag passes; with FF1 going
// from 0 to 1 that share changes (0.4 -> about 1), and a pulse tuned on the old loop would
// push the table by 2.5x the spike.
TEST(Servo, FrictionWaitsForTheRerunWhenTheGainsChange) {
  Config c("pncconf-servo");
  DiagnosisInput d = lags(kLagX, kLagY);
  d.diagnosis.spike_mm[0] = {0.010, 0.0002};
  d.diagnosis.spike_ms[0].value = 40.0;
  const Plan plan = make_plan(c.ini, d, PlanOptions{});
  const FileChange* ini = file_of(plan, "pncconf-servo.ini");
  ASSERT_NE(ini, nullptr) << all(plan.notes);
  EXPECT_NEAR(number(IniDocument::parse(ini->after), "JOINT_0", "FF1"), 1.0, 1e-6);
  EXPECT_EQ(file_of(plan, "circtest-fric.hal"), nullptr);
  EXPECT_EQ(ini->after.find("[FRICTION_X]"), std::string::npos) << ini->after;
  EXPECT_TRUE(has_text(plan.notes,
                       "friction compensation not planned in this round: the servo "
                       "gains change"))
      << all(plan.notes);
}

// Y's pid reading X's key: the two joints need different FF1 (their lags differ), so one key
// cannot hold both; refused naming Y's setp and X's, not written twice with the last winning.
TEST(Servo, TwoJointsReadingOneKeyWithDifferentGainsAreRefused) {
  Config c("pncconf-servo");
  c.edit("pncconf-servo.hal", "setp   pid.y.FF1       [JOINT_1]FF1",
         "setp   pid.y.FF1       [JOINT_0]FF1");
  const std::string hal = c.read("pncconf-servo.hal");
  EXPECT_ERROR(make_plan(c.ini, lags(kLagX, kLagY), servo_only()), ExitCode::data,
               c.path("pncconf-servo.hal") + ":" + std::to_string(line_of(hal, "pid.y.FF1")) +
                   ": setp pid.y.FF1 reads [JOINT_0]FF1 as setp pid.x.FF1 does (" +
                   c.path("pncconf-servo.hal") + ":" + std::to_string(line_of(hal, "pid.x.FF1")) +
                   "), but joint 0 needs ");
  // Equal P and equal lags need equal FF1: one key serves both, written once.
  std::string ini = c.read("pncconf-servo.ini");
  ini.replace(ini.find("P = 31.0"), 8, "P = 30.0");
  c.write("pncconf-servo.ini", ini);
  const Plan same = make_plan(c.ini, lags(kLagX, kLagX), servo_only());
  EXPECT_TRUE(has_text(same.changes, "Y servo (joint 1, pid.y): FF1")) << all(same.changes);
}

// ---- every way halcmd sets a value (halcmd(1): "PIN = VALUE" is "setp PIN VALUE"; "sets
// SIGNAL VALUE" sets every pin on the signal; [SECTION]KEY in each), the last one run wins ----

// A later "PIN = VALUE" (custom.hal runs after pncconf-servo.hal) decides FF1: its literal is
// what circcomp reads and edits, not the [JOINT_0] FF1 the earlier setp names.
TEST(ServoForms, LaterEqualsFormIsReadAndEdited) {
  Config c("pncconf-servo");
  c.write("custom.hal", c.read("custom.hal") + "pid.x.FF1 = 0.4\n");
  const Plan plan = make_plan(c.ini, lags(kLagX, kLagY), servo_only());
  EXPECT_TRUE(has_text(plan.changes, "X servo (joint 0, pid.x): FF1 0.4 -> ")) << all(plan.changes);
  EXPECT_TRUE(has_text(plan.changes, "custom.hal:3 (pid.x.FF1 =)")) << all(plan.changes);
  const FileChange* custom = file_of(plan, "custom.hal");
  ASSERT_NE(custom, nullptr) << all(plan.notes);
  EXPECT_EQ(custom->after.find("pid.x.FF1 = 0.4\n"), std::string::npos) << custom->after;
  EXPECT_NE(custom->after.find("pid.x.FF1 = 1.0\n"), std::string::npos) << custom->after;
  // [JOINT_0] FF1 is not what LinuxCNC uses: it stays.
  const FileChange* ini = file_of(plan, "pncconf-servo.ini");
  if (ini != nullptr) {
    EXPECT_EQ(IniDocument::parse(ini->after).get("JOINT_0", "FF1"), "0.0");
  }
  // The HAL literal is a change of the plan's data, with its value before and after.
  const auto j = plan_json(plan);
  bool found = false;
  for (const auto& ch : j["changes"]) {
    if (ch["key"] == "FF1" && ch["before"] == "0.4") {
      found = true;
      EXPECT_EQ(ch["after"], "1.0");
      EXPECT_EQ(ch["kind"], "setting");
      EXPECT_EQ(ch["hal_line"], 3);
    }
  }
  EXPECT_TRUE(found) << j.dump(2);
}

TEST(ServoForms, EqualsFormWithAnIniReferenceEditsThatKey) {
  Config c("pncconf-servo");
  c.write("custom.hal", c.read("custom.hal") + "pid.x.FF1 = [PID_X]FF1\n");
  c.write("pncconf-servo.ini", c.read("pncconf-servo.ini") + "\n[PID_X]\nFF1 = 0.3\n");
  const Plan plan = make_plan(c.ini, lags(kLagX, kLagY), servo_only());
  EXPECT_TRUE(has_text(plan.changes, "FF1 0.3 -> 1.0 at [PID_X] FF1")) << all(plan.changes);
  const IniDocument after = IniDocument::parse(file_of(plan, "pncconf-servo.ini")->after);
  EXPECT_EQ(after.get("PID_X", "FF1"), "1.0");
  EXPECT_EQ(after.get("JOINT_0", "FF1"), "0.0");
}

TEST(ServoForms, SetsOfTheSignalDecidesAndIsEdited) {
  Config c("pncconf-servo");
  c.edit("pncconf-servo.hal", "setp   pid.y.FF1       [JOINT_1]FF1", "net y-ff1 pid.y.FF1");
  c.write("custom.hal", c.read("custom.hal") + "sets y-ff1 [JOINT_1](FF1)\n");
  Plan plan = make_plan(c.ini, lags(kLagX, kLagY), servo_only());
  EXPECT_TRUE(has_text(plan.changes, "Y servo (joint 1, pid.y): FF1 0.0 -> ")) << all(plan.changes);
  EXPECT_TRUE(has_text(plan.changes, "at [JOINT_1] FF1")) << all(plan.changes);
  // A literal sets value is edited in place.
  c.write("custom.hal", c.read("custom.hal") + "sets y-ff1 0.25   # by hand\n");
  plan = make_plan(c.ini, lags(kLagX, kLagY), servo_only());
  EXPECT_TRUE(has_text(plan.changes, "FF1 0.25 -> ")) << all(plan.changes);
  EXPECT_TRUE(has_text(plan.changes, "custom.hal:4 (sets y-ff1)")) << all(plan.changes);
  const FileChange* custom = file_of(plan, "custom.hal");
  ASSERT_NE(custom, nullptr);
  EXPECT_EQ(custom->after.find("sets y-ff1 0.25"), std::string::npos);
  EXPECT_NE(custom->after.find("   # by hand\n"), std::string::npos);
}

TEST(ServoForms, SetsReachingAPinOutsideThePlanIsRefused) {
  Config c("pncconf-servo");
  c.edit("pncconf-servo.hal", "setp   pid.y.FF1       [JOINT_1]FF1", "net ff1 pid.y.FF1 pid.z.FF1");
  c.write("custom.hal", c.read("custom.hal") + "sets ff1 0.2\n");
  EXPECT_ERROR(make_plan(c.ini, lags(kLagX, kLagY), servo_only()), ExitCode::data,
               c.path("custom.hal") + ":3: sets ff1 sets pid.y.FF1 and also pid.z.FF1");
}

TEST(ServoForms, HalcmdEntryOfTheIniIsRefusedNamingItsLine) {
  Config c("pncconf-servo");
  c.edit("pncconf-servo.ini", "HALFILE = custom.hal\n",
         "HALFILE = custom.hal\nHALCMD = setp pid.x.FF1 0.3\n");
  const std::size_t line = line_of(c.read("pncconf-servo.ini"), "HALCMD");
  EXPECT_ERROR(make_plan(c.ini, lags(kLagX, kLagY), servo_only()), ExitCode::data,
               c.ini + ":" + std::to_string(line) + ": pid.x.FF1 is set by this [HAL] HALCMD");
}

TEST(ServoForms, PostguiHalfileRunsLastAndIsEdited) {
  Config c("pncconf-servo");
  c.write("custom_postgui.hal", "setp pid.x.FF1 0.6\n");
  const Plan plan = make_plan(c.ini, lags(kLagX, kLagY), servo_only());
  EXPECT_TRUE(has_text(plan.changes, "FF1 0.6 -> 1.0 at ")) << all(plan.changes);
  ASSERT_NE(file_of(plan, "custom_postgui.hal"), nullptr);
  EXPECT_EQ(file_of(plan, "custom_postgui.hal")->after, "setp pid.x.FF1 1.0\n");
}

// An axis lagging 0.01 ms with a standard error of 0.01 ms: FF1 is matched (the whole band
// asks (0.01 + 0.02) ms x P 30 = 0.0009 of FF1), which is no reason to measure again.
TEST(ServoForms, LagOfAboutZeroIsAlreadyMatched) {
  Config c("pncconf-servo");
  c.edit("pncconf-servo.ini", "FF1 = 0.0", "FF1 = 1.0");
  const Plan plan = make_plan(c.ini, lags(0.01, 0.01), servo_only());
  EXPECT_TRUE(has_text(plan.notes,
                       "X servo: the lag 0.010 ms (standard error 0.010 ms) is "
                       "already matched"))
      << all(plan.notes);
  EXPECT_FALSE(has_text(plan.notes, "measure again")) << all(plan.notes);
  EXPECT_TRUE(plan.files.empty());
  // A lag as uncertain but large enough to matter is still measured again.
  DiagnosisInput d = lags(1.0, 1.0);
  d.diagnosis.axis_lag[0].lag_ms.standard_error = 0.5;
  EXPECT_TRUE(has_text(make_plan(c.ini, d, servo_only()).notes, "measure again"));
}
