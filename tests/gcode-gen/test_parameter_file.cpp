// The parameter file (.var) read as LinuxCNC reads it: each line against LinuxCNC's own
// interpreter (rs274 -v), which restores the file exactly as a running LinuxCNC does; and
// through circgen --ini, where the work offset decides the soft-limit check.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/gcode/parameter_file.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

// What LinuxCNC restored: the work offset it selected and its origin, and the G92 offset, as
// the interpreter's first SET_G5X_OFFSET and SET_G92_OFFSET calls state them.
struct Restored {
  int selected = 0;
  std::array<double, 3> origin{};
  std::array<double, 3> g92{};
};

std::vector<double> numbers(const std::string& args) {
  std::vector<double> out;
  std::string item;
  for (char c : args + ",") {
    if (c == ',') {
      out.push_back(std::stod(item));
      item.clear();
    } else {
      item += c;
    }
  }
  return out;
}

// rs274 on a copy of the file (it rewrites it on exit), with an INI when given.
Restored rs274_restores(const std::string& var_text, const std::string& ini_text = {}) {
  ScratchDir home;
  spit(home.file("p.var"), var_text);
  spit(home.file("prog.ngc"), "M2\n");
  std::vector<std::string> argv{CIRCTEST_RS274, "-g", "-v", home.file("p.var")};
  if (!ini_text.empty()) {
    spit(home.file("m.ini"), ini_text);
    argv.insert(argv.end(), {"-i", home.file("m.ini")});
  }
  argv.insert(argv.end(), {home.file("prog.ngc"), home.file("out.canon")});
  const CommandResult r = run_command(argv, {"HOME=" + home.path()});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  const CanonProgram canon = parse_canon(slurp_if_exists(home.file("out.canon")));
  Restored out;
  bool g5x = false, g92 = false;
  for (const CanonCall& call : canon.call_log) {
    if (call.name != "SET_G5X_OFFSET" && call.name != "SET_G92_OFFSET") continue;
    const std::vector<double> v = numbers(call.args);
    if (call.name == "SET_G5X_OFFSET" && !g5x) {
      out.selected = static_cast<int>(v.at(0));
      out.origin = {v.at(1), v.at(2), v.at(3)};
      g5x = true;
    } else if (call.name == "SET_G92_OFFSET" && !g92) {
      out.g92 = {v.at(0), v.at(1), v.at(2)};
      g92 = true;
    }
  }
  EXPECT_TRUE(g5x && g92) << slurp_if_exists(home.file("out.canon"));
  return out;
}

// The standalone interpreter takes the file's lengths in its own units: its factor, from a
// file whose G54 X is 1.
double rs274_length_factor() {
  static const double factor = rs274_restores("5220 1\n5221 1\n").origin[0];
  return factor;
}

struct Agreeing {
  std::string name;
  std::string var;
  std::string ini;  // [RS274NGC] DISABLE_G92_PERSISTENCE, or none
};

// Files circgen accepts: what it reads is what LinuxCNC restores.
TEST(ParameterFile, CircgenReadsWhatLinuxcncRestores) {
  if (!rs274_available()) GTEST_SKIP() << "rs274 not installed (linuxcnc-uspace)";
  const std::string keep = "[RS274NGC]\nDISABLE_G92_PERSISTENCE = 0\n";
  const std::string clear = "[RS274NGC]\nDISABLE_G92_PERSISTENCE = 1\n";
  const std::vector<Agreeing> cases{
      {"plus_sign", "5220 1\n+5221 180\n5222 -2\n5223 3\n", ""},
      {"fraction_selects_by_truncation", "5220 2.6\n5241 7\n5242 8\n5243 9\n5261 1\n", ""},
      {"just_below_one", "5220 0.99995\n5221 4\n", ""},
      {"just_below_ten", "5220 9.99995\n5221 4\n5381 6\n", ""},
      {"negative_selection", "5220 -3\n5221 5\n", ""},
      {"blanks_tabs_comment", "  5220\t3   (G56)\n# note\n\n5261\t-0.5e+2 x\n", ""},
      {"crlf", "5220 3\r\n5261 12.5\r\n5262 1\r\n", ""},
      {"g92_kept", "5210 1\n5211 1\n5212 2\n5213 3\n5220 1\n5221 10\n", keep},
      {"g92_cleared", "5210 1\n5211 1\n5212 2\n5213 3\n5220 1\n5221 10\n", clear},
      {"g92_not_applied", "5210 0\n5211 1\n5212 2\n5213 3\n5220 1\n", ""},
  };
  const double k = rs274_length_factor();
  ASSERT_GT(k, 0.0);
  for (const Agreeing& c : cases) {
    SCOPED_TRACE(c.name);
    const Restored theirs = rs274_restores(c.var, c.ini);
    const WorkOffsets ours = parse_work_offsets(
        c.var, "p.var", 1.0, c.ini == clear ? G92Persistence::cleared : G92Persistence::kept);
    EXPECT_EQ(ours.selected, theirs.selected);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(ours.origin_mm[ours.selected][i] * k, theirs.origin[i], 1e-6) << i;
      EXPECT_NEAR(ours.g92_applied ? ours.g92_mm[i] * k : 0.0, theirs.g92[i], 1e-6) << i;
    }
  }
}

struct Refused {
  std::string var;
  std::string words;  // in the refusal
  // What LinuxCNC sets from the refused line, by the refusal: #number = value.
  std::optional<std::pair<int, double>> linuxcnc;
};

// Lines LinuxCNC reads otherwise than they read are refused, naming the file and line; the
// refusal's "is #N = V to LinuxCNC" is what the interpreter restores.
TEST(ParameterFile, LinesLinuxcncReadsOtherwiseAreRefused) {
  const std::vector<Refused> cases{
      {"5220 1\n5221.0 180\n", "p.var:2: '5221.0 180' is #5221 = 0 to LinuxCNC", {{5221, 0.0}}},
      {"5220 1\n5221 180mm\n", "p.var:2: '5221 180mm' is #5221 = 180 to LinuxCNC", {{5221, 180}}},
      {"5220 1\n5221-3\n", "p.var:2: '5221-3' is #5221 = -3 to LinuxCNC", {{5221, -3.0}}},
      {"5220 1\n5221 0x10\n", "p.var:2: '5221 0x10' is #5221 = 16 to LinuxCNC", {{5221, 16.0}}},
      {"5220 1\n5221 1e1x\n", "p.var:2: '5221 1e1x' is #5221 = 10 to LinuxCNC", {{5221, 10.0}}},
      {"5221 nan\n", "p.var:1: #5221: 'nan' is not a finite number", std::nullopt},
      {"5221 1e400\n", "p.var:1: #5221: '1e400' is not a finite number", std::nullopt},
      {"0 1\n", "p.var:1: #0: LinuxCNC refuses a parameter number outside 1..5601", std::nullopt},
      {"5602 1\n", "p.var:1: #5602: LinuxCNC refuses a parameter number outside 1..5601",
       std::nullopt},
      {"5221 1\n5221 2\n", "p.var:2: #5221 after #5221: LinuxCNC refuses", std::nullopt},
      {"5220 1\n" + std::string(300, ' ') + "5221 5\n",
       "p.var:2: a line of 306 characters: LinuxCNC reads lines of up to 254 characters",
       std::nullopt},
  };
  for (const Refused& c : cases) {
    SCOPED_TRACE(c.var.substr(0, 40));
    try {
      parse_work_offsets(c.var, "p.var", 1.0);
      ADD_FAILURE() << "accepted";
    } catch (const ParseError& e) {
      EXPECT_NE(std::string(e.what()).find(c.words), std::string::npos) << e.what();
    }
    if (c.linuxcnc && rs274_available()) {
      const Restored theirs = rs274_restores(c.var);
      ASSERT_EQ(c.linuxcnc->first, 5221);  // G54 X, selected by #5220 = 1
      EXPECT_EQ(theirs.selected, 1);
      EXPECT_NEAR(theirs.origin[0], c.linuxcnc->second * rs274_length_factor(), 1e-6);
    }
  }
}

// Through circgen --ini: the origin LinuxCNC uses decides the soft-limit check.
class CircgenParameterFile : public ::testing::Test {
 protected:
  void SetUp() override { set_ini(""); }
  void set_ini(const std::string& rs274ngc) {
    spit(dir_.file("m.ini"),
         "[TRAJ]\nLINEAR_UNITS = mm\n[AXIS_X]\nMIN_LIMIT = -200\nMAX_LIMIT = 200\n"
         "MAX_VELOCITY = 30\nMAX_ACCELERATION = 500\n[AXIS_Y]\nMIN_LIMIT = -200\nMAX_LIMIT = "
         "200\nMAX_VELOCITY = 30\nMAX_ACCELERATION = 500\n"
         "[AXIS_Z]\nMIN_LIMIT = -100\nMAX_LIMIT = 10\nMAX_VELOCITY = 30\nMAX_ACCELERATION = "
         "500\n[RS274NGC]\n"
         "PARAMETER_FILE = p.var\n" +
             rs274ngc);
  }
  CommandResult run(const std::string& var) {
    spit(dir_.file("p.var"), var);
    return run_circgen({"--d", "150", "--f", "300", "--ini", dir_.file("m.ini")});
  }
  ScratchDir dir_;
};

TEST_F(CircgenParameterFile, ASignedNumberIsReadAsLinuxcncReadsIt) {
  // G54 X 180 (LinuxCNC takes "+5221"): the circle reaches X 255, beyond MAX_LIMIT 200.
  const CommandResult r = run("5220 1\n+5221 180\n");
  EXPECT_EQ(r.exit_code, 6) << r.err;
  EXPECT_NE(r.err.find("the test reaches X = 255 mm in machine coordinates, above [AXIS_X] "
                       "MAX_LIMIT = 200"),
            std::string::npos)
      << r.err;
}

TEST_F(CircgenParameterFile, TheSelectedSystemIsTruncatedAsLinuxcncDoes) {
  // #5220 2.6 is G55 to LinuxCNC, whose origin X -180 puts the circle at X -255 (G56,
  // rounded, would be at 0 and pass).
  const CommandResult r = run("5220 2.6\n5241 -180\n");
  EXPECT_EQ(r.exit_code, 6) << r.err;
  EXPECT_NE(r.err.find("X = -255 mm"), std::string::npos) << r.err;
  const CommandResult passes = run("5220 2.6\n5241 -10\n");
  EXPECT_EQ(passes.exit_code, 0) << passes.err;
  EXPECT_NE(passes.err.find("the program inherits the work offset; the path is checked in G55"),
            std::string::npos)
      << passes.err;
}

TEST_F(CircgenParameterFile, AWholeNumberWrittenWithAPointIsRefused) {
  const CommandResult r = run("5220 1\n5221.0 180\n");
  EXPECT_EQ(r.exit_code, 4) << r.err;
  EXPECT_EQ(r.err, "circgen: error: " + dir_.file("p.var") +
                       ":2: '5221.0 180' is #5221 = 0 to LinuxCNC (it reads \"%d %lf\": a whole "
                       "number, then a number, and ignores the rest); write the line as NUMBER "
                       "VALUE\n");
  EXPECT_TRUE(r.out.empty());
}

TEST_F(CircgenParameterFile, G92PersistenceAsTheIniSetsIt) {
  const std::string g92 = "5210 1\n5211 -180\n5220 1\n";
  EXPECT_EQ(run(g92).exit_code, 6);  // kept: G92 X -180 moves the circle to X -255
  set_ini("DISABLE_G92_PERSISTENCE = 1\n");
  const CommandResult cleared = run(g92);
  EXPECT_EQ(cleared.exit_code, 0) << cleared.err;
  EXPECT_NE(cleared.out.find("(circtest: work_offset_origin_source: G54 #5221..#5223 in "),
            std::string::npos);
  EXPECT_EQ(cleared.out.find("plus G92"), std::string::npos);
  set_ini("DISABLE_G92_PERSISTENCE = yes\n");
  const CommandResult ambiguous = run(g92);
  EXPECT_EQ(ambiguous.exit_code, 4);
  EXPECT_NE(ambiguous.err.find(":20: [RS274NGC] DISABLE_G92_PERSISTENCE = yes: expected 0 or 1"),
            std::string::npos)
      << ambiguous.err;
}

}  // namespace
}  // namespace circtest::testing
