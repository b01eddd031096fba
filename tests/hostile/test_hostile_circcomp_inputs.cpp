// circcomp and circtest-ini on inputs that are not what they should be: a diagnosis JSON that
// is not what circana writes (or a FIFO), INI includes that fail, circtest-ini arguments, HAL
// wiring circfric cannot be spliced into, options a command does not take, gains out of range.
// Every case runs the real programs and checks the exit code, the words of the refusal, and that
// nothing outside the configuration changed.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "circtest/core/sha256.hpp"
#include "scratch.hpp"

#include "hostile_circcomp_fixture.hpp"

TEST_F(Hostile, ADiagnosisThatIsNotCircanasIsAnInputError) {
  const std::string good = slurp(diagnosis());
  auto with = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    text.replace(text.find(from), from.size(), to);
    const std::string path =
        (top() / "diagnoses" / ("bad" + std::to_string(n_++) + ".json")).string();
    spit(path, text);
    return path;
  };
  struct Case {
    std::string path;
    int code;
    std::string words;
  };
  const std::vector<Case> cases = {
      {with("\"X\": 0.002", "\"X\": 1e400"), 4, "\"backlash_mm.X\": a number beyond"},
      {with("\"circtest.diagnosis/1\"", "5"), 4, "\"schema\": expected a string"},
      {with("\"circtest.diagnosis/1\"", "\"circtest.diagnosis/2\""), 4,
       "\"schema\": circtest.diagnosis/2 is a version this circcomp does not read"},
      {with("\"units\": \"mm\"", "\"units\": \"mm\", \"version\": \"2.0\""), 4,
       "\"version\": 2.0 is newer than this circcomp reads (1.x): use the circcomp of the "
       "circana that wrote it"},
      {with("\"units\": \"mm\"", "\"units\": \"mm\", \"version\": \"1\\u0007\""), 4,
       "\"version\": expected MAJOR.MINOR (\"1.5\"), got '1\\x07'"},
      {with("\"plane\": \"XY\"", "\"plane\": [1]"), 4, "\"plane\": expected a string"},
      {with("\"units\": \"mm\"", "\"units\": {}"), 4, "\"units\": expected a string"},
      {with("\"standard_error\": {", "\"standard_error\": 5, \"x\": {"), 4,
       "\"standard_error\": expected an object"},
      {with("\"ini_sha256\": \"", "\"ini_sha256\": 5, \"y\": \""), 4,
       "\"ini_sha256\": expected a string"},
      {with("\"plane\": \"XY\"", "\"plane\": \"X\xff\""), 4, "\"plane\": not JSON"},
      {with("\"scale_ppm\": {", "\"scale_ppm\": [1], \"z\": {"), 4,
       "\"scale_ppm\": expected an object"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.words);
    expect_refused(
        [&] {
          return circcomp({"plan", "--ini", ini_, c.path});
        },
        c.code, c.path + ": " + c.words);
    // The message quotes no byte that is not printable ASCII (the invalid UTF-8 as \xff).
    const CommandResult r = circcomp({"plan", "--ini", ini_, c.path});
    EXPECT_TRUE(std::all_of(r.err.begin(), r.err.end() - 1, [](char ch) {
      return ch >= 0x20 && ch < 0x7f;
    })) << r.err;
  }
  // Deeply nested, huge, endless.
  const std::string deep = (top() / "diagnoses" / "deep.json").string();
  spit(deep, "{\"schema\": " + std::string(100000, '[') + std::string(100000, ']') + "}");
  expect_refused(
      [&] {
        return circcomp({"plan", "--ini", ini_, deep});
      },
      4, "nested deeper than 16 levels");
  const std::string huge = (top() / "diagnoses" / "huge.json").string();
  spit(huge, "{\"notes\": \"" + std::string(5 << 20, 'x') + "\"}");
  expect_refused(
      [&] {
        return circcomp({"plan", "--ini", ini_, huge});
      },
      3, "larger than the limit of 4 MiB");
  expect_refused(
      [&] {
        return circcomp({"plan", "--ini", ini_, "/dev/zero"});
      },
      3, "/dev/zero: is a character device");
  const std::string fine = diagnosis();
  expect_refused(
      [&] {
        return circcomp({"plan", "--ini", "/dev/zero", fine});
      },
      3, "/dev/zero: not a regular file");
}

TEST_F(Hostile, IniIncludesThatFailAreErrors) {
  struct Case {
    std::string include;
    int code;
    std::string words;
  };
  spit(cfg_ / "nested.inc", "[EMC]\n#INCLUDE other.inc\n");
  spit(cfg_ / "ok.inc", "[EMC]\nMACHINE = m\n");
  // The line after kMachineIni's last.
  const std::string at =
      "m.ini:" +
      std::to_string(std::count(kMachineIni, kMachineIni + std::strlen(kMachineIni), '\n') + 1);
  const std::string next = "m.ini:" + std::to_string(std::stoi(at.substr(6)) + 1);
  const std::vector<Case> cases = {
      {"#INCLUDE missing.inc\n", 3, at + ": #INCLUDE missing.inc: "},
      {"#INCLUDE\n", 4, at + ": #INCLUDE without a file name"},
      {"#INCLUDE m.ini\n", 4, at + ": #INCLUDE m.ini: includes the INI itself"},
      {"#INCLUDE ok.inc\n#INCLUDE ok.inc\n", 4,
       next + ": #INCLUDE ok.inc: includes a file already included"},
      {"#INCLUDE nested.inc\n", 4, "nested.inc:2: #INCLUDE inside an included file"},
      {"#INCLUDE ../victimdir\n", 3, at + ": #INCLUDE ../victimdir: "},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.include);
    spit(ini_, std::string(kMachineIni) + c.include);
    const std::string text = slurp(ini_);
    for (const auto& args : std::vector<std::vector<std::string>>{
             {CIRCTEST_INI_PATH, "get", ini_, "TRAJ", "LINEAR_UNITS"},
             {CIRCTEST_INI_PATH, "set", ini_, "TRAJ", "LINEAR_UNITS", "inch"}}) {
      expect_refused([&] { return run_command(args); }, c.code, c.words);
    }
    expect_refused([&] { return circcomp({"plan", "--ini", ini_, diagnosis()}); }, c.code, c.words);
    EXPECT_EQ(slurp(ini_), text);
  }
}

TEST_F(Hostile, CirctestIniSetArgumentsAreUsageErrors) {
  for (const auto& [section, key, value] :
       std::vector<std::array<std::string, 3>>{{"TRAJ", "A=B", "1"},
                                               {"TRAJ", "A B", "1"},
                                               {"TRAJ", "K", "two\nlines"},
                                               {"TRAJ", "K", "continued\\"},
                                               {"TR]AJ", "K", "1"},
                                               {"TRAJ\n[X", "K", "1"},
                                               {"", "K", "1"}}) {
    SCOPED_TRACE(section + " " + key + " " + value);
    const Snapshot before = snapshot(top(), "");
    const CommandResult r = run_command({CIRCTEST_INI_PATH, "set", ini_, section, key, value});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("circtest-ini: error: set: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("usage: circtest-ini"), std::string::npos) << r.err;
    EXPECT_EQ(changes(before, snapshot(top(), "")), "");
  }
  EXPECT_EQ(slurp(ini_), kMachineIni);
}

TEST_F(Hostile, FrictionWiringThatCannotBeSplicedIsRefused) {
  const std::string servo_hal =
      "loadrt trivkins coordinates=XYZ\nloadrt motmod\nloadrt pid names=pid.x,pid.y\n"
      "addf motion-command-handler servo-thread\naddf motion-controller servo-thread\n"
      "net x-pos-cmd joint.0.motor-pos-cmd => pid.x.command\n"
      "net y-pos-cmd joint.1.motor-pos-cmd => pid.y.command\n";
  spit(cfg_ / "mill.hal", servo_hal);
  spit(top() / "circfric.so", "");
  auto fric = [&](const std::string& diagnosis_path) {
    return run_command(
        {CIRCCOMP_PATH, "apply", "--ini", ini_, diagnosis_path, "--only", "friction"},
        {"CIRCTEST_FRIC_MODULE=" + (top() / "circfric.so").string()});
  };
  const std::string spike = R"(, "reversal_spike_mm": {"X": 0.004, "Y": null},
      "reversal_spike_ms": {"X": 20.0, "Y": null})";
  auto refused = [&](int code, const std::string& words) {
    const Snapshot before = snapshot(top(), "");
    const CommandResult r = fric(diagnosis(0.0, spike));
    EXPECT_EQ(r.exit_code, code) << r.err << r.out;
    EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
    EXPECT_EQ(changes(before, snapshot(top(), "")), "") << r.err;  // inside cfg/ too
  };
  // No motion-controller in any thread.
  spit(cfg_ / "mill.hal", "loadrt trivkins coordinates=XYZ\nloadrt motmod\n");
  refused(5, "m.ini:10: no HAL file read");
  // The command a literal; the joint's command to something that is no pid.
  std::string hal = servo_hal;
  hal.replace(hal.find("net x-pos-cmd joint.0.motor-pos-cmd => pid.x.command"), 53,
              "setp pid.x.command 0");
  spit(cfg_ / "mill.hal", hal);
  refused(5, "mill.hal:6: pid.x.command is a literal (setp)");
  hal = servo_hal;
  hal.replace(hal.find("=> pid.x.command"), 16, "=> offset.0.in");
  spit(cfg_ / "mill.hal", hal);
  refused(5, "mill.hal:6: signal x-pos-cmd carries joint.0.motor-pos-cmd (axis X) to offset.0.in");
  // Not asked for by name, friction that cannot be wired is a note: the other corrections go on.
  const CommandResult plain =
      run_command({CIRCCOMP_PATH, "plan", "--ini", ini_, diagnosis(0.0, spike)});
  EXPECT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_NE(plain.out.find("# note: friction compensation not planned: "), std::string::npos)
      << plain.out;
  EXPECT_NE(plain.out.find("to offset.0.in"), std::string::npos) << plain.out;
  // Nonsense in a HAL command: the file and line, exit 4.
  spit(cfg_ / "mill.hal", servo_hal + "net\n");
  refused(4, "mill.hal:8: expected 'net SIGNAL PIN...'");
  spit(cfg_ / "mill.hal", servo_hal + "addf pid.x.do-pid-calcs servo-thread 1e300\n");
  refused(4, "mill.hal:8: addf pid.x.do-pid-calcs servo-thread 1e300: expected a position");
  // The HAL file a FIFO: never opened (it would block).
  fs::remove(cfg_ / "mill.hal");
  ASSERT_EQ(::mkfifo((cfg_ / "mill.hal").c_str(), 0644), 0);
  refused(3, "is a FIFO");
  fs::remove(cfg_ / "mill.hal");
  spit(cfg_ / "mill.hal", servo_hal);
  // circtest-fric.hal a link out of the configuration, or a stranger's file.
  fs::create_symlink(top() / "victim.txt", cfg_ / "circtest-fric.hal");
  refused(12, "circtest-fric.hal: is a symbolic link");
  fs::remove(cfg_ / "circtest-fric.hal");
  spit(cfg_ / "circtest-fric.hal", "# mine\n");
  refused(5, "circtest-fric.hal: exists but is not [HAL] HALFILE and not circcomp's");
  fs::remove(cfg_ / "circtest-fric.hal");
  // No circfric.so where the run loads it.
  const std::string missing = (top() / "nowhere" / "circfric.so").string();
  const Snapshot before = snapshot(top(), "");
  const CommandResult r =
      run_command({CIRCCOMP_PATH, "apply", "--ini", ini_, diagnosis(0.0, spike)},
                  {"CIRCTEST_FRIC_MODULE=" + missing});
  EXPECT_EQ(r.exit_code, 7) << r.err;
  EXPECT_NE(r.err.find(missing + " is not there (CIRCTEST_FRIC_MODULE)"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("--only backlash,scale,squareness,cyclic"), std::string::npos) << r.err;
  EXPECT_EQ(changes(before, snapshot(top(), "")), "");
  // And the same configuration applies and reverts cleanly with the module there.
  const CommandResult ok = fric(diagnosis(0.0, spike));
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(slurp(cfg_ / "circtest-fric.hal").find("unlinkp pid.x.command\n"), std::string::npos);
  EXPECT_EQ(revert().exit_code, 0);
  EXPECT_EQ(slurp(ini_), kMachineIni);
  EXPECT_FALSE(fs::exists(cfg_ / "circtest-fric.hal"));
}

// A diagnosis that is a named FIFO: refused at once (a FIFO without a writer would block the
// read), not waited on; "timeout" stops a hang with 124.
TEST_F(Hostile, ADiagnosisThatIsAFifoIsRefusedWithoutWaiting) {
  const fs::path fifo = top() / "diagnosis.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  for (const char* command : {"plan", "apply"}) {
    SCOPED_TRACE(command);
    const CommandResult r = run_command(
        {"/usr/bin/timeout", "20", CIRCCOMP_PATH, command, "--ini", ini_, fifo.string()},
        {"CIRCTEST_KINS_MODULE=" + (top() / "circtest_kins.so").string()});
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_NE(r.err.find(fifo.string() + ": is a FIFO, not a regular file"), std::string::npos)
        << r.err;
  }
  EXPECT_EQ(slurp(ini_), kMachineIni);
}

// Each command's --help lists what that command accepts, and the command refuses the rest.
TEST_F(Hostile, EachCommandsHelpListsOnlyItsOptions) {
  const CommandResult revert_help = circcomp({"revert", "--help"});
  EXPECT_EQ(revert_help.exit_code, 0);
  EXPECT_EQ(revert_help.out.find("--only"), std::string::npos) << revert_help.out;
  EXPECT_EQ(revert_help.out.find("--gain"), std::string::npos) << revert_help.out;
  EXPECT_NE(revert_help.out.find("--to last|as-found"), std::string::npos) << revert_help.out;
  const CommandResult apply_help = circcomp({"apply", "--help"});
  EXPECT_EQ(apply_help.out.find("--json"), std::string::npos) << apply_help.out;
  EXPECT_EQ(apply_help.out.find("--to"), std::string::npos) << apply_help.out;
  EXPECT_NE(apply_help.out.find("--gain F"), std::string::npos) << apply_help.out;
  const CommandResult plan_help = circcomp({"plan", "--help"});
  EXPECT_NE(plan_help.out.find("--json"), std::string::npos) << plan_help.out;
  EXPECT_EQ(plan_help.out.find("revert"), std::string::npos) << plan_help.out;
  expect_refused(
      [&] {
        return revert({"--only", "backlash"});
      },
      2, "--only: only for plan and apply");
  expect_refused([&] { return revert({"--gain", "0.5"}); }, 2, "--gain: only for plan and apply");
}

// An option out of its range is a usage error before any file is read: a bad --gain with a
// diagnosis that is not there says the gain (exit 2), not the missing file (exit 3).
TEST_F(Hostile, AGainOutOfRangeIsRefusedBeforeAnyFileIsRead) {
  for (const char* command : {"plan", "apply"}) {
    for (const char* gain : {"0", "1.5", "-1"}) {
      SCOPED_TRACE(std::string(command) + " --gain " + gain);
      const CommandResult r =
          circcomp({command, "--ini", ini_, (top() / "nope.json").string(), "--gain", gain});
      EXPECT_EQ(r.exit_code, 2) << r.err;
      EXPECT_NE(r.err.find("--gain: expected 0 < F <= 1"), std::string::npos) << r.err;
    }
  }
  EXPECT_EQ(slurp(ini_), kMachineIni);
}
