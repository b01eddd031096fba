// circcomp and circtest-ini on what a careless or hostile user can put next to a machine's
// configuration: manifests that name files outside it, symbolic links, FIFOs and folders where
// files belong, a configuration that includes or names files elsewhere, numbers that would
// size a table beyond any machine (inputs that are not what they should be:
// test_hostile_circcomp_inputs.cpp). Every case runs the real programs and checks the exit code,
// the words of the refusal, and that no byte and no modification time outside the configuration
// changed.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hostile_circcomp_fixture.hpp"

TEST_F(Hostile, RevertTouchesNothingAManifestNamesOutside) {
  const std::string victim = (top() / "victim.txt").string();
  const std::string s = sha("x");
  const std::vector<std::pair<std::string, std::string>> manifests = {
      // version 1: absolute paths outside, an original named with ../
      {"circcomp-manifest 1\ncreated\t-\t" + victim + "\n", "not a path inside"},
      {"circcomp-manifest 1\nexisted\tx.orig\t" + (top() / "other" / "m.ini").string() + "\n",
       "not a path inside"},
      {"circcomp-manifest 1\nexisted\t../../victim.txt\t" + ini_ + "\n", "'..' component"},
      {"circcomp-manifest 1\ncreated\t-\t" + (cfg_ / ".." / "victim.txt").string() + "\n",
       "not a path inside"},
      // version 2: names must be plain relative names
      {"circcomp-manifest 2\nlast\tcreated\t" + victim + "\t-\t" + s + "\n", "absolute path"},
      {"circcomp-manifest 2\nlast\tcreated\t../victim.txt\t-\t" + s + "\n", "'..' component"},
      {"circcomp-manifest 2\nlast\tcreated\tsub/../../victim.txt\t-\t" + s + "\n",
       "'..' component"},
      {"circcomp-manifest 2\nlast\texisted\tm.ini\t../../victim.txt\t" + s + "\n",
       "'..' component"},
      {"circcomp-manifest 2\nlast\texisted\tm.ini\tsub/x.orig\t" + s + "\n", "NAME.orig"},
  };
  for (const auto& [manifest, words] : manifests) {
    SCOPED_TRACE(manifest);
    write_manifest(manifest);
    const std::string ini_before = slurp(ini_);
    expect_refused([&] { return revert(); }, 12, words);
    expect_refused([&] { return revert({"--to", "as-found", "--force"}); }, 12, words);
    EXPECT_EQ(slurp(ini_), ini_before);
    // apply reads the manifest it extends: refused the same way, nothing written.
    expect_refused([&] { return apply(diagnosis()); }, 12, words);
    EXPECT_EQ(slurp(ini_), ini_before);
  }
}

TEST_F(Hostile, NoLinkIsFollowedOutOfTheConfiguration) {
  // A .circcomp that is a link into an /etc-like folder: apply and revert refuse it.
  fs::create_directory_symlink(top() / "etc", cfg_ / ".circcomp");
  expect_refused([&] { return apply(diagnosis()); }, 12, "is a symbolic link");
  expect_refused([&] { return revert(); }, 12, "is a symbolic link");
  EXPECT_EQ(slurp(ini_), kMachineIni);
  fs::remove(cfg_ / ".circcomp");

  // The manifest, or an original it names, a link to a file outside.
  fs::create_directories(cfg_ / ".circcomp");
  spit(top() / "etc" / "fake-manifest",
       "circcomp-manifest 2\nlast\tcreated\tnew.comp\t-\t" + sha("") + "\n");
  fs::create_symlink(top() / "etc" / "fake-manifest", cfg_ / ".circcomp" / "manifest");
  expect_refused([&] { return revert(); }, 12, "is a symbolic link");
  fs::remove(cfg_ / ".circcomp" / "manifest");
  fs::create_symlink(top() / "victim.txt", cfg_ / ".circcomp" / "a.orig");
  write_manifest("circcomp-manifest 2\nlast\texisted\tm.ini\ta.orig\t" + sha(kMachineIni) + "\n");
  expect_refused([&] { return revert(); }, 12, "a.orig: is a symbolic link");
  fs::remove_all(cfg_ / ".circcomp");

  // A file the plan changes that is a link (to a file outside): the HAL file that loads the
  // kinematics, and a COMP_FILE.
  fs::rename(cfg_ / "mill.hal", top() / "etc" / "mill.hal");
  fs::create_symlink(top() / "etc" / "mill.hal", cfg_ / "mill.hal");
  expect_refused(
      [&] {
        return circcomp({"plan", "--ini", ini_, diagnosis(100.0)});
      },
      12, "mill.hal: is a symbolic link");
  expect_refused([&] { return apply(diagnosis(100.0)); }, 12, "mill.hal: is a symbolic link");
  EXPECT_FALSE(fs::exists(cfg_ / ".circcomp"));
  EXPECT_EQ(slurp(ini_), kMachineIni);

  // A folder on the way that is a link out of the configuration.
  fs::create_directory_symlink(top() / "etc", cfg_ / "tables");
  spit(top() / "etc" / "x.comp", "-300 0 0\n300 0 0\n");
  std::string text = kMachineIni;
  text.replace(text.find("BACKLASH = 0.008\n"), 17,
               "COMP_FILE = tables/x.comp\nCOMP_FILE_TYPE = 1\n");
  spit(ini_, text);
  expect_refused([&] { return apply(diagnosis()); }, 12, "outside the configuration directory");
  EXPECT_EQ(slurp(ini_), text);
}

TEST_F(Hostile, FilesOutsideTheConfigurationAreReadNeverWritten) {
  // A COMP_FILE named outside (../) and one by an absolute path.
  spit(top() / "victim.comp", "-300 0 0\n300 0 0\n");
  for (const std::string& name :
       {std::string("../victim.comp"), (top() / "victim.comp").string()}) {
    std::string text = kMachineIni;
    text.replace(text.find("BACKLASH = 0.008\n"), 17,
                 "COMP_FILE = " + name + "\nCOMP_FILE_TYPE = 1\n");
    spit(ini_, text);
    expect_refused(
        [&] {
          return circcomp({"plan", "--ini", ini_, diagnosis()});
        },
        12, "outside the configuration directory");
    expect_refused([&] { return apply(diagnosis()); }, 12, "outside the configuration directory");
    EXPECT_EQ(slurp(ini_), text);
  }
  // A HAL file outside that loads trivkins, which squareness would switch to circtest_kins.
  spit(top() / "shared.hal", "loadrt trivkins coordinates=XYZ\n");
  std::string hal = kMachineIni;
  hal.replace(hal.find("HALFILE = mill.hal"), 18, "HALFILE = ../shared.hal");
  spit(ini_, hal);
  expect_refused([&] { return apply(diagnosis(100.0)); }, 12,
                 "shared.hal: outside the configuration directory");
  EXPECT_EQ(slurp(ini_), hal);
  // An #INCLUDE outside holding the joint circcomp would change: refused; one holding only
  // what circcomp reads: the plan goes ahead.
  spit(top() / "joints.inc", "[JOINT_0]\nMIN_LIMIT = -300\nMAX_LIMIT = 300\nBACKLASH = 0.008\n");
  std::string text = kMachineIni;
  text.replace(text.find("[JOINT_0]"), text.find("[JOINT_1]") - text.find("[JOINT_0]"),
               "#INCLUDE ../joints.inc\n");
  spit(ini_, text);
  expect_refused([&] { return apply(diagnosis()); }, 12, "joints.inc: outside the configuration");
  spit(top() / "units.inc", "[EMC]\nMACHINE = hostile\n");
  spit(ini_, std::string(kMachineIni) + "#INCLUDE ../units.inc\n");
  const CommandResult r = circcomp({"plan", "--ini", ini_, diagnosis()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

TEST_F(Hostile, AFifoOrAFolderWhereAFileBelongs) {
  ASSERT_EQ(::mkfifo((cfg_ / "fifo.comp").c_str(), 0644), 0);
  fs::create_directories(cfg_ / "dir.comp");
  spit(cfg_ / "dir.comp" / "keep", "keep\n");
  fs::create_symlink(top() / "victim.txt", cfg_ / "link.comp");
  for (const std::string name : {"fifo.comp", "dir.comp", "link.comp"}) {
    SCOPED_TRACE(name);
    // As a COMP_FILE: refused before it is opened (a FIFO would block the plan).
    std::string text = kMachineIni;
    text.replace(text.find("BACKLASH = 0.008\n"), 17,
                 "COMP_FILE = " + name + "\nCOMP_FILE_TYPE = 1\n");
    spit(ini_, text);
    expect_refused([&] { return apply(diagnosis()); }, 12, name + ": is a");
    spit(ini_, kMachineIni);
    // Named by a manifest as a file circcomp created, or restored.
    write_manifest("circcomp-manifest 2\nlast\tcreated\t" + name + "\t-\t" + sha("") + "\n");
    expect_refused([&] { return revert({"--force"}); }, 12, name + ": is a");
    spit(cfg_ / ".circcomp" / "a.orig", "x\n");
    write_manifest("circcomp-manifest 2\nlast\texisted\t" + name + "\ta.orig\t" + sha("") + "\n");
    expect_refused([&] { return revert({"--force"}); }, 12, name + ": is a");
    fs::remove_all(cfg_ / ".circcomp");
  }
  EXPECT_TRUE(fs::is_fifo(cfg_ / "fifo.comp"));
  EXPECT_TRUE(fs::is_symlink(cfg_ / "link.comp"));
  EXPECT_EQ(slurp(cfg_ / "dir.comp" / "keep"), "keep\n");
}

TEST_F(Hostile, RevertRefusesAFileEditedSinceApplyUnlessForced) {
  ASSERT_EQ(apply(diagnosis()).exit_code, 0);
  const std::string applied = slurp(ini_);
  spit(ini_, applied + "# the customer's own edit\n");
  const CommandResult r = revert();
  EXPECT_EQ(r.exit_code, 10) << r.err;
  EXPECT_NE(r.err.find("m.ini: changed since circcomp wrote it"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--force"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(ini_), applied + "# the customer's own edit\n");  // nothing reverted
  EXPECT_TRUE(fs::exists(cfg_ / "circtest-joint0.comp"));
  EXPECT_EQ(revert({"--force"}).exit_code, 0);
  EXPECT_EQ(slurp(ini_), kMachineIni);
  EXPECT_FALSE(fs::exists(cfg_ / "circtest-joint0.comp"));
  EXPECT_FALSE(fs::exists(cfg_ / ".circcomp"));
}

TEST_F(Hostile, RevertToAsFoundUndoesEveryApplyInOneStep) {
  const std::string hal = slurp(cfg_ / "mill.hal");
  ASSERT_EQ(apply(diagnosis()).exit_code, 0);  // backlash and scale: the INI and a table
  const std::string after_one = slurp(ini_);
  const CommandResult two = apply(diagnosis(80.0));  // squareness, measured after apply 1
  ASSERT_EQ(two.exit_code, 0) << two.err;
  ASSERT_EQ(apply(diagnosis(-5.0)).exit_code, 0);  // and a third
  // The plain revert undoes the last apply only, and says the earlier ones remain.
  CommandResult r = revert();
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("--to as-found"), std::string::npos) << r.out;
  r = revert({"--to", "as-found"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("as found before the first apply"), std::string::npos) << r.out;
  EXPECT_EQ(slurp(ini_), kMachineIni);
  EXPECT_EQ(slurp(cfg_ / "mill.hal"), hal);
  EXPECT_FALSE(fs::exists(cfg_ / "circtest-joint0.comp"));
  EXPECT_FALSE(fs::exists(cfg_ / "circtest-comp.hal"));
  EXPECT_FALSE(fs::exists(cfg_ / ".circcomp"));
  // Without the plain revert in between, and after it a plain revert is nothing to do.
  ASSERT_EQ(apply(diagnosis()).exit_code, 0);
  ASSERT_EQ(slurp(ini_), after_one);
  ASSERT_EQ(apply(diagnosis(80.0)).exit_code, 0);
  EXPECT_EQ(revert({"--to", "as-found"}).exit_code, 0);
  EXPECT_EQ(slurp(ini_), kMachineIni);
  EXPECT_NE(revert().out.find("nothing to revert"), std::string::npos);
  EXPECT_EQ(circcomp({"revert", "--ini", ini_, "--to", "first"}).exit_code, 2);
}

TEST_F(Hostile, ApplyRefusesWithoutTheKinematicsModule) {
  const std::string d = diagnosis(100.0);
  const std::string missing = (top() / "nowhere" / "circtest_kins.so").string();
  const Snapshot before = snapshot(top(), "");
  CommandResult r =
      run_command({CIRCCOMP_PATH, "apply", "--ini", ini_, d}, {"CIRCTEST_KINS_MODULE=" + missing});
  EXPECT_EQ(r.exit_code, 7) << r.err;
  EXPECT_NE(r.err.find(missing + " is not there (CIRCTEST_KINS_MODULE)"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("--only backlash,scale,cyclic"), std::string::npos) << r.err;
  EXPECT_EQ(changes(before, snapshot(top(), "")),
            "");  // nothing at all, inside the configuration too
  // plan says so; a plan without squareness needs no module.
  r = run_command({CIRCCOMP_PATH, "plan", "--ini", ini_, d}, {"CIRCTEST_KINS_MODULE=" + missing});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("# note: apply will refuse (exit 7)"), std::string::npos) << r.out;
  r = run_command({CIRCCOMP_PATH, "apply", "--ini", ini_, d, "--only", "backlash,scale"},
                  {"CIRCTEST_KINS_MODULE=" + missing});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  // Without the variable: where LinuxCNC's loadrt looks (unless it is installed there).
  if (!fs::exists("/usr/lib/linuxcnc/modules/circtest_kins.so")) {
    r = run_command({CIRCCOMP_PATH, "apply", "--ini", ini_, diagnosis(100.0)},
                    {"CIRCTEST_KINS_MODULE="});
    EXPECT_EQ(r.exit_code, 7) << r.err;
    EXPECT_NE(r.err.find("circtest_kins.so is not there (where LinuxCNC's loadrt looks"),
              std::string::npos)
        << r.err;
  }
}

TEST_F(Hostile, NumbersThatSizeATableAreRangeChecked) {
  // A cyclic pitch of 1e-200 mm: no table of 1e200 points, no garbage.
  const std::string tiny = diagnosis(
      0.0, R"(, "cyclic": {"X": {"amplitude_mm": 0.002, "pitch_mm": 1e-200, "phase_rad": 0}})");
  expect_refused([&] { return apply(tiny); }, 5, "\"cyclic.X.pitch_mm\": 1e-200 mm");
  expect_refused([&] { return apply(tiny); }, 5, "expected 0.001 to 10000 mm");
  EXPECT_EQ(slurp(ini_), kMachineIni);
  // A travel of LinuxCNC's "no limit" default: no table over it.
  std::string text = kMachineIni;
  text.replace(text.find("MIN_LIMIT = -300"), 16, "MIN_LIMIT = -1e99");
  spit(ini_, text);
  expect_refused([&] { return apply(diagnosis()); }, 5, "MIN_LIMIT = -1e99");
  EXPECT_EQ(slurp(ini_), text);
  // Units per mm that are no unit.
  text = kMachineIni;
  text.replace(text.find("LINEAR_UNITS = mm"), 17, "LINEAR_UNITS = 1e-300");
  spit(ini_, text);
  expect_refused([&] { return apply(diagnosis()); }, 5, "LINEAR_UNITS = 1e-300");
}

TEST_F(Hostile, AVersionOneManifestInsideIsStillReverted) {
  // What an earlier circcomp left: absolute paths inside the configuration, no checksums.
  fs::create_directories(cfg_ / ".circcomp");
  spit(cfg_ / ".circcomp" / "1a-2b-0.orig", kMachineIni);
  spit(ini_, std::string(kMachineIni) + "[CIRCTEST_COMP]\nSQUARENESS_XY = 1e-4\n");
  spit(cfg_ / "circtest-comp.hal", "setp circtest-kins.squareness-xy 1e-4\n");
  write_manifest("circcomp-manifest 1\nexisted\t1a-2b-0.orig\t" + ini_ + "\ncreated\t-\t" +
                 (cfg_ / "circtest-comp.hal").string() + "\n");
  const CommandResult r = revert();
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(slurp(ini_), kMachineIni);
  EXPECT_FALSE(fs::exists(cfg_ / "circtest-comp.hal"));
  EXPECT_FALSE(fs::exists(cfg_ / ".circcomp"));
}

TEST_F(Hostile, OneFileUnderTwoNamesIsRefused) {
  // Two joints whose COMP_FILEs are one file by two spellings: two plans for one file, and a
  // manifest naming it twice, would follow.
  spit(cfg_ / "x.comp", "-300 0 0\n300 0 0\n");
  std::string text = kMachineIni;
  text.replace(text.find("BACKLASH = 0.008\n"), 17, "COMP_FILE = x.comp\nCOMP_FILE_TYPE = 1\n");
  text.replace(text.find("BACKLASH = 0.008\n"), 17, "COMP_FILE = ./x.comp\nCOMP_FILE_TYPE = 1\n");
  spit(ini_, text);
  std::string d = slurp(diagnosis());
  d.replace(d.find("\"Y\": 0.0}"), 9, "\"Y\": 0.003}");
  const std::string path = (top() / "diagnoses" / "both.json").string();
  spit(path, d);
  expect_refused([&] { return apply(path); }, 5, "are the same file");
  EXPECT_EQ(slurp(ini_), text);
  EXPECT_EQ(slurp(cfg_ / "x.comp"), "-300 0 0\n300 0 0\n");
}

// Friction compensation (circfric): a HAL that circcomp cannot splice, a HAL file that is not
// a file, circcomp's own HAL file name taken by a link or by a stranger, nonsense in a HAL
// command, and no circfric.so: each refused with its code, nothing touched anywhere.
