// Test sets a careless or hostile user hands circana and circcomp: a plane listed twice,
// segments without their plane or with one outside the set, planes interleaved, a plane asked
// for that the set lacks, a one-plane command given a set, plots whose paths cannot be
// written, a set's diagnosis whose planes do not match. Each is refused with its exit code, the
// file (and line) and the words of the refusal; nothing half-written.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "scratch.hpp"

namespace {

namespace fs = std::filesystem;
using circtest::testing::CommandResult;
using circtest::testing::run_command;
using circtest::testing::ScratchDir;
using circtest::testing::slurp;

class HostileTestSet : public ::testing::Test {
 protected:
  void SetUp() override {
    set_ = dir_.file("set.csv");
    const CommandResult r =
        run_command({SIMTRACE_PATH, "-o", set_, "--set", "XY,YZ,ZX", "--feeds", "2000", "--d", "60",
                     "--backlash-x", "0.01", "--noise", "0.0003"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    text_ = slurp(set_);
  }
  // The set's trace with metadata line KEY's value replaced.
  std::string with(const std::string& key, const std::string& value) {
    std::string t = text_;
    const std::string head = "# " + key + ": ";
    const auto at = t.find(head);
    EXPECT_NE(at, std::string::npos) << key;
    const auto end = t.find('\n', at);
    t.replace(at, end - at, head + value);
    return dir_.write("bad.csv", t);
  }
  void expect(const std::vector<std::string>& argv, int code, const std::string& words) {
    const CommandResult r = run_command(argv);
    EXPECT_EQ(r.exit_code, code) << r.err;
    EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
    EXPECT_EQ(r.out, "");
  }

  ScratchDir dir_{"circtest-hostile-set"};
  std::string set_, text_;
};

}  // namespace

TEST_F(HostileTestSet, APlaneListedTwiceIsRefusedAtItsLine) {
  expect({CIRCANA_PATH, "analyze", with("plane", "XY,YZ,XY")}, 4,
         "bad.csv:1: metadata 'plane': expected XY, YZ or ZX, got 'XY,YZ,XY'");
}

TEST_F(HostileTestSet, SegmentsWithoutTheirPlaneOrOutsideTheSetAreRefused) {
  expect({CIRCANA_PATH, "diagnose", with("segments", "1:CCW:F2000:XY,2:CW:F2000")}, 4,
         "bad.csv:6: metadata 'segments': entry '2:CW:F2000' names no plane");
  expect({CIRCANA_PATH, "analyze", with("segments", "1:CCW:F2000:XY,2:CW:F2000:XZ")}, 4,
         "plane 'XZ' is not one of the set's planes (XY,YZ,ZX, metadata 'plane' line 1)");
}

TEST_F(HostileTestSet, PlanesInterleavedAreRefusedAtTheRow) {
  // Run 5 (ZX's first) said to be XY's: XY's runs would resume after YZ's.
  const std::string bad =
      with("segments",
           "1:CCW:F2000:XY,2:CW:F2000:XY,3:CCW:F2000:YZ,4:CW:F2000:YZ,5:CCW:F2000:XY,"
           "6:CW:F2000:ZX");
  expect({CIRCANA_PATH, "analyze", bad}, 5,
         "segment 5 (XY) comes after runs of YZ: a set's planes run one after another");
  // And a run the segments do not announce.
  expect({CIRCANA_PATH, "analyze",
          with("segments", "1:CCW:F2000:XY,2:CW:F2000:XY,3:CCW:F2000:YZ,4:CW:F2000:YZ")},
         5, "segment 5: a run the metadata 'segments' (line 6) does not announce");
}

TEST_F(HostileTestSet, APlaneTheSetLacksAndOnePlaneCommandsAreRefused) {
  const std::string yz_zx = dir_.file("yz-zx.csv");
  const CommandResult r =
      run_command({SIMTRACE_PATH, "-o", yz_zx, "--set", "YZ,ZX", "--feeds", "2000", "--d", "60"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect({CIRCANA_PATH, "analyze", yz_zx, "--plane", "XY"}, 5,
         "--plane XY: not a plane of this test set (planes YZ,ZX)");
  // --plane picks one plane of the set.
  const CommandResult one = run_command({CIRCANA_PATH, "diagnose", set_, "--plane", "ZX"});
  EXPECT_EQ(one.exit_code, 0) << one.err;
  EXPECT_NE(one.out.find("plane ZX, 2 runs"), std::string::npos) << one.out;
  expect({CIRCANA_PATH, "store", set_, "--db", dir_.file("h.db")}, 5,
         "a test set of the planes XY,YZ,ZX: this command reads one plane; give --plane");
  EXPECT_FALSE(fs::exists(dir_.dir() / "h.db"));
  expect({CIRCANA_PATH, "analyze", set_, "--svg", dir_.file("p.svg"), "--compare", set_}, 2,
         "--compare: " + set_ + " is a test set (XY,YZ,ZX): compare one plane");
}

TEST_F(HostileTestSet, APlotPathThatCannotBeWrittenLeavesNoPlotOfTheSet) {
  fs::create_directory(dir_.dir() / "p-YZ.svg");
  const CommandResult r = run_command({CIRCANA_PATH, "analyze", set_, "--svg", dir_.file("p.svg")});
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("p-YZ.svg"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_.dir() / "p-XY.svg"));
  EXPECT_FALSE(fs::exists(dir_.dir() / "p-ZX.svg"));
  EXPECT_EQ(r.out, "");
}

TEST_F(HostileTestSet, ASetsDiagnosisWhosePlanesDoNotMatchIsRefusedByCircComp) {
  const CommandResult d = run_command({CIRCANA_PATH, "diagnose", set_, "--json"});
  ASSERT_EQ(d.exit_code, 0) << d.err;
  std::string doc = d.out;
  doc.replace(doc.find("\"plane\": \"XY,YZ,ZX\""), 19, "\"plane\": \"XY,ZX\"");
  const std::string json = dir_.write("d.json", doc);
  const std::string ini = dir_.write(
      "m.ini", "[TRAJ]\nCOORDINATES = X Y Z\nLINEAR_UNITS = mm\n[KINS]\nKINEMATICS = trivkins\n");
  expect({CIRCCOMP_PATH, "plan", "--ini", ini, json}, 4,
         "\"test_set.diagnoses\": the planes' diagnoses are XY,YZ,ZX, the document's plane says "
         "XY,ZX");
}
