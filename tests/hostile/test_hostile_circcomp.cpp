// circcomp and circtest-ini on what a careless or hostile user can put next to a machine's
// configuration: manifests that name files outside it, symbolic links, FIFOs and folders where
// files belong, a configuration that includes or names files elsewhere, a diagnosis JSON
// that is not what circana writes, numbers that would size a table beyond any machine. Every
// case runs the real programs and checks the exit code, the words of the refusal, and that no
// byte and no modification time outside the configuration changed.
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

namespace fs = std::filesystem;

namespace {

using namespace circtest::testing;  // ScratchDir, slurp, spit, run_command

// What lies at a path, without following a link: kind, bytes (or link target) and mtime.
struct Seen {
  std::string kind;
  std::string content;
  long long mtime_ns = 0;
  bool operator==(const Seen&) const = default;
};
using Snapshot = std::map<std::string, Seen>;

// Everything below TOP but the folders SKIP and TOP/diagnoses (the tests' inputs).
Snapshot snapshot(const fs::path& top, const fs::path& skip) {
  Snapshot out;
  for (auto it = fs::recursive_directory_iterator(top); it != fs::recursive_directory_iterator();
       ++it) {
    const fs::path p = it->path();
    if (p == skip || p == top / "diagnoses") {
      it.disable_recursion_pending();
      continue;
    }
    struct stat st {};
    ::lstat(p.c_str(), &st);
    Seen s;
    s.mtime_ns = static_cast<long long>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec;
    if (S_ISLNK(st.st_mode)) {
      s.kind = "link";
      s.content = fs::read_symlink(p).string();
    } else if (S_ISREG(st.st_mode)) {
      s.kind = "file";
      s.content = slurp(p);
    } else if (S_ISDIR(st.st_mode)) {
      s.kind = "dir";
    } else {
      s.kind = "other";
    }
    out[p.string()] = s;
  }
  return out;
}

// The paths whose kind, content or mtime differ; "" when none.
std::string changes(const Snapshot& before, const Snapshot& after) {
  std::string out;
  for (const auto& [path, seen] : before) {
    const auto it = after.find(path);
    if (it == after.end()) {
      out += path + " removed\n";
    } else if (!(it->second == seen)) {
      out += path + (it->second.content == seen.content ? " touched\n" : " changed\n");
    }
  }
  for (const auto& [path, seen] : after) {
    if (!before.count(path)) out += path + " created\n";
  }
  return out;
}

const char* kMachineIni =
    "[TRAJ]\nCOORDINATES = X Y Z\nLINEAR_UNITS = mm\n\n[KINS]\nKINEMATICS = trivkins "
    "coordinates=XYZ\nJOINTS = 3\n\n[HAL]\nHALFILE = mill.hal\n\n"
    "[JOINT_0]\nMIN_LIMIT = -300\nMAX_LIMIT = 300\nBACKLASH = 0.008\n\n"
    "[JOINT_1]\nMIN_LIMIT = -300\nMAX_LIMIT = 300\nBACKLASH = 0.008\n\n"
    "[JOINT_2]\nMIN_LIMIT = -300\nMAX_LIMIT = 300\n";

// A scratch folder holding the configuration cfg/ and, beside it, what must never be touched:
// a victim file, a victim folder, an /etc-like folder, another configuration and the
// stand-in circtest_kins.so.
class Hostile : public ::testing::Test {
 protected:
  void SetUp() override {
    cfg_ = top() / "cfg";
    fs::create_directories(cfg_);
    ini_ = (cfg_ / "m.ini").string();
    spit(ini_, kMachineIni);
    spit(cfg_ / "mill.hal", "loadrt trivkins coordinates=XYZ\nloadrt motmod\n");
    spit(top() / "victim.txt", "victim\n");
    fs::create_directories(top() / "victimdir");
    spit(top() / "victimdir" / "keep.txt", "keep\n");
    fs::create_directories(top() / "etc");
    spit(top() / "etc" / "passwd", "root:x:0:0\n");
    fs::create_directories(top() / "other");
    spit(top() / "other" / "m.ini", kMachineIni);
    spit(top() / "circtest_kins.so", "");
    // mtimes a second in the past, so that a rewrite with the same bytes shows too.
    for (const auto& e : fs::recursive_directory_iterator(top())) {
      fs::last_write_time(e.path(), fs::last_write_time(e.path()) - std::chrono::seconds(2));
    }
  }
  fs::path top() const { return scratch_.dir(); }

  // X backlash 2 um, X scale 40 ppm, SQUARENESS urad of squareness, for the INI as it is now.
  std::string diagnosis(double squareness_urad = 0.0, const std::string& extra = "") {
    const std::string json =
        R"({"schema": "circtest.diagnosis/1", "units": "mm", "plane": "XY",
    "backlash_mm": {"X": 0.002, "Y": 0.0}, "scale_ppm": {"X": 40.0, "Y": 0.0},
    "squareness_urad": )" +
        std::to_string(squareness_urad) + extra + R"(,
    "standard_error": {"backlash_mm": {"X": 1e-5, "Y": 1e-5}, "scale_ppm": {"X": 0.5, "Y": 0.5},
                       "squareness_urad": 0.5},
    "ini_sha256": ")" +
        circtest::sha256_hex(slurp(ini_)) + "\"}";
    fs::create_directories(top() / "diagnoses");
    const std::string path =
        (top() / "diagnoses" / ("d" + std::to_string(n_++) + ".json")).string();
    spit(path, json);
    return path;
  }

  CommandResult circcomp(std::vector<std::string> args) {
    args.insert(args.begin(), CIRCCOMP_PATH);
    return run_command(args, {"CIRCTEST_KINS_MODULE=" + (top() / "circtest_kins.so").string()});
  }
  CommandResult apply(const std::string& diagnosis_path) {
    return circcomp({"apply", "--ini", ini_, diagnosis_path});
  }
  CommandResult revert(std::vector<std::string> more = {}) {
    std::vector<std::string> args{"revert", "--ini", ini_};
    args.insert(args.end(), more.begin(), more.end());
    return circcomp(args);
  }
  void write_manifest(const std::string& text) {
    fs::create_directories(cfg_ / ".circcomp");
    spit(cfg_ / ".circcomp" / "manifest", text);
  }

  // RUN refused with CODE and WORDS; nothing outside cfg/ changed.
  template <class Run>
  void expect_refused(Run&& run, int code, const std::string& words) {
    const Snapshot before = snapshot(top(), cfg_);
    const CommandResult r = run();
    EXPECT_EQ(r.exit_code, code) << r.err << r.out;
    EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
    EXPECT_EQ(changes(before, snapshot(top(), cfg_)), "") << r.err;
  }

  ScratchDir scratch_{"circtest-hostile-circcomp"};
  fs::path cfg_;
  std::string ini_;
  int n_ = 0;
};

std::string sha(const std::string& text) {
  return circtest::sha256_hex(text);
}

}  // namespace

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
       "\"version\": expected MAJOR.MINOR (\"1.3\"), got '1\\x07'"},
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
