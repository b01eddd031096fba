// circcomp's friction compensation on a pncconf-style servo and a stepconf-style stepper
// configuration (tests/compensation/fixtures): the circtest-fric.hal it writes, the INI values
// of step 1 and step 2, the notes when there is nothing to do, the refusals naming the HAL file
// and line, and apply + revert leaving the configuration byte-identical.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/friction.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/sha256.hpp"
#include "plan_test_support.hpp"

namespace fs = std::filesystem;
using namespace circtest;
using namespace circtest::compensation;
using circtest::testing::file_of;
using circtest::testing::has_text;

namespace {

// A copy of one fixture configuration (tests/compensation/fixtures) in a scratch folder.
struct Config : circtest::testing::ConfigCopy {
  explicit Config(const std::string& fixture) : ConfigCopy(FIXTURE_DIR, fixture, "fric") {}
};

// A diagnosis with reversal spikes X and Y (mm, standard error 0.1 um) and decays (ms).
DiagnosisInput spikes(std::optional<double> x_mm, std::optional<double> y_mm, double x_ms = 18.5,
                      double y_ms = 22.0) {
  DiagnosisInput d;
  d.source = "d.json";
  d.diagnosis.plane = Plane::XY;
  d.diagnosis.axes = {'X', 'Y'};
  d.diagnosis.spike_mm[0] = {x_mm, 1e-4};
  d.diagnosis.spike_mm[1] = {y_mm, 1e-4};
  d.diagnosis.spike_ms[0].value = x_ms;
  d.diagnosis.spike_ms[1].value = y_ms;
  return d;
}

// The servo fixture made an inch machine ([TRAJ] LINEAR_UNITS = inch).
void in_inch(Config& c) {
  std::string text = c.read("servo-mill.ini");
  text.replace(text.find("LINEAR_UNITS = mm"), 17, "LINEAR_UNITS = inch");
  c.write("servo-mill.ini", text);
}

PlanOptions friction_only() {
  PlanOptions o;
  o.only = {Correction::friction};
  o.friction_requested = true;
  return o;
}

const char* kServoFricHal =
    "# Written by circcomp (circtest): friction compensation at reversals, circfric(9)\n"
    "# (docs/circfric.md) spliced between motion's position command and the pid or stepgen.\n"
    "# The values live in the INI's [FRICTION_<axis>] sections; `circcomp revert` removes\n"
    "# this file and its [HAL] HALFILE line.\n"
    "loadrt circfric names=fric-x,fric-y\n"
    "addf fric-x servo-thread 3\n"
    "addf fric-y servo-thread 4\n"
    "# axis X, joint 0: x-pos-cmd (servo-mill.hal:17) into pid.x.command\n"
    "unlinkp pid.x.command\n"
    "net x-pos-cmd => fric-x.pos-in\n"
    "net fric-x-pos-out fric-x.pos-out => pid.x.command\n"
    "net x-vel-cmd => fric-x.vel-cmd\n"
    "net x-enable => fric-x.enable\n"
    "setp fric-x.amplitude [FRICTION_X]AMPLITUDE\n"
    "setp fric-x.amplitude-max [FRICTION_X]AMPLITUDE_MAX\n"
    "setp fric-x.decay-ms [FRICTION_X]DECAY_MS\n"
    "# axis Y, joint 1: y-pos-cmd (servo-mill.hal:32) into pid.y.command\n"
    "unlinkp pid.y.command\n"
    "net y-pos-cmd => fric-y.pos-in\n"
    "net fric-y-pos-out fric-y.pos-out => pid.y.command\n"
    "net y-vel-cmd => fric-y.vel-cmd\n"
    "net y-enable => fric-y.enable\n"
    "setp fric-y.amplitude [FRICTION_Y]AMPLITUDE\n"
    "setp fric-y.amplitude-max [FRICTION_Y]AMPLITUDE_MAX\n"
    "setp fric-y.decay-ms [FRICTION_Y]DECAY_MS\n";

}  // namespace

TEST(Friction, ServoStepOneWritesTheHalFileAndTheIniValues) {
  Config c("servo-mill");
  const Plan plan = make_plan(c.ini, spikes(0.0047, 0.0031), PlanOptions{});
  ASSERT_EQ(plan.files.size(), 2u);
  const FileChange* hal = file_of(plan, "circtest-fric.hal");
  ASSERT_NE(hal, nullptr);
  EXPECT_FALSE(hal->existed);
  EXPECT_EQ(hal->after, kServoFricHal);
  const FileChange* ini = file_of(plan, "servo-mill.ini");
  ASSERT_NE(ini, nullptr);
  const IniDocument after = IniDocument::parse(ini->after);
  // amplitude = the spike, decay = the measured decay, amplitude-max = 2 x the spike.
  EXPECT_EQ(after.get("FRICTION_X", "AMPLITUDE"), "0.0047");
  EXPECT_EQ(after.get("FRICTION_X", "DECAY_MS"), "18.5");
  EXPECT_EQ(after.get("FRICTION_X", "AMPLITUDE_MAX"), "0.0094");
  EXPECT_EQ(after.get("FRICTION_X", "SPIKE_MM"), "0.0047");
  EXPECT_EQ(after.get("FRICTION_Y", "AMPLITUDE"), "0.0031");
  EXPECT_EQ(after.get("FRICTION_Y", "DECAY_MS"), "22.0");
  EXPECT_EQ(after.get("FRICTION_Y", "AMPLITUDE_MAX"), "0.0062");
  // One more HALFILE, after the existing ones; the rest of the INI as it was.
  const auto halfiles = after.get_all("HAL", "HALFILE");
  ASSERT_EQ(halfiles.size(), 3u);
  EXPECT_EQ(halfiles[2].value, "circtest-fric.hal");
  const std::string diff = unified_diff(plan);
  EXPECT_NE(diff.find("+HALFILE = circtest-fric.hal\n"), std::string::npos) << diff;
  EXPECT_NE(diff.find("+unlinkp pid.x.command\n"), std::string::npos) << diff;
  EXPECT_NE(diff.find("+AMPLITUDE = 0.0047\n"), std::string::npos) << diff;
  for (std::size_t at = diff.find("\n-"); at != std::string::npos; at = diff.find("\n-", at + 1)) {
    EXPECT_EQ(diff.compare(at, 5, "\n--- "), 0) << "nothing removed:\n" << diff;
  }
  EXPECT_TRUE(has_text(plan.changes, "[FRICTION_X] step 1 (first tuning)"));
  EXPECT_TRUE(plan.needs_fric_module);
  EXPECT_FALSE(has_text(plan.advice, "reversal spikes"));  // planned, not advised
}

TEST(Friction, StepperSplicesBeforeStepgenAfterMotionController) {
  Config c("stepper-mill");
  const Plan plan = make_plan(c.ini, spikes(0.006, 0.0), friction_only());
  const FileChange* hal = file_of(plan, "circtest-fric.hal");
  ASSERT_NE(hal, nullptr);
  EXPECT_EQ(hal->after.substr(hal->after.find("loadrt")),
            "loadrt circfric names=fric-x\n"
            "addf fric-x servo-thread 4\n"
            "# axis X, joint 0: xpos-cmd (stepper-mill.hal:14) into stepgen.0.position-cmd\n"
            "unlinkp stepgen.0.position-cmd\n"
            "net xpos-cmd => fric-x.pos-in\n"
            "net fric-x-pos-out fric-x.pos-out => stepgen.0.position-cmd\n"
            "net fric-x-vel-cmd joint.0.vel-cmd => fric-x.vel-cmd\n"
            "net xenable => fric-x.enable\n"
            "setp fric-x.amplitude [FRICTION_X]AMPLITUDE\n"
            "setp fric-x.amplitude-max [FRICTION_X]AMPLITUDE_MAX\n"
            "setp fric-x.decay-ms [FRICTION_X]DECAY_MS\n");
  const IniDocument after = IniDocument::parse(file_of(plan, "stepper-mill.ini")->after);
  EXPECT_EQ(after.get("FRICTION_X", "AMPLITUDE"), "0.006");
  EXPECT_FALSE(after.has_section("FRICTION_Y"));
  EXPECT_TRUE(has_text(plan.notes, "Y reversal spike of 0.00 um is below 2 um"));
}

TEST(Friction, APidBeforeMotionControllerIsNoted) {
  Config c("servo-mill");
  // In pncconf's order (the pids after motion-controller) no such note.
  EXPECT_FALSE(has_text(make_plan(c.ini, spikes(0.004, std::nullopt), friction_only()).notes,
                        "before motion-controller"));
  std::string hal = c.read("servo-mill.hal");
  const std::string pid = "addf pid.x.do-pid-calcs servo-thread\n";
  hal.erase(hal.find(pid), pid.size());
  hal.insert(hal.find("addf motion-command-handler"), pid);
  c.write("servo-mill.hal", hal);
  const Plan plan = make_plan(c.ini, spikes(0.004, std::nullopt), friction_only());
  EXPECT_TRUE(has_text(plan.notes,
                       "pid.x.do-pid-calcs runs before motion-controller in "
                       "servo-thread"));
  EXPECT_NE(file_of(plan, "circtest-fric.hal")->after.find("addf fric-x servo-thread 4\n"),
            std::string::npos);
}

TEST(Friction, InchMachineGetsMachineUnits) {
  Config c("servo-mill");
  in_inch(c);
  const Plan plan = make_plan(c.ini, spikes(0.00508, std::nullopt), friction_only());
  const IniDocument after = IniDocument::parse(file_of(plan, "servo-mill.ini")->after);
  EXPECT_EQ(after.get("FRICTION_X", "AMPLITUDE"), "0.0002");
  EXPECT_EQ(after.get("FRICTION_X", "AMPLITUDE_MAX"), "0.0004");
  EXPECT_EQ(after.get("FRICTION_X", "SPIKE_MM"), "0.00508");
  // The plan says the spike in the machine's units and mm, as AMPLITUDE is in inch.
  EXPECT_TRUE(has_text(plan.changes,
                       "AMPLITUDE 0.0002 (spike 0.0002 in (0.00508 mm)), "
                       "DECAY_MS 18.5, AMPLITUDE_MAX 0.0004 (2 x spike)"));
}

// On an inch machine every friction note, change and refusal says its size in inch and mm,
// and step 2 writes its AMPLITUDE in inch: 0.2 mil first compensated (5.08 um) plus a
// residual of 0.1 mil (2.54 um) is 0.0003 in.
TEST(Friction, InchMachineSaysInchAndMm) {
  Config c("servo-mill");
  in_inch(c);
  DiagnosisInput d = spikes(0.0015, 0.003);
  d.diagnosis.spike_mm[1].standard_error = 0.002;
  Plan plan = make_plan(c.ini, d, friction_only());
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(has_text(plan.notes,
                       "X reversal spike of 0.0000591 in (0.0015 mm) is below "
                       "0.0000787 in (0.002 mm): no friction change"));
  EXPECT_TRUE(has_text(plan.notes,
                       "Y reversal spike of 0.0001181 in (0.003 mm) is not "
                       "significant (standard error 0.0000787 in (0.002 mm)"));
  plan = make_plan(c.ini, spikes(std::nullopt, -0.00254), friction_only());
  EXPECT_TRUE(has_text(plan.notes, "Y reversal spike of -0.0001 in (-0.00254 mm) points inwards"));
  try {
    (void)make_plan(c.ini, spikes(0.254, 0.0), friction_only());
    ADD_FAILURE() << "a 0.254 mm spike was planned";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("X reversal spike = 0.01 in (0.254 mm) is implausible "
                                         "for friction (more than 0.003937 in (0.1 mm))"),
              std::string::npos)
        << e.what();
  }
  PlanOptions backlash;
  backlash.only = {Correction::backlash};
  plan = make_plan(c.ini, spikes(0.00508, 0.0), backlash);
  EXPECT_TRUE(has_text(plan.advice, "X reversal spikes of 0.0002 in (0.00508 mm) decaying"));
  // Step 1, applied; step 2 from a residual of 0.0001 in.
  apply_plan(make_plan(c.ini, spikes(0.00508, std::nullopt), friction_only()));
  plan = make_plan(c.ini, spikes(0.00254, std::nullopt), friction_only());
  ASSERT_EQ(plan.files.size(), 1u);
  EXPECT_EQ(IniDocument::parse(plan.files[0].after).get("FRICTION_X", "AMPLITUDE"), "0.0003");
  EXPECT_TRUE(has_text(plan.changes,
                       "AMPLITUDE 0.0002 -> 0.0003 (residual spike 0.0001 in "
                       "(0.00254 mm), 50 % of the 0.0002 in (0.00508 mm) "
                       "compensated)"));
  plan = make_plan(c.ini, spikes(0.00127, std::nullopt), friction_only());
  EXPECT_TRUE(has_text(plan.notes,
                       "X residual reversal spike of 0.00005 in (0.00127 mm) is "
                       "below 0.0000787 in (0.002 mm)"));
}

TEST(Friction, GantryGetsOneInstancePerJoint) {
  Config c("servo-mill");
  std::string ini = c.read("servo-mill.ini");
  ini.replace(ini.find("coordinates=XYZ"), 15, "coordinates=XYYZ");
  ini.replace(ini.find("JOINTS = 3"), 10, "JOINTS = 4");
  c.write("servo-mill.ini", ini);
  // Joint 2 is the second Y motor (pid.z stands in for its pid), joint 3 is Z.
  std::string hal = c.read("servo-mill.hal");
  const std::string z = "net z-pos-cmd    joint.2.motor-pos-cmd";
  hal.replace(hal.find(z), z.size(), "net y2-pos-cmd   joint.2.motor-pos-cmd");
  c.write("servo-mill.hal", hal);
  const Plan plan = make_plan(c.ini, spikes(std::nullopt, 0.004), friction_only());
  const FileChange* f = file_of(plan, "circtest-fric.hal");
  ASSERT_NE(f, nullptr);
  EXPECT_NE(f->after.find("loadrt circfric names=fric-y-j1,fric-y-j2\n"), std::string::npos)
      << f->after;
  EXPECT_NE(f->after.find("net y2-pos-cmd => fric-y-j2.pos-in\n"
                          "net fric-y-j2-pos-out fric-y-j2.pos-out => pid.z.command\n"),
            std::string::npos)
      << f->after;
  EXPECT_NE(f->after.find("setp fric-y-j2.amplitude [FRICTION_Y]AMPLITUDE\n"), std::string::npos);
}

TEST(Friction, NoSpikeNoFrictionChange) {
  Config c("servo-mill");
  // Below 2 um, not significant against its standard error, null, inwards, decay unknown.
  DiagnosisInput d = spikes(0.0015, 0.003);
  d.diagnosis.spike_mm[1].standard_error = 0.002;
  Plan plan = make_plan(c.ini, d, friction_only());
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(has_text(plan.notes, "X reversal spike of 1.50 um is below 2 um"));
  EXPECT_TRUE(has_text(plan.notes, "Y reversal spike of 3.00 um is not significant"));
  plan = make_plan(c.ini, spikes(std::nullopt, -0.004), friction_only());
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(has_text(plan.notes, "X reversal spike: not in the diagnosis"));
  EXPECT_TRUE(has_text(plan.notes, "points inwards"));
  DiagnosisInput no_decay = spikes(0.004, 0.0);
  no_decay.diagnosis.spike_ms[0].value.reset();
  plan = make_plan(c.ini, no_decay, friction_only());
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(has_text(plan.notes, "its decay was not measured"));
  // Without friction in the plan's kinds, a spike is advice as before.
  PlanOptions backlash;
  backlash.only = {Correction::backlash};
  plan = make_plan(c.ini, spikes(0.004, 0.0), backlash);
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(has_text(plan.advice, "X reversal spikes of 4.0 um"));
}

TEST(Friction, ImplausibleSpikeIsRefusedUnlessForced) {
  Config c("servo-mill");
  EXPECT_THROW(make_plan(c.ini, spikes(0.15, 0.0), friction_only()), DataError);
  PlanOptions forced = friction_only();
  forced.force = true;
  EXPECT_EQ(IniDocument::parse(
                file_of(make_plan(c.ini, spikes(0.15, 0.0), forced), "servo-mill.ini")->after)
                .get("FRICTION_X", "AMPLITUDE_MAX"),
            "0.3");
  // Twice the spike beyond circfric's bound of 1 machine unit: refused even when forced.
  EXPECT_THROW(make_plan(c.ini, spikes(0.6, 0.0), forced), DataError);
}

TEST(Friction, StepTwoRefinesTheAmplitudeOnly) {
  Config c("servo-mill");
  apply_plan(make_plan(c.ini, spikes(0.005, std::nullopt), friction_only()));
  const std::string hal_after_step1 = c.read("circtest-fric.hal");
  auto amplitude_after = [&](DiagnosisInput d, double gain, Plan* out = nullptr) {
    PlanOptions o = friction_only();
    o.gain = gain;
    Plan plan = make_plan(c.ini, d, o);
    EXPECT_EQ(file_of(plan, "circtest-fric.hal"), nullptr) << "step 2 changes only the INI";
    const FileChange* ini = file_of(plan, "servo-mill.ini");
    std::optional<std::string> v;
    if (ini != nullptr) v = IniDocument::parse(ini->after).get("FRICTION_X", "AMPLITUDE");
    if (out != nullptr) *out = std::move(plan);
    return v;
  };
  // Residual 2 um of the 5 um compensated (40 % > 30 %): 5 + 2 um.
  Plan plan;
  EXPECT_EQ(amplitude_after(spikes(0.002, std::nullopt), 1.0, &plan), "0.007");
  EXPECT_TRUE(has_text(plan.changes, "[FRICTION_X] step 2 (refinement): AMPLITUDE 0.005 -> 0.007"));
  // With a gain: 5 + 0.5 x 2 um. Over-compensated (-3 um): 5 - 3 um.
  EXPECT_EQ(amplitude_after(spikes(0.002, std::nullopt), 0.5), "0.006");
  EXPECT_EQ(amplitude_after(spikes(-0.003, std::nullopt), 1.0), "0.002");
  // 8 um more would pass amplitude-max (2 x 5 um): clamped to it.
  EXPECT_EQ(amplitude_after(spikes(0.008, std::nullopt), 1.0, &plan), "0.01");
  EXPECT_TRUE(has_text(plan.notes, "clamped to 0.01"));
  // 1.4 um is below 2 um: nothing changes.
  EXPECT_EQ(amplitude_after(spikes(0.0014, std::nullopt), 1.0, &plan), std::nullopt);
  EXPECT_TRUE(has_text(plan.notes, "X residual reversal spike of 1.40 um is below 2 um"));
  // AMPLITUDE_MAX raised by hand above twice the first spike: back to 2 x 5 um, and the bound.
  IniDocument edited = IniDocument::load(c.ini);
  edited.set("FRICTION_X", "AMPLITUDE_MAX", "0.05");
  c.write("servo-mill.ini", edited.render());
  plan = make_plan(c.ini, spikes(0.009, std::nullopt), friction_only());
  const IniDocument after = IniDocument::parse(file_of(plan, "servo-mill.ini")->after);
  EXPECT_EQ(after.get("FRICTION_X", "AMPLITUDE_MAX"), "0.01");
  EXPECT_EQ(after.get("FRICTION_X", "AMPLITUDE"), "0.01");
  EXPECT_EQ(c.read("circtest-fric.hal"), hal_after_step1);
}

TEST(Friction, NoStepTwoWhenTheResidualIsThirtyPercentOrLess) {
  Config c("servo-mill");
  apply_plan(make_plan(c.ini, spikes(0.010, std::nullopt), friction_only()));
  // 3 um of 10 um: not more than 30 %, no step 2; 3.1 um: step 2.
  Plan plan = make_plan(c.ini, spikes(0.003, std::nullopt), friction_only());
  EXPECT_TRUE(plan.files.empty());
  EXPECT_TRUE(has_text(plan.notes,
                       "is 30 % of the 10.00 um compensated, not more than 30 %: no "
                       "step 2, [FRICTION_X] unchanged"));
  plan = make_plan(c.ini, spikes(0.0031, std::nullopt), friction_only());
  ASSERT_EQ(plan.files.size(), 1u);
  EXPECT_EQ(IniDocument::parse(plan.files[0].after).get("FRICTION_X", "AMPLITUDE"), "0.0131");
}

TEST(Friction, StepTwoOfOneAxisWiresTheOtherAxisNew) {
  Config c("servo-mill");
  apply_plan(make_plan(c.ini, spikes(0.005, std::nullopt), friction_only()));
  const Plan plan = make_plan(c.ini, spikes(0.0001, 0.004), friction_only());
  const FileChange* hal = file_of(plan, "circtest-fric.hal");
  ASSERT_NE(hal, nullptr);
  EXPECT_TRUE(hal->existed);
  EXPECT_EQ(hal->after, kServoFricHal);  // X kept, Y added
  const IniDocument after = IniDocument::parse(file_of(plan, "servo-mill.ini")->after);
  EXPECT_EQ(after.get_all("HAL", "HALFILE").size(), 3u);  // not added twice
  EXPECT_EQ(after.get("FRICTION_X", "AMPLITUDE"), "0.005");
  EXPECT_EQ(after.get("FRICTION_Y", "AMPLITUDE"), "0.004");
}

TEST(Friction, ApplyThenRevertIsByteIdentical) {
  Config c("servo-mill");
  const auto before = c.files();
  apply_plan(make_plan(c.ini, spikes(0.0047, 0.0031), PlanOptions{}));
  EXPECT_EQ(c.read("circtest-fric.hal"), kServoFricHal);
  EXPECT_NE(c.files(), before);
  ASSERT_TRUE(revert(c.ini));
  EXPECT_EQ(c.files(), before);
  EXPECT_FALSE(fs::exists(c.dir / "circtest-fric.hal"));
}

// Each layout circcomp cannot splice is refused with the HAL file and line.
TEST(Friction, UnfindablePositionCommandIsRefusedWithFileAndLine) {
  struct Case {
    const char* what;
    std::string from, to;
    std::string where;  // "file:line"
    std::string words;
  };
  const std::vector<Case> cases = {
      {"the pid's command a literal", "net x-pos-cmd       =>  pid.x.command\n",
       "setp pid.x.command 0\n", "servo-mill.hal:17", "pid.x.command is a literal (setp)"},
      {"the joint's command on no net", "net x-pos-cmd    <=  joint.0.motor-pos-cmd\n", "",
       "servo-mill.ini:12", "no net in the HAL files read"},
      {"the joint's command to something that is no pid",
       "net x-pos-cmd    <=  joint.0.motor-pos-cmd\n",
       "net x-pos-raw    <=  joint.0.motor-pos-cmd\nnet x-pos-raw => offset.0.in\n",
       "servo-mill.hal:21",
       "signal x-pos-raw carries joint.0.motor-pos-cmd (axis X) to offset.0.in: no pid"},
      {"the joint's command to two pids", "pid.z.enable\n",
       "pid.z.enable\nnet x-pos-cmd => pid.z.command\n", "servo-mill.hal:17",
       "more than one pid or stepgen"},
      {"no motion-controller in any thread", "addf motion-controller servo-thread\n", "\n",
       "servo-mill.ini:12", "adds motion-controller to a thread"},
      {"circfric loaded by hand already", "loadrt pid names=pid.x,pid.y,pid.z\n",
       "loadrt pid names=pid.x,pid.y,pid.z\nloadrt circfric count=1\n", "servo-mill.hal:5",
       "loads circfric itself"},
  };
  for (const auto& k : cases) {
    SCOPED_TRACE(k.what);
    Config c("servo-mill");
    std::string hal = c.read("servo-mill.hal");
    ASSERT_NE(hal.find(k.from), std::string::npos);
    hal.replace(hal.find(k.from), k.from.size(), k.to);
    c.write("servo-mill.hal", hal);
    try {
      make_plan(c.ini, spikes(0.004, std::nullopt), friction_only());
      ADD_FAILURE() << "no refusal";
    } catch (const WiringError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(k.where + ": "), std::string::npos) << what;
      EXPECT_NE(what.find(k.words), std::string::npos) << what;
      EXPECT_EQ(e.code(), ExitCode::data);
    }
  }
}

TEST(Friction, CliPlansAndRefusesWithExitCodes) {
  Config c("servo-mill");
  const std::string json =
      R"({"schema": "circtest.diagnosis/1", "plane": "XY", "axes": ["X", "Y"],
          "reversal_spike_mm": {"X": 0.0047, "Y": null}, "reversal_spike_ms": {"X": 18.5, "Y": null},
          "standard_error": {"reversal_spike_mm": {"X": 0.0001, "Y": null}}})";
  c.write("d.json", json);
  const std::string base = std::string(CIRCCOMP_PATH) + " plan --ini " + c.ini + " " +
                           (c.dir / "d.json").string() + " --only friction";
  const std::string out = (c.dir / "out.txt").string();
  int rc = std::system((base + " >" + out + " 2>&1").c_str());
  ASSERT_EQ(WEXITSTATUS(rc), 0) << read_file(out);
  const std::string text = read_file(out);
  EXPECT_NE(text.find("+HALFILE = circtest-fric.hal"), std::string::npos) << text;
  EXPECT_NE(text.find("+AMPLITUDE_MAX = 0.0094"), std::string::npos) << text;
  EXPECT_NE(text.find("# change: [FRICTION_X] step 1 (first tuning)"), std::string::npos) << text;
  // A literal command: exit 5, file and line, the option that leaves friction out.
  std::string hal = c.read("servo-mill.hal");
  const std::string from = "net x-pos-cmd       =>  pid.x.command\n";
  hal.replace(hal.find(from), from.size(), "setp pid.x.command 0\n");
  c.write("servo-mill.hal", hal);
  rc = std::system((base + " >" + out + " 2>&1").c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 5);
  const std::string err = read_file(out);
  EXPECT_NE(err.find("servo-mill.hal:17: pid.x.command is a literal"), std::string::npos) << err;
  EXPECT_NE(err.find("--only backlash,scale,squareness,cyclic"), std::string::npos) << err;
}

// A HAL file built to be slow or deep: a word of a megabyte of '[' references and a signal
// relinked with every one of 100,000 pins a second time parse in linear time, without
// recursion that grows with the input.
TEST(Friction, HostileHalTextParsesInLinearTime) {
  const IniDocument ini = IniDocument::parse("[A]\nB = x\n", "f.ini");
  std::string word = "setp p.q ";
  for (int i = 0; i < 100000; ++i) word += "[A]B[";
  word += std::string(500000, 'a') + "\n";
  std::string relink = "net s";
  for (int i = 0; i < 100000; ++i) relink += " p" + std::to_string(i) + ".x";
  relink += "\n";
  // The parse's CPU time: the tests running beside it on the machine do not count.
  const std::clock_t start = std::clock();
  const HalWiring w = parse_hal_text(word + relink + relink, "big.hal", ini);
  const double seconds = static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
  EXPECT_EQ(w.signals.at("s").pins.size(), 100000u);
  EXPECT_LT(seconds, 5.0);
}

TEST(Friction, IniReferencesInHalWordsAreReplacedAsHalcmdDoes) {
  const IniDocument ini = IniDocument::parse("[A]\nB = x\n[JOINT_0]\nP = 50\n", "f.ini");
  const HalWiring w =
      parse_hal_text("net [A]B [A](B).y [[A]B] [A]C [A] [A](B [JOINT_0]P.q\n", "h.hal", ini);
  ASSERT_EQ(w.signals.count("x"), 1u);
  EXPECT_EQ(w.signals.at("x").pins,
            (std::set<std::string>{"x.y", "[x]", "[A]C", "[A]", "[A](B", "50.q"}));
}

// What circcomp cannot wire is told from what it refuses to do by the error's type, not by the
// file it names: a diagnosis named like the HAL file still only loses friction (a note), and
// a [FRICTION_X] value broken by hand is refused (exit 5, file and line) even when friction was
// not asked for by name.
TEST(Friction, OnlyWiringErrorsBecomeNotesWhenFrictionIsNotNamed) {
  {
    Config c("servo-mill");
    std::string hal = c.read("servo-mill.hal");
    const std::string from = "net x-pos-cmd       =>  pid.x.command\n";
    hal.replace(hal.find(from), from.size(), "setp pid.x.command 0\n");
    c.write("servo-mill.hal", hal);
    DiagnosisInput d = spikes(0.004, std::nullopt);
    d.source = (c.dir / "servo-mill.hal").string();
    try {
      make_plan(c.ini, d, friction_only());
      ADD_FAILURE() << "no refusal";
    } catch (const WiringError& e) {
      EXPECT_EQ(e.code(), ExitCode::data);
      EXPECT_NE(std::string(e.what()).find("servo-mill.hal:17: pid.x.command is a literal"),
                std::string::npos)
          << e.what();
    }
    const Plan plan = make_plan(c.ini, d, PlanOptions{});
    EXPECT_TRUE(has_text(plan.notes, "friction compensation not planned: "));
    EXPECT_TRUE(has_text(plan.notes, "pid.x.command is a literal"));
  }
  {
    Config c("servo-mill");
    apply_plan(make_plan(c.ini, spikes(0.005, std::nullopt), friction_only()));
    IniDocument edited = IniDocument::load(c.ini);
    edited.set("FRICTION_X", "AMPLITUDE", "abc");
    c.write("servo-mill.ini", edited.render());
    try {
      make_plan(c.ini, spikes(0.003, std::nullopt), PlanOptions{});
      ADD_FAILURE() << "a broken [FRICTION_X] became a note";
    } catch (const WiringError& e) {
      ADD_FAILURE() << "not a wiring error: " << e.what();
    } catch (const DataError& e) {
      EXPECT_EQ(e.code(), ExitCode::data);
      EXPECT_NE(std::string(e.what()).find("servo-mill.ini:"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("[FRICTION_X] AMPLITUDE = 'abc': expected a length"),
                std::string::npos)
          << e.what();
    }
  }
}

// Step 1 on a P loop without feed-forward: the command pulse reaches the table through the
// loop's lag 1 / Kv, which passes only (decay / lag)^(-lag / (decay - lag)) of it: the
// amplitude is the spike divided by that share, bounded by AMPLITUDE_MAX (2 x spike).
TEST(Friction, StepOneDividesByTheShareOfThePulseTheLagPasses) {
  auto amplitude = [](std::optional<double> kv, Plan* out = nullptr) {
    Config c("servo-mill");
    DiagnosisInput d = spikes(0.0047, std::nullopt);
    d.diagnosis.kv_per_s.value = kv;
    Plan plan = make_plan(c.ini, d, friction_only());
    const IniDocument after = IniDocument::parse(file_of(plan, "servo-mill.ini")->after);
    EXPECT_EQ(after.get("FRICTION_X", "AMPLITUDE_MAX"), "0.0094");
    EXPECT_EQ(after.get("FRICTION_X", "DECAY_MS"), "18.5");
    if (out != nullptr) *out = std::move(plan);
    return std::stod(*after.get("FRICTION_X", "AMPLITUDE"));
  };
  // Lag 3.33 ms, decay 18.5 ms: ratio 5.55, share 5.55^(-1 / 4.55) = 0.686.
  const double ratio = 18.5 / (1e3 / 300.0);
  Plan plan;
  EXPECT_NEAR(amplitude(300.0, &plan), 0.0047 / std::pow(ratio, -1.0 / (ratio - 1.0)), 1e-7);
  EXPECT_TRUE(
      has_text(plan.changes, "/ 0.69, the share of the pulse the 3.3 ms lag (1 / Kv) passes"));
  // Lag 33 ms (sim-servo's P 30) against 18.5 ms: 0.27, so 2.7 x the spike: bounded.
  EXPECT_EQ(amplitude(30.0, &plan), 0.0094);
  EXPECT_TRUE(has_text(plan.changes, "bounded by AMPLITUDE_MAX"));
  // No Kv in the diagnosis (or nonsense): the spike itself.
  EXPECT_EQ(amplitude(std::nullopt), 0.0047);
  EXPECT_EQ(amplitude(-5.0), 0.0047);
  EXPECT_EQ(amplitude(0.0), 0.0047);
}

// Step 2 where AMPLITUDE_MAX holds the amplitude below what an outward residual asks for: the
// decay lengthens by that share (the pulse's area), at most twice; an over-compensation only
// lowers the amplitude.
TEST(Friction, StepTwoLengthensTheDecayWhereTheAmplitudeIsBounded) {
  auto step2 = [](double residual_mm) {
    Config c("servo-mill");
    apply_plan(make_plan(c.ini, spikes(0.005, std::nullopt), friction_only()));
    Plan plan = make_plan(c.ini, spikes(residual_mm, std::nullopt), friction_only());
    const IniDocument after = IniDocument::parse(file_of(plan, "servo-mill.ini")->after);
    return std::make_pair(*after.get("FRICTION_X", "AMPLITUDE"),
                          *after.get("FRICTION_X", "DECAY_MS"));
  };
  // 5 + 8 um wanted, 10 um allowed: the decay 18.5 ms x 13 / 10.
  EXPECT_EQ(step2(0.008), std::make_pair(std::string("0.01"), std::string("24.05")));
  // 5 + 20 um wanted: 2.5 x, bounded to twice the decay.
  EXPECT_EQ(step2(0.020), std::make_pair(std::string("0.01"), std::string("37.0")));
  // Within the bound, or over-compensated: the decay stays.
  EXPECT_EQ(step2(0.002), std::make_pair(std::string("0.007"), std::string("18.5")));
  EXPECT_EQ(step2(-0.003), std::make_pair(std::string("0.002"), std::string("18.5")));
}

// AMPLITUDE_MAX is twice SPIKE_MM as written: step 2 finds it at its bound, not a last digit
// above it to be lowered.
TEST(Friction, StepOneBoundIsTwiceTheSpikeAsWritten) {
  Config c("servo-mill");
  DiagnosisInput d = spikes(0.010498736, std::nullopt);
  d.diagnosis.kv_per_s.value = 30.0;
  apply_plan(make_plan(c.ini, d, friction_only()));
  const IniDocument ini = IniDocument::load(c.ini);
  EXPECT_EQ(std::stod(*ini.get("FRICTION_X", "AMPLITUDE_MAX")),
            2.0 * std::stod(*ini.get("FRICTION_X", "SPIKE_MM")));
  const Plan plan = make_plan(c.ini, spikes(0.004, std::nullopt), friction_only());
  EXPECT_FALSE(has_text(plan.notes, "] AMPLITUDE_MAX ")) << "no bound lowered by a rounding";
  EXPECT_TRUE(has_text(plan.changes, "DECAY_MS"));
}

// A loop that follows within a few ms passes circfric's pulse before the table sticks: no
// pulse is planned for that axis, a note says why; the lagging axis is tuned as ever.
TEST(Friction, NoPulseWhereTheAxisFollowsWithinAFewMs) {
  Config c("servo-mill");
  DiagnosisInput d = spikes(0.010, 0.008);
  d.diagnosis.axis_lag[0].lag_ms = {0.7, 0.01};   // X: FF1 about 1
  d.diagnosis.axis_lag[1].lag_ms = {33.0, 0.01};  // Y: FF1 0
  const Plan plan = make_plan(c.ini, d, friction_only());
  const FileChange* ini = file_of(plan, "servo-mill.ini");
  ASSERT_NE(ini, nullptr);
  const IniDocument after = IniDocument::parse(ini->after);
  EXPECT_FALSE(after.get("FRICTION_X", "AMPLITUDE"));
  EXPECT_TRUE(after.get("FRICTION_Y", "AMPLITUDE"));
  EXPECT_TRUE(has_text(plan.notes,
                       "X friction compensation not planned: the axis follows "
                       "within 0.7 ms"));
}

// An axis that follows within a few ms and whose spike peaks after the reversal (the drive
// sticks) gets circfric's rising pulse: RISE_MS puts the pulse's peak at 0.4 of the spike's
// peak time (checked with the pulse formula of circfric(9), not circcomp's), the amplitude is
// the spike's height (the loop passes the pulse whole) and the HAL file sets rise-ms; the
// lagging axis keeps the plain pulse and no rise line.
TEST(Friction, RisingPulseWhereTheAxisFollowsAndTheSpikePeaksLate) {
  Config c("servo-mill");
  DiagnosisInput d = spikes(0.010, 0.008, 38.0, 22.0);
  d.diagnosis.axis_lag[0].lag_ms = {0.7, 0.01};   // X: FF1 about 1
  d.diagnosis.axis_lag[1].lag_ms = {33.0, 0.01};  // Y: FF1 0
  d.diagnosis.spike_peak_ms[0].value = 76.0;
  d.diagnosis.spike_peak_ms[1].value = 40.0;  // a lagging axis: the plain pulse whatever the peak
  const Plan plan = make_plan(c.ini, d, friction_only());
  const FileChange* ini = file_of(plan, "servo-mill.ini");
  ASSERT_NE(ini, nullptr);
  const IniDocument after = IniDocument::parse(ini->after);
  const auto num = [&](const char* sec, const char* key) {
    const auto v = after.get(sec, key);
    EXPECT_TRUE(v) << sec << " " << key;
    return v ? std::stod(*v) : NAN;
  };
  const double rise_s = num("FRICTION_X", "RISE_MS") * 1e-3, decay_s = 0.038;
  const double peak_s = std::log(decay_s / rise_s) * decay_s * rise_s / (decay_s - rise_s);
  EXPECT_NEAR(peak_s, 0.4 * 0.076, 1e-5);
  EXPECT_NEAR(num("FRICTION_X", "AMPLITUDE"), 0.010, 1e-9);
  EXPECT_NEAR(num("FRICTION_X", "AMPLITUDE_MAX"), 0.020, 1e-9);
  EXPECT_NEAR(num("FRICTION_X", "DECAY_MS"), 38.0, 1e-9);
  EXPECT_FALSE(after.get("FRICTION_Y", "RISE_MS"));
  EXPECT_TRUE(after.get("FRICTION_Y", "AMPLITUDE"));
  const FileChange* hal = file_of(plan, "circtest-fric.hal");
  ASSERT_NE(hal, nullptr);
  EXPECT_NE(hal->after.find("setp fric-x.rise-ms [FRICTION_X]RISE_MS\n"), std::string::npos)
      << hal->after;
  EXPECT_EQ(hal->after.find("fric-y.rise-ms"), std::string::npos) << hal->after;
  EXPECT_TRUE(has_text(plan.changes, "a rising pulse: the axis follows within 0.7 ms"));

  // A peak later than a rise below the decay can make: the latest peak, said so.
  d.diagnosis.spike_peak_ms[0].value = 200.0;
  const Plan late = make_plan(c.ini, d, friction_only());
  const IniDocument late_ini = IniDocument::parse(file_of(late, "servo-mill.ini")->after);
  EXPECT_NEAR(std::stod(*late_ini.get("FRICTION_X", "RISE_MS")), 0.95 * 38.0, 1e-3);
  EXPECT_TRUE(has_text(late.changes, "the latest a decay of 38.0 ms allows; 80 ms wanted"))
      << circtest::testing::all(late.changes);
}
