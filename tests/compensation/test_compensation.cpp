// circcomp on fixture configurations: incremental corrections against hand-computed values,
// provenance, bounds, apply/revert byte-identical, squareness through circtest_kins, and the
// CLI's codes (the tables, scale and cyclic errors: test_compensation_tables.cpp).
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>

#include "circtest/compensation/config_dir.hpp"
#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/manifest.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/sha256.hpp"
#include "compensation_test_support.hpp"
#include "sanitizer.hpp"

namespace fs = std::filesystem;
using namespace circtest;
using namespace circtest::compensation;
using namespace circtest::testing;

namespace {

int run(const std::string& args, std::string* err = nullptr) {
  const std::string cmd = std::string(CIRCCOMP_PATH) + " " + args +
                          " >/dev/null 2>/tmp/circcomp-err-" + std::to_string(::getpid());
  const int rc = std::system(cmd.c_str());
  if (err) *err = read_file("/tmp/circcomp-err-" + std::to_string(::getpid()));
  return WEXITSTATUS(rc);
}

}  // namespace

TEST(Compensation, BacklashIsIncremental) {
  Scratch s;
  const std::string ini = s.write("m.ini", machine());
  for (const auto& [measured, expected] :
       std::vector<std::pair<double, std::string>>{{0.002, "0.01"}, {-0.002, "0.006"}}) {
    const Plan plan = make_plan(ini, diag(measured), only(Correction::backlash));
    ASSERT_EQ(plan.files.size(), 1u);
    const IniDocument after = IniDocument::parse(plan.files[0].after);
    EXPECT_EQ(after.get("JOINT_0", "BACKLASH"), expected);
    EXPECT_EQ(after.get("JOINT_1", "BACKLASH"), std::nullopt);  // Y: nothing to correct
    // Only that line differs.
    std::string before = plan.files[0].before;
    before.replace(before.find("BACKLASH = 0.008"), 16, "BACKLASH = " + expected);
    EXPECT_EQ(plan.files[0].after, before);
  }
  // A gain applies a share: 0.008 + 0.5 * 0.002.
  PlanOptions half = only(Correction::backlash);
  half.gain = 0.5;
  EXPECT_EQ(IniDocument::parse(make_plan(ini, diag(0.002), half).files[0].after)
                .get("JOINT_0", "BACKLASH"),
            "0.009");
}

TEST(Compensation, ApplyRevertIdempotence) {
  Scratch s;
  const std::string text = machine();
  const std::string ini = s.write("m.ini", text);
  const DiagnosisInput d = diag(0.002, ini);
  require_fresh(ini, d, false);
  apply_plan(make_plan(ini, d, only(Correction::backlash)));
  EXPECT_EQ(IniDocument::load(ini).get("JOINT_0", "BACKLASH"), "0.01");
  // The same diagnosis again: the INI is not the one measured any more.
  EXPECT_THROW(require_fresh(ini, d, false), StaleError);
  EXPECT_TRUE(revert(ini));
  EXPECT_EQ(read_file(ini), text);
  EXPECT_FALSE(fs::exists(s.dir() / ".circcomp"));
  EXPECT_FALSE(revert(ini));  // a second revert is a no-op
  EXPECT_EQ(read_file(ini), text);
}

// The manifest names files relative to the configuration, with the SHA-256 of what apply
// wrote, and reads back as written.
TEST(Compensation, ManifestNamesRelativeFilesWithTheirChecksums) {
  Scratch s;
  const std::string ini = s.write("m.ini", machine());
  DiagnosisInput d = diag(0.002, ini);
  d.diagnosis.scale_ppm[0] = {20.0, 0.5};
  apply_plan(make_plan(ini, d, PlanOptions{}));
  const std::string text = s.read(".circcomp/manifest");
  const ConfigDir dir(ini);
  const Manifest m = parse_manifest(text, "manifest", dir);
  EXPECT_EQ(render_manifest(m), text);
  ASSERT_EQ(m.last.size(), 2u);
  EXPECT_EQ(m.last[0].name, "m.ini");
  EXPECT_TRUE(m.last[0].existed);
  EXPECT_EQ(m.last[0].sha256, sha256_hex(s.read("m.ini")));
  EXPECT_EQ(m.last[1].name, "circtest-joint0.comp");
  EXPECT_FALSE(m.last[1].existed);
  EXPECT_EQ(m.last[1].sha256, sha256_hex(s.read("circtest-joint0.comp")));
  EXPECT_EQ(m.found.size(), 2u);  // the first apply: its originals are the state as found
  EXPECT_EQ(text.find(s.dir().string()), std::string::npos) << text;  // no absolute path
  EXPECT_TRUE(revert(ini));
  EXPECT_EQ(s.read("m.ini"), machine());
}

TEST(Compensation, GantryCorrectsBothJoints) {
  Scratch s;
  std::string text = machine("trivkins coordinates=XYYZ", "") + joint(3);
  text.replace(text.find("JOINTS = 3"), 10, "JOINTS = 4");
  const std::string ini = s.write("m.ini", text);
  DiagnosisInput d = diag(0.0);
  d.diagnosis.backlash_mm[1] = {0.003, 1e-5};
  const IniDocument after =
      IniDocument::parse(make_plan(ini, d, only(Correction::backlash)).files[0].after);
  EXPECT_EQ(after.get("JOINT_1", "BACKLASH"), "0.003");
  EXPECT_EQ(after.get("JOINT_2", "BACKLASH"), "0.003");
  EXPECT_EQ(after.get("JOINT_0", "BACKLASH"), std::nullopt);
  EXPECT_EQ(after.get("JOINT_3", "BACKLASH"), std::nullopt);
}

TEST(Compensation, IncludedJointsChangeInTheirFile) {
  Scratch s;
  const std::string inc = joint(0, "BACKLASH = 0.008\n");
  s.write("joints.inc", inc);
  std::string text = machine();
  text.replace(text.find("[JOINT_0]"), joint(0, "BACKLASH = 0.008\n").size(),
               "#INCLUDE joints.inc\n");
  const std::string ini = s.write("m.ini", text);
  const DiagnosisInput d = diag(0.002, ini);
  const Plan plan = make_plan(ini, d, only(Correction::backlash));
  ASSERT_EQ(plan.files.size(), 1u);
  EXPECT_EQ(fs::path(plan.files[0].path).filename(), "joints.inc");
  apply_plan(plan);
  EXPECT_EQ(read_file(ini), text);
  EXPECT_NE(s.read("joints.inc").find("BACKLASH = 0.01\n"), std::string::npos);
  EXPECT_TRUE(revert(ini));
  EXPECT_EQ(s.read("joints.inc"), inc);
}

TEST(Compensation, CrlfStaysCrlf) {
  Scratch s;
  std::string text = machine("trivkins", "");
  std::string crlf;
  for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  const std::string ini = s.write("m.ini", crlf);
  DiagnosisInput d = diag(0.002);
  d.diagnosis.scale_ppm[0] = {10.0, 0.5};
  const Plan plan = make_plan(ini, d, PlanOptions{});
  int inis = 0;
  for (const auto& f : plan.files) {
    if (!f.path.ends_with("m.ini")) continue;
    ++inis;
    EXPECT_NE(f.after.find("COMP_FILE = circtest-joint0.comp\r\n"), std::string::npos);
    for (std::size_t i = 0; i < f.after.size(); ++i) {
      if (f.after[i] == '\n') {
        ASSERT_EQ(f.after[i - 1], '\r') << "bare LF at " << i;
      }
    }
  }
  EXPECT_EQ(inis, 1);
}

// On an inch machine a length is said in inch too (the diagnosis is in mm): the refusal and the
// note name both (0.3 mm = 0.011811 in; the note's bound 0.0001 mm = 0.0000039 in).
TEST(Compensation, RefusalsOnAnInchMachineSayInch) {
  Scratch s;
  std::string text = machine();
  const auto at = text.find("LINEAR_UNITS = mm");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, std::string("LINEAR_UNITS = mm").size(), "LINEAR_UNITS = inch");
  const std::string ini = s.write("m.ini", text);
  try {
    make_plan(ini, diag(0.3), {});
    FAIL() << "no error for 0.3 mm of backlash";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("X backlash = 0.011811 in (0.3 mm) is implausible"),
              std::string::npos)
        << e.what();
  }
  const Plan small = make_plan(ini, diag(0.0001), {});
  const bool said = std::any_of(small.notes.begin(), small.notes.end(), [](const std::string& n) {
    return n.find("Y backlash: 0.0 in (0.0 mm) is below 0.0000039 in (0.0001 mm)") !=
           std::string::npos;
  });
  std::string notes;
  for (const std::string& n : small.notes) notes += n + " / ";
  EXPECT_TRUE(said) << notes;
}

TEST(Compensation, Refusals) {
  Scratch s;
  const std::string ini = s.write("m.ini", machine());
  auto expect_data = [&](const DiagnosisInput& d, const std::string& words,
                         const PlanOptions& o = {}) {
    try {
      make_plan(ini, d, o);
      FAIL() << "no error for " << words;
    } catch (const DataError& e) {
      EXPECT_EQ(e.code(), ExitCode::data);
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expect_data(diag(0.3), "X backlash = 0.3 mm is implausible");
  DiagnosisInput uncertain = diag(0.002);
  uncertain.diagnosis.backlash_mm[0].standard_error = 0.003;
  expect_data(uncertain, "has a standard error of 0.003 mm, larger than the value");
  DiagnosisInput skewed = diag(0.0);
  skewed.diagnosis.scale_ppm[0] = {1500.0, 1.0};
  expect_data(skewed, "X scale = 1500.0 ppm is implausible");
  PlanOptions force;
  force.force = true;
  EXPECT_NO_THROW(make_plan(ini, diag(0.3), force));
  const std::string five = s.write("5.ini", machine("5axiskins"));
  try {
    make_plan(five, diag(0.002), PlanOptions{});
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "KINEMATICS = 5axiskins: circcomp maps axes to joints only for trivkins"),
              std::string::npos);
  }
  DiagnosisInput no_hash = diag(0.002);
  EXPECT_THROW(require_fresh(ini, no_hash, false), StaleError);
  EXPECT_NO_THROW(require_fresh(ini, no_hash, true));
}

// Library text names no command-line option: used as a library, the refusals name
// the PlanOptions settings in plain words; circcomp words them as its options (CliExitCodes).
TEST(Compensation, LibraryRefusalsNameNoOption) {
  Scratch s;
  const std::string ini = s.write("m.ini", machine());
  auto message = [&](auto&& call) -> std::string {
    try {
      call();
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  };
  DiagnosisInput uncertain = diag(0.002);
  uncertain.diagnosis.backlash_mm[0].standard_error = 0.003;
  PlanOptions half;
  half.gain = 1.5;
  DiagnosisInput stale = diag(0.002);
  stale.diagnosis.ini_sha256 = std::string(64, '0');
  Plan needs_kins;
  needs_kins.needs_kins_module = true;
  ::setenv("CIRCTEST_KINS_MODULE", (s.dir() / "missing" / "circtest_kins.so").c_str(), 1);
  const std::string kins_text = message([&] { require_kins_module(needs_kins); });
  ::unsetenv("CIRCTEST_KINS_MODULE");
  EXPECT_NE(kins_text.find("or leave squareness out of the corrections; nothing changed"),
            std::string::npos)
      << kins_text;
  EXPECT_EQ(kins_text.find("--"), std::string::npos) << kins_text;
  const std::string texts[] = {
      message([&] { make_plan(ini, diag(0.3), PlanOptions{}); }),
      message([&] { make_plan(ini, uncertain, PlanOptions{}); }),
      message([&] { make_plan(ini, diag(0.002), half); }),
      message([&] { require_fresh(ini, diag(0.002), false); }),
      message([&] { require_fresh(ini, stale, false); }),
  };
  EXPECT_NE(texts[0].find("check the measurement, or the force setting"), std::string::npos)
      << texts[0];
  EXPECT_NE(texts[1].find("measure again, or the force setting"), std::string::npos) << texts[1];
  EXPECT_NE(texts[2].find("the gain setting: expected 0 < F <= 1"), std::string::npos) << texts[2];
  EXPECT_NE(texts[3].find("record with circtest-run, or with circlog-record given the INI, or "
                          "the force setting"),
            std::string::npos)
      << texts[3];
  EXPECT_NE(texts[4].find("measure again, or the force setting"), std::string::npos) << texts[4];
  for (const auto& t : texts) EXPECT_EQ(t.find("--"), std::string::npos) << t;
}

TEST(Compensation, CliExitCodes) {
  Scratch s;
  const std::string ini = s.write("m.ini", machine());
  const std::string json = R"({"schema": "circtest.diagnosis/1", "units": "mm", "plane": "XY",
    "axes": ["X", "Y"], "backlash_mm": {"X": 0.002, "Y": 0.0},
    "standard_error": {"backlash_mm": {"X": 1e-5, "Y": 1e-5}}, "ini_sha256": ")" +
                           sha256_hex(read_file(ini)) + "\"}";
  const std::string diagnosis = s.write("d.json", json);
  const std::string base = "--ini " + ini + " " + diagnosis;
  std::string err;
  EXPECT_EQ(run("plan " + base), 0);
  EXPECT_EQ(read_file(ini), machine());  // plan writes nothing
  EXPECT_EQ(run("plan " + base + " --only play", &err), 2);
  EXPECT_NE(err.find("--only"), std::string::npos) << err;
  EXPECT_EQ(run("apply " + base), 0);
  EXPECT_EQ(run("apply " + base, &err), 10);
  EXPECT_NE(err.find("changed since the measurement"), std::string::npos) << err;
  // circcomp words the library's settings as its options.
  EXPECT_NE(err.find("measure again, or --force"), std::string::npos) << err;
  EXPECT_EQ(run("plan " + base + " --gain 2", &err), 2);
  EXPECT_NE(err.find("--gain: expected 0 < F <= 1"), std::string::npos) << err;
  EXPECT_EQ(run("revert --ini " + ini), 0);
  EXPECT_EQ(read_file(ini), machine());
  EXPECT_EQ(run("plan --ini " + ini + " " + s.write("bad.json", "{\"schema\": \"other\"}"), &err),
            4);
  EXPECT_NE(err.find("circtest.diagnosis/1"), std::string::npos) << err;
  EXPECT_EQ(run("plan --ini " + (s.dir() / "none.ini").string() + " " + diagnosis), 3);
}

// ---- squareness through circtest_kins ----

namespace {

std::string hal_machine(const std::string& kins, const std::string& extra = "") {
  return machine(kins) + "[HAL]\nHALFILE = mill.hal\nHALFILE = LIB:basic_sim.tcl\n\n" + extra;
}

DiagnosisInput square(double urad, const std::string& plane = "XY") {
  DiagnosisInput d;
  d.source = "d.json";
  d.diagnosis.plane = *parse_plane(plane);
  d.diagnosis.axes = plane == "XY"   ? std::array<char, 2>{'X', 'Y'}
                     : plane == "YZ" ? std::array<char, 2>{'Y', 'Z'}
                                     : std::array<char, 2>{'Z', 'X'};
  d.diagnosis.squareness_urad = {urad, 0.5};
  return d;
}

}  // namespace

TEST(Compensation, SquarenessSwitchesToCircTestKins) {
  Scratch s;
  const std::string text = hal_machine("trivkins coordinates=XYZ kinstype=1");
  const std::string ini = s.write("m.ini", text);
  const std::string hal_text = "# the mill\nloadrt  trivkins coordinates=XYZ\nloadrt motmod\n";
  s.write("mill.hal", hal_text);
  const Plan plan = make_plan(ini, square(100.0), only(Correction::squareness));
  ASSERT_EQ(plan.files.size(), 3u);  // INI, mill.hal, the new circtest-comp.hal
  const IniDocument after = IniDocument::parse(change_of(plan, "m.ini")->after);
  EXPECT_EQ(after.get("KINS", "KINEMATICS"), "circtest_kins coordinates=XYZ kinstype=1");
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_XY"), "1.000000e-04");
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_YZ"), "0.0");
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_ZX"), "0.0");
  const auto halfiles = after.get_all("HAL", "HALFILE");
  ASSERT_EQ(halfiles.size(), 3u);
  EXPECT_EQ(halfiles[2].value, "circtest-comp.hal");  // last: after the kinematics is loaded
  EXPECT_EQ(change_of(plan, "mill.hal")->after,
            "# the mill\nloadrt  circtest_kins coordinates=XYZ\nloadrt motmod\n");
  const FileChange* comp = change_of(plan, "circtest-comp.hal");
  ASSERT_TRUE(comp);
  EXPECT_FALSE(comp->existed);
  EXPECT_NE(comp->after.find("setp circtest-kins.squareness-xy [CIRCTEST_COMP]SQUARENESS_XY\n"),
            std::string::npos);

  // Applied and reverted byte-identical, the created HAL file removed.
  apply_plan(plan);
  EXPECT_EQ(s.read("mill.hal"), change_of(plan, "mill.hal")->after);
  EXPECT_TRUE(revert(ini));
  EXPECT_EQ(s.read("m.ini"), text);
  EXPECT_EQ(s.read("mill.hal"), hal_text);
  EXPECT_FALSE(fs::exists(s.dir() / "circtest-comp.hal"));
}

TEST(Compensation, SquarenessIsIncrementalOnCircTestKins) {
  Scratch s;
  const std::string ini =
      s.write("m.ini", hal_machine("circtest_kins coordinates=XYZ",
                                   "[CIRCTEST_COMP]\nSQUARENESS_XY = 1.0e-04\n"
                                   "SQUARENESS_YZ = 2.0e-05\nSQUARENESS_ZX = 0.0\n"));
  s.write("mill.hal", "loadrt [KINS]KINEMATICS\n");
  // The measurement saw 100 urad compensated; a residual of -3 urad gives 97 urad.
  Plan plan = make_plan(ini, square(-3.0), only(Correction::squareness));
  IniDocument after = IniDocument::parse(change_of(plan, "m.ini")->after);
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_XY"), "9.700000e-05");
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_YZ"), "2.0e-05");  // untouched
  EXPECT_EQ(after.get("KINS", "KINEMATICS"), "circtest_kins coordinates=XYZ");
  // YZ: its own key, the others kept; half the residual with --gain 0.5.
  PlanOptions half = only(Correction::squareness);
  half.gain = 0.5;
  plan = make_plan(ini, square(10.0, "YZ"), half);
  after = IniDocument::parse(change_of(plan, "m.ini")->after);
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_YZ"), "2.500000e-05");
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_XY"), "1.0e-04");
  // The HAL file is added once: a plan that finds it in HALFILE adds no second line.
  const std::string listed =
      s.write("l.ini", hal_machine("circtest_kins coordinates=XYZ",
                                   "[CIRCTEST_COMP]\nSQUARENESS_XY = 1.0e-04\nSQUARENESS_YZ = 0\n"
                                   "SQUARENESS_ZX = 0\n"));
  IniDocument l = IniDocument::load(listed);
  l.append("HAL", "HALFILE", "circtest-comp.hal");
  write_file_atomic(listed, l.render());
  plan = make_plan(listed, square(5.0), only(Correction::squareness));
  ASSERT_EQ(plan.files.size(), 1u);
  EXPECT_EQ(IniDocument::parse(plan.files[0].after).get_all("HAL", "HALFILE").size(), 3u);
}

TEST(Compensation, SquarenessRefusals) {
  Scratch s;
  const std::string ini = s.write("m.ini", hal_machine("trivkins coordinates=XYZ"));
  s.write("mill.hal", "loadrt [KINS]KINEMATICS\n");
  try {
    make_plan(ini, square(1500.0), only(Correction::squareness));
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("X/Y squareness = 1500.0 urad is implausible"),
              std::string::npos)
        << e.what();
  }
  // A circtest-comp.hal that is not circcomp's is never overwritten.
  s.write("circtest-comp.hal", "# someone's own file\n");
  EXPECT_THROW(make_plan(ini, square(50.0), only(Correction::squareness)), DataError);
  fs::remove(s.dir() / "circtest-comp.hal");
  // Kinematics other than trivkins/circtest_kins: refused.
  const std::string five = s.write("5.ini", hal_machine("5axiskins"));
  EXPECT_THROW(make_plan(five, square(50.0), only(Correction::squareness)), DataError);
  // Below half a microradian there is nothing to write.
  EXPECT_TRUE(make_plan(ini, square(0.2), only(Correction::squareness)).files.empty());
}

// A 50,000-line INI with changes at both ends (the kinematics near the top, [CIRCTEST_COMP]
// appended): circcomp plan runs in bounded memory (the LCS table of the whole file was 10 GB)
// and its diff, applied by patch(1) to a copy, gives the plan's new INI. The bound: 256 MB of
// address space (ulimit -v) and of peak resident memory; under AddressSanitizer, which reserves
// terabytes of address space for its shadow, 512 MB of resident memory (its hard_rss_limit_mb
// stops the program past it) for the program, its shadow and its allocator's quarantine.
TEST(Compensation, LargeIniIsPlannedInBoundedMemoryAndItsDiffApplies) {
#ifdef CIRCTEST_UNDER_ASAN
  const long limit_mb = 512;
  const std::string bounded = "ASAN_OPTIONS=${ASAN_OPTIONS:-}:hard_rss_limit_mb=512 ";
#else
  const long limit_mb = 256;
  const std::string bounded = "ulimit -v 262144; ";
#endif
  Scratch s;
  std::string text = machine();
  std::size_t lines = static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
  for (int i = 0; lines < 50000; ++i, lines += 3) {
    text += "[EXTRA_" + std::to_string(i) + "]\nKEY = " + std::to_string(i) + "\n\n";
  }
  const std::string ini = s.write("m.ini", text);
  s.write("circtest_kins.so", "");
  DiagnosisInput d = diag(0.002, ini);
  d.diagnosis.squareness_urad = {100.0, 0.5};
  PlanOptions o;
  o.only = {Correction::backlash, Correction::squareness};
  const Plan plan = make_plan(ini, d, o);
  ASSERT_EQ(plan.files.size(), 2u);
  const std::string dir = s.dir().string();
  const std::string json = R"({"schema": "circtest.diagnosis/1", "units": "mm", "plane": "XY",
    "axes": ["X", "Y"], "backlash_mm": {"X": 0.002, "Y": 0.0}, "squareness_urad": 100,
    "standard_error": {"backlash_mm": {"X": 1e-5, "Y": 1e-5}, "squareness_urad": 0.5}})";
  s.write("d.json", json);
  const std::string plan_cmd = "cd " + dir + " && (" + bounded + CIRCCOMP_PATH +
                               " plan --ini m.ini --only backlash,squareness d.json >plan.diff)";
  ASSERT_EQ(std::system(plan_cmd.c_str()), 0) << read_file(dir + "/plan.diff").substr(0, 2000);
  rusage children{};
  ASSERT_EQ(::getrusage(RUSAGE_CHILDREN, &children), 0);
  EXPECT_LT(children.ru_maxrss, limit_mb * 1024) << "peak resident kB of circcomp plan";
  const std::string cmd = "cd " + dir +
                          " && mkdir copy && cp m.ini copy/ && cd copy && sed -n '/^--- a\\/m.ini/,"
                          "/^--- /p' ../plan.diff | sed '$d' | patch -s -p1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  EXPECT_EQ(read_file(dir + "/copy/m.ini"), plan.files[0].after);
}
