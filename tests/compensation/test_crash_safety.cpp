// circcomp apply SIGKILLed after each of its steps (CIRCCOMP_KILL_AFTER_STEP: the process
// kills itself with SIGKILL there, so nothing of it runs afterwards, as in a power cut): every
// configuration file is then wholly the old or wholly the new version, no temporary is left,
// and circcomp revert restores the state before the apply byte-identical. The hook is only in
// circcomp-crash-test (the same main.cpp built with CIRCCOMP_CRASH_TEST); the installed
// circcomp ignores the variable.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/sha256.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;
using namespace circtest;
using circtest::testing::spit;

namespace {

using Tree = std::map<std::string, std::string>;  // relative path -> content

// The configuration's files (the .circcomp state folder apart).
Tree tree_of(const fs::path& dir) {
  Tree t;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string rel = fs::relative(e.path(), dir).string();
    if (rel.starts_with(".circcomp")) continue;
    if (e.is_regular_file()) t[rel] = read_file(e.path().string());
  }
  return t;
}

// A mill with a HAL file that loads trivkins by name: a backlash, a scale table and the
// squareness change four files (INI and HAL changed, a COMP_FILE and circtest-comp.hal created).
void make_machine(const fs::path& dir) {
  fs::create_directories(dir);
  std::string ini =
      "[TRAJ]\nCOORDINATES = X Y Z\nLINEAR_UNITS = mm\n\n[KINS]\nKINEMATICS = trivkins "
      "coordinates=XYZ\nJOINTS = 3\n\n[HAL]\nHALFILE = mill.hal\n\n";
  for (int j = 0; j < 3; ++j) {
    ini += "[JOINT_" + std::to_string(j) +
           "]\nTYPE = LINEAR\nMIN_LIMIT = -300\nMAX_LIMIT = 300\nBACKLASH = 0.008\n\n";
  }
  spit(dir / "m.ini", ini);
  spit(dir / "mill.hal", "loadrt trivkins coordinates=XYZ\nloadrt motmod\n");
}

std::string diagnosis_for(const fs::path& ini, double squareness_urad, bool with_scale) {
  std::string scale = with_scale ? R"("scale_ppm": {"X": 40.0, "Y": 0.0},)"
                                 : R"("scale_ppm": {"X": 0.0, "Y": 0.0},)";
  return R"({"schema": "circtest.diagnosis/1", "units": "mm", "plane": "XY", "axes": ["X", "Y"],
    "backlash_mm": {"X": 0.002, "Y": 0.0}, )" +
         scale + R"( "squareness_urad": )" + std::to_string(squareness_urad) + R"(,
    "standard_error": {"backlash_mm": {"X": 1e-5, "Y": 1e-5}, "scale_ppm": {"X": 0.5, "Y": 0.5},
                       "squareness_urad": 0.5},
    "ini_sha256": ")" +
         sha256_hex(read_file(ini.string())) + "\"}";
}

struct Outcome {
  bool killed = false;
  int exit_code = -1;
  std::string err;
};

// K >= 0: circcomp-crash-test kills itself after step K; K < 0: a complete run. PROGRAM: the
// program run, the crash test's build unless said.
Outcome apply(const fs::path& dir, const fs::path& diagnosis, long kill_after,
              const char* program = CIRCCOMP_CRASH_TEST_PATH) {
  const fs::path err = dir.parent_path() / (dir.filename().string() + ".err");
  std::string cmd;
  if (kill_after >= 0) cmd = "CIRCCOMP_KILL_AFTER_STEP=" + std::to_string(kill_after) + " ";
  cmd += std::string(program) + " apply --ini " + (dir / "m.ini").string() + " " +
         diagnosis.string() + " >/dev/null 2>" + err.string();
  const int status = std::system(cmd.c_str());
  Outcome o;
  // system() runs sh -c; a child killed by a signal shows as 128 + signal in sh's status.
  o.killed = WIFEXITED(status) && WEXITSTATUS(status) == 128 + SIGKILL;
  o.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  o.err = read_file(err.string());
  return o;
}

int revert(const fs::path& dir, long kill_after = -1) {
  std::string cmd;
  if (kill_after >= 0) cmd = "CIRCCOMP_KILL_AFTER_STEP=" + std::to_string(kill_after) + " ";
  cmd += std::string(CIRCCOMP_CRASH_TEST_PATH) + " revert --ini " + (dir / "m.ini").string() +
         " >/dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Every file of NOW is OLD's or NEW's version of it; created files are absent or whole.
void expect_whole(const Tree& now, const Tree& old_tree, const Tree& new_tree, long k) {
  for (const auto& [name, text] : now) {
    const auto o = old_tree.find(name), n = new_tree.find(name);
    ASSERT_TRUE(o != old_tree.end() || n != new_tree.end())
        << "step " << k << ": a file neither version has: " << name;
    EXPECT_TRUE((o != old_tree.end() && o->second == text) ||
                (n != new_tree.end() && n->second == text))
        << "step " << k << ": " << name << " is torn";
  }
  for (const auto& [name, text] : old_tree) {
    EXPECT_TRUE(now.count(name)) << "step " << k << ": " << name << " disappeared";
  }
}

// Only the manifest, originals and the lock in the state folder: no temporary of any write.
void expect_no_temporaries(const fs::path& dir, long k) {
  const fs::path state = dir / ".circcomp";
  if (!fs::exists(state)) return;
  for (const auto& e : fs::directory_iterator(state)) {
    const std::string name = e.path().filename().string();
    EXPECT_TRUE(name == "manifest" || name == "lock" || name.ends_with(".orig"))
        << "step " << k << ": left behind: " << name;
  }
}

// "k7" (GCC 12 warns falsely on "k" + std::to_string(k), -Wrestrict).
std::string named(const char* prefix, long k) {
  std::string s(prefix);
  s += std::to_string(k);
  return s;
}

class CrashSafety : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("circcomp-crash-" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    // The squareness plans need circtest_kins where the run loads it (require_kins_module):
    // a stand-in file, named as circtest-run names the build tree's.
    spit(root_ / "circtest_kins.so", "");
    ::setenv("CIRCTEST_KINS_MODULE", (root_ / "circtest_kins.so").c_str(), 1);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(root_);
  }

  // A new machine in ROOT/NAME with one complete apply of a diagnosis (SQUARENESS_URAD, the
  // scale when WITH_SCALE): the folder and its files before and after.
  struct Applied {
    fs::path dir;
    Tree before, after;
  };
  Applied applied_machine(const std::string& name, double squareness_urad, bool with_scale) {
    Applied m{root_ / name, {}, {}};
    make_machine(m.dir);
    m.before = tree_of(m.dir);
    const fs::path diagnosis = root_ / (name + ".json");
    spit(diagnosis, diagnosis_for(m.dir / "m.ini", squareness_urad, with_scale));
    const Outcome o = apply(m.dir, diagnosis, -1);
    EXPECT_EQ(o.exit_code, 0) << o.err;
    m.after = tree_of(m.dir);
    return m;
  }

  fs::path root_;
};

}  // namespace

TEST_F(CrashSafety, KilledAtEveryStepOfAFirstApply) {
  // The new version: one complete apply.
  const Applied ref = applied_machine("ref", 100.0, true);
  ASSERT_FALSE(HasFailure());
  const Tree& old_tree = ref.before;
  const Tree& new_tree = ref.after;
  ASSERT_EQ(new_tree.size(), old_tree.size() + 2);  // the COMP_FILE and circtest-comp.hal
  for (const auto& [name, text] : old_tree) ASSERT_NE(new_tree.at(name), text) << name;

  long steps = 0;
  for (long k = 0; k < 100; ++k) {
    const fs::path dir = root_ / named("k", k);
    make_machine(dir);
    const fs::path diagnosis = root_ / (named("k", k) + ".json");
    spit(diagnosis, diagnosis_for(dir / "m.ini", 100.0, true));
    const Outcome o = apply(dir, diagnosis, k);
    if (!o.killed) {
      ASSERT_EQ(o.exit_code, 0) << o.err;  // K beyond the last step: a complete apply
      EXPECT_EQ(tree_of(dir), new_tree);
      steps = k;
      break;
    }
    EXPECT_NE(o.err.find("killed after step " + std::to_string(k)), std::string::npos) << o.err;
    expect_whole(tree_of(dir), old_tree, new_tree, k);
    expect_no_temporaries(dir, k);
    ASSERT_EQ(revert(dir), 0) << "step " << k;
    EXPECT_EQ(tree_of(dir), old_tree) << "step " << k << ": revert did not restore";
    EXPECT_FALSE(fs::exists(dir / ".circcomp")) << "step " << k;
    EXPECT_EQ(revert(dir), 0);  // a second revert: nothing to do
    EXPECT_EQ(tree_of(dir), old_tree);
  }
  // Two steps (temporary written, renamed) for each of 2 originals, the manifest, 4 files.
  EXPECT_EQ(steps, 2 * (2 + 1 + 4));
}

TEST_F(CrashSafety, KilledDuringASecondApplyKeepsTheFirstOnesOriginals) {
  // Apply 1 (backlash and scale) completes; apply 2 (squareness, measured after apply 1) is
  // killed. Revert undoes apply 2 when its manifest was in place, else apply 1: never a mix,
  // and never the originals of apply 1 lost to apply 2's backups.
  for (long k = 0; k < 100; ++k) {
    const Applied one = applied_machine(named("s", k), 0.0, true);
    ASSERT_FALSE(HasFailure());
    const fs::path& dir = one.dir;
    spit(root_ / "two.json", diagnosis_for(dir / "m.ini", 80.0, false));
    const Outcome o = apply(dir, root_ / "two.json", k);
    if (!o.killed) {
      ASSERT_EQ(o.exit_code, 0) << o.err;
      EXPECT_GT(k, 4);
      break;
    }
    expect_no_temporaries(dir, k);
    ASSERT_EQ(revert(dir), 0);
    // Before the new manifest is in place the steps are the originals and the manifest's
    // temporary; from then on revert undoes apply 2.
    const bool committed = o.err.find("original of") == std::string::npos &&
                           o.err.find("manifest: written") == std::string::npos;
    EXPECT_EQ(tree_of(dir), committed ? one.after : one.before)
        << "step " << k << " (" << o.err << ")";
  }
}

TEST_F(CrashSafety, KilledRevertIsFinishedByTheNextOne) {
  // A complete apply, then revert killed after each of its steps (each file restored or
  // removed, the manifest removed): every file whole, and a second revert ends at the state
  // before the apply.
  long steps = 0;
  for (long k = 0; k < 100; ++k) {
    const Applied m = applied_machine(named("r", k), 100.0, true);
    ASSERT_FALSE(HasFailure());
    const fs::path& dir = m.dir;
    const Tree& old_tree = m.before;
    const Tree& new_tree = m.after;
    const int rc = revert(dir, k);
    if (rc != 128 + SIGKILL) {
      ASSERT_EQ(rc, 0);
      EXPECT_EQ(tree_of(dir), old_tree);
      steps = k;
      break;
    }
    expect_whole(tree_of(dir), old_tree, new_tree, k);
    expect_no_temporaries(dir, k);
    ASSERT_EQ(revert(dir), 0) << "step " << k;
    EXPECT_EQ(tree_of(dir), old_tree) << "step " << k;
    EXPECT_FALSE(fs::exists(dir / ".circcomp")) << "step " << k;
  }
  EXPECT_EQ(steps, 4 + 1);  // four files, then the manifest
}

TEST_F(CrashSafety, TheInstalledCirccompHasNoKillHook) {
  // The variable that kills circcomp-crash-test after its first step does nothing to the
  // circcomp that is installed: the apply completes and writes the same files.
  const Applied ref = applied_machine("ref", 100.0, true);
  ASSERT_FALSE(HasFailure());
  const fs::path dir = root_ / "shipped";
  make_machine(dir);
  spit(root_ / "shipped.json", diagnosis_for(dir / "m.ini", 100.0, true));
  const Outcome o = apply(dir, root_ / "shipped.json", 0, CIRCCOMP_PATH);
  EXPECT_FALSE(o.killed) << o.err;
  EXPECT_EQ(o.exit_code, 0) << o.err;
  EXPECT_EQ(tree_of(dir), ref.after);
}

// Standard output and the commit (README, exit codes 3 and 13): what apply or revert will do
// is written before it starts, so a standard output that fails from the start (/dev/full)
// stops it with exit 3 and nothing changed; one that fails only after the commit (here:
// /dev/full from the commit's first step on) gives exit 13 and a stderr line saying the
// change IS made, with the configuration changed.
namespace {

struct ShellRun {
  int exit_code = -1;
  std::string err;
};

ShellRun run_shell(const std::string& cmd, const fs::path& err) {
  const int status = std::system((cmd + " 2>" + err.string()).c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_file(err.string())};
}

}  // namespace

TEST_F(CrashSafety, StandardOutputFailingBeforeTheCommitChangesNothing) {
  const fs::path dir = root_ / "full";
  make_machine(dir);
  const Tree before = tree_of(dir);
  const fs::path diagnosis = root_ / "full.json";
  spit(diagnosis, diagnosis_for(dir / "m.ini", 100.0, true));
  const std::string ini = (dir / "m.ini").string();
  const ShellRun a = run_shell(
      std::string(CIRCCOMP_PATH) + " apply --ini " + ini + " " + diagnosis.string() + " >/dev/full",
      root_ / "full.err");
  EXPECT_EQ(a.exit_code, 3) << a.err;
  EXPECT_NE(a.err.find("the apply not started, nothing changed"), std::string::npos) << a.err;
  EXPECT_EQ(tree_of(dir), before);
  EXPECT_FALSE(fs::exists(dir / ".circcomp" / "manifest"));
  // The same for revert: an applied configuration stays applied.
  const ShellRun applied = run_shell(
      std::string(CIRCCOMP_PATH) + " apply --ini " + ini + " " + diagnosis.string() + " >/dev/null",
      root_ / "full.err");
  ASSERT_EQ(applied.exit_code, 0) << applied.err;
  const Tree after = tree_of(dir);
  const ShellRun r = run_shell(std::string(CIRCCOMP_PATH) + " revert --ini " + ini + " >/dev/full",
                               root_ / "full.err");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("the revert not started, nothing changed"), std::string::npos) << r.err;
  EXPECT_EQ(tree_of(dir), after);
}

TEST_F(CrashSafety, StandardOutputFailingAfterTheCommitSaysTheChangeIsMade) {
  const Applied ref = applied_machine("ref", 100.0, true);
  ASSERT_FALSE(HasFailure());
  const fs::path dir = root_ / "late";
  make_machine(dir);
  const fs::path diagnosis = root_ / "late.json";
  spit(diagnosis, diagnosis_for(dir / "m.ini", 100.0, true));
  const std::string ini = (dir / "m.ini").string();
  const std::string late = "CIRCCOMP_FULL_STDOUT_AFTER_STEP=0 ";
  const ShellRun a = run_shell(late + CIRCCOMP_CRASH_TEST_PATH + " apply --ini " + ini + " " +
                                   diagnosis.string() + " >/dev/null",
                               root_ / "late.err");
  EXPECT_EQ(a.exit_code, 13) << a.err;
  EXPECT_NE(
      a.err.find("after the apply: the change IS made; undo it with: circcomp revert --ini " + ini),
      std::string::npos)
      << a.err;
  EXPECT_EQ(tree_of(dir), ref.after);
  const ShellRun r = run_shell(
      late + CIRCCOMP_CRASH_TEST_PATH + " revert --ini " + ini + " >/dev/null", root_ / "late.err");
  EXPECT_EQ(r.exit_code, 13) << r.err;
  EXPECT_NE(r.err.find("after the revert: the change IS made"), std::string::npos) << r.err;
  EXPECT_EQ(tree_of(dir), ref.before);
}

// Eight applies of one diagnosis started at once: exactly one changes the configuration, every
// other is refused (exit 10: the lock is held, or the INI is no longer the one measured or
// planned) and says why; the configuration is then the one apply's.
TEST_F(CrashSafety, ConcurrentAppliesOfOneDiagnosisOneWins) {
  const Applied ref = applied_machine("ref", 100.0, true);
  ASSERT_FALSE(HasFailure());
  for (int round = 0; round < 3; ++round) {
    const fs::path dir = root_ / named("race", round);
    make_machine(dir);
    const fs::path diagnosis = root_ / (named("race", round) + ".json");
    spit(diagnosis, diagnosis_for(dir / "m.ini", 100.0, true));
    std::string cmd = "cd " + root_.string() + " && for i in 1 2 3 4 5 6 7 8; do (" +
                      CIRCCOMP_PATH + " apply --ini " + (dir / "m.ini").string() + " " +
                      diagnosis.string() + " >/dev/null 2>" + dir.string() + ".err$i; echo $? >" +
                      dir.string() + ".rc$i) & done; wait";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    int won = 0;
    for (int i = 1; i <= 8; ++i) {
      const std::string rc = read_file(dir.string() + ".rc" + std::to_string(i));
      const std::string err = read_file(dir.string() + ".err" + std::to_string(i));
      if (rc == "0\n") {
        ++won;
        continue;
      }
      EXPECT_EQ(rc, "10\n") << err;
      EXPECT_TRUE(err.find("another circcomp apply or revert of this configuration is under "
                           "way") != std::string::npos ||
                  err.find("changed since") != std::string::npos ||
                  err.find("changed while circcomp planned") != std::string::npos)
          << err;
    }
    EXPECT_EQ(won, 1) << "round " << round;
    EXPECT_EQ(tree_of(dir), ref.after);
    ASSERT_EQ(revert(dir), 0);
    EXPECT_EQ(tree_of(dir), ref.before);
    EXPECT_FALSE(fs::exists(dir / ".circcomp"));
  }
}
