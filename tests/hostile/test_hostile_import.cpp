// circana import on what a careless or hostile user hands it: exports whose titles, fields,
// numbers or own metadata do not fit, options that disagree with the file. Each refused with
// its exit code and one line naming the file and line; the output is never written.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "circtest/core/sha256.hpp"
#include "circtest/core/strings.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;
using namespace circtest::testing;  // ScratchDir, slurp, run_command

namespace {

class Import : public ::testing::Test {
 protected:
  CommandResult circana(std::vector<std::string> args) {
    args.insert(args.begin(), CIRCANA_PATH);
    return run_command(args);
  }
  // Refused with CODE, one line on stderr holding each of WORDS, nothing on stdout, and the
  // output not written.
  void expect_refused(const std::vector<std::string>& args, int code,
                      const std::vector<std::string>& words) {
    const std::string out = dir_.file("refused.csv");
    std::vector<std::string> argv = args;
    argv.insert(argv.end(), {"-o", out});
    const CommandResult r = circana(argv);
    const std::string shown = circtest::join(args, " ");
    EXPECT_EQ(r.exit_code, code) << shown << "\n" << r.err;
    EXPECT_EQ(r.out, "") << shown;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
    for (const auto& w : words) EXPECT_NE(r.err.find(w), std::string::npos) << w << "\n" << r.err;
    EXPECT_FALSE(fs::exists(out)) << shown;
  }

  ScratchDir dir_{"circtest-hostile-import"};
};

}  // namespace

TEST_F(Import, BadExportsAreRefusedWithFileAndLine) {
  const std::string radius[] = {"--radius", "50"};
  const auto cmd = [&](const std::string& file, std::vector<std::string> more = {}) {
    std::vector<std::string> a{"import", file, radius[0], radius[1]};
    a.insert(a.end(), more.begin(), more.end());
    return a;
  };
  std::string good;
  for (int i = 0; i < 10; ++i) good += std::to_string(i * 36) + ",1\n";

  const std::string unreadable = dir_.write("title.csv", "Foo,Bar\n" + good);
  expect_refused(cmd(unreadable), 4,
                 {unreadable + ":1:", "cannot tell what 'Foo' holds", "--columns"});
  const std::string no_unit = dir_.write("nounit.csv", "Angle,Deviation\n" + good);
  expect_refused(cmd(no_unit), 4, {no_unit + ":1:", "'Angle'"});
  const std::string three = dir_.write("three.csv", "0 1 2\n1 2 3\n2 3 4\n");
  expect_refused(cmd(three), 4, {three + ":1:", "3 columns and no title row", "--columns"});
  const std::string short_row = dir_.write("short.csv", good + "7\n");
  expect_refused(cmd(short_row), 4, {short_row + ":11:", "expected 2 fields (angle_deg,dev_um)"});
  // A decimal comma is never read as a decimal point: the fields do not fit.
  const std::string comma = dir_.write("comma.csv", good + "0,5;1,2\n");
  expect_refused(cmd(comma), 4, {comma + ":11:", "expected 2 fields", "got 4"});
  const std::string word = dir_.write("word.csv", good + "1 nan\n");
  expect_refused(cmd(word), 4, {word + ":11:", "column 'dev_um': expected a number, got 'nan'"});
  const std::string run0 = dir_.write("run0.csv", "angle_deg,dev_um,run\n0,1,1\n1,1,1\n2,1,0\n");
  expect_refused(cmd(run0), 4, {run0 + ":4:", "a run id, a whole number from 1"});
  const std::string back = dir_.write("back.csv", "0 0 50\n1 0 50\n0.5 0 50\n3 0 50\n");
  expect_refused({"import", back, "--columns", "t_s,x_mm,y_mm"}, 5,
                 {back + ":3:", "time goes back"});
  // Options that do not fit the file.
  expect_refused({"import", dir_.write("g.csv", good)}, 2, {"--radius", "nominal radius"});
  expect_refused(cmd(dir_.write("g.csv", good), {"--columns", "angel_deg,dev_um"}), 2,
                 {"unknown column 'angel_deg'", "did you mean angle_deg?"});
  expect_refused(cmd(dir_.write("g.csv", good), {"--columns", "x_mm,y_mm", "--plane", "YZ"}), 2,
                 {"unknown column 'x_mm' for the plane YZ"});
  expect_refused(cmd(dir_.write("g.csv", good), {"--columns", "angle_deg,x_mm"}), 2,
                 {"--columns: columns angle_deg,x_mm"});
  std::string turning = good;
  for (int i = 9; i >= 0; --i) turning += std::to_string(i * 36) + ",1\n";
  const std::string turns = dir_.write("turns.csv", turning);
  expect_refused(cmd(turns, {"--direction", "ccw"}), 5, {turns + ":12:", "turns back"});
  expect_refused(cmd(dir_.write("g.csv", good), {"--ini", dir_.path()}), 3, {dir_.path()});
  // A circana export's metadata in another encoding than UTF-8.
  const std::string latin1 = dir_.write(
      "latin1.txt", "# exported_by: circana export-polar\n# operator: J\xFCrgen\n" + good);
  expect_refused(cmd(latin1), 4, {latin1 + ":2:", "metadata 'operator': not UTF-8 text"});
  // The output over the input: the export is not replaced by its own import.
  const std::string self = dir_.write("self.csv", good);
  const CommandResult r = circana({"import", self, "--radius", "50", "-o", self});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("the same file as the input"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(self), good);
}

TEST_F(Import, AnExportDisagreeingWithTheOptionsIsRefused) {
  const std::string ini = dir_.write("m.ini", "[EMC]\nMACHINE = m\n");
  const std::string logged = dir_.file("run.csv");
  ASSERT_EQ(run_command({SIMTRACE_PATH, "-o", logged}).exit_code, 0);
  const std::string polar = dir_.file("polar.txt");
  ASSERT_EQ(circana({"export-polar", logged, "-o", polar}).exit_code, 0);
  // The export states its radius, plane and feed; an option that says otherwise is refused.
  expect_refused({"import", polar, "--radius", "50"}, 5,
                 {polar + ":3:", "--radius 50 disagrees with the export's radius_mm: 75"});
  expect_refused({"import", polar, "--plane", "YZ"}, 5, {polar + ":2:", "--plane YZ"});
  expect_refused({"import", polar, "--feed", "700"}, 5, {"--feed 700", "feed_mm_per_min: 1000"});
  // Position columns are read for the plane the export states, not the default XY.
  const std::string zx = dir_.write(
      "zx.txt", "# exported_by: circana export-polar\n# plane: ZX\n0 50 0\n1 50 1\n2 50 2\n");
  expect_refused({"import", zx, "--columns", "t_s,x_mm,y_mm"}, 2,
                 {"unknown column 'y_mm' for the plane ZX"});
  // An export that names its INI refuses another one.
  const std::string with_ini = dir_.file("with-ini.csv");
  ASSERT_EQ(circana({"import", polar, "-o", with_ini, "--ini", ini}).exit_code, 0);
  const std::string polar2 = dir_.file("polar2.txt");
  ASSERT_EQ(circana({"export-polar", with_ini, "-o", polar2}).exit_code, 0);
  const std::string other = dir_.write("other.ini", "[EMC]\nMACHINE = other\n");
  expect_refused({"import", polar2, "--ini", other}, 5, {"disagrees with the export's ini_sha256"});
  const std::string again = dir_.file("again.csv");
  ASSERT_EQ(circana({"import", polar2, "-o", again, "--ini", ini}).exit_code, 0);
  EXPECT_NE(slurp(again).find("# ini_sha256: " + circtest::sha256_hex(slurp(ini))),
            std::string::npos);
}
