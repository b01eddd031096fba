// The end of a session's test as circtest says it: the verdict against the session's limits
// (ISO 14253-1 with U, worked out by hand from the figures), a fault before the first run was
// recorded (the LinuxCNC link's events), and verify's refusal of a moved work offset.
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "scratch.hpp"
#include "session_steps.hpp"

using namespace circtest;
using namespace circtest::session;
using circtest::testing::ScratchDir;

namespace {

// H 5.6 um (U 1.2); G 10.0 and 12.0 um (U 1.0); F_max 4.0, F_min -8.0 um (U 1.5).
constexpr const char* kResults = R"({"H": 0.0056, "U_H": 0.0012, "runs": [
  {"G": 0.010, "U_G": 0.001, "F_max": 0.004, "F_min": -0.003, "U_F": 0.0015},
  {"G": 0.012, "U_G": 0.001, "F_max": 0.002, "F_min": -0.008, "U_F": 0.0015}]})";
// Backlash X 3 um, Y -4 um (the largest |value|: 4 um), squareness 50 urad.
constexpr const char* kDiagnosis =
    R"({"backlash_mm": {"X": 0.003, "Y": -0.004}, "squareness_urad": 50})";

std::vector<FerrorLimit> limits_xy() {
  ScratchDir dir;
  const std::string ini = dir.write("m.ini",
                                    "[KINS]\nJOINTS = 2\nKINEMATICS = trivkins coordinates=XY\n"
                                    "[JOINT_0]\nFERROR = 0.05\nMIN_FERROR = 0.01\n"
                                    "MAX_VELOCITY = 50\n[JOINT_1]\n");
  return ferror_limits(IniDocument::load(ini), ini);
}

}  // namespace

// H: 5.6 + 1.2 = 6.8 <= 15 passes; G: 12.0 + 1.0 = 13.0 > 12.5 but 12.0 - 1.0 = 11.0 <= 12.5
// is not decided; F: |F| 8.0 - 1.5 = 6.5 > 5 fails: out of tolerance.
TEST(SessionVerdict, DecidesEachLimitByIso14253WithU) {
  EXPECT_EQ(verdict_line(kResults, "", "H=0.015,G=0.0125,F=0.005"),
            "verdict against H=0.015,G=0.0125,F=0.005 (ISO 14253-1, U k = 2): OUT OF "
            "TOLERANCE: H 5.6 + U 1.2 <= 15.0 um; G 12.0 + U 1.0 > 12.5 um: within the "
            "uncertainty; F 8.0 - U 1.5 > 5.0 um");
  // Without the fail: not decided; every one within: within the limits.
  EXPECT_EQ(verdict_line(kResults, "", "G=0.0125"),
            "verdict against G=0.0125 (ISO 14253-1, U k = 2): NOT DECIDED: G 12.0 + U 1.0 > "
            "12.5 um: within the uncertainty");
  // (value + U a little below the limit: value + U exactly at it is a matter of binary
  // rounding, which circtest::history's tests hold against circana analyze's.)
  EXPECT_EQ(verdict_line(kResults, "", "H=0.0069,G=0.0131"),
            "verdict against H=0.0069,G=0.0131 (ISO 14253-1, U k = 2): within the limits: H 5.6 "
            "+ U 1.2 <= 6.9 um; G 12.0 + U 1.0 <= 13.1 um");
}

// Backlash and squareness come from the diagnosis, judged on the value alone; without a
// diagnosis they are not measured, which fails (as the report's banner says FAIL).
TEST(SessionVerdict, BacklashAndSquarenessFromTheDiagnosis) {
  EXPECT_EQ(verdict_line(kResults, kDiagnosis, "backlash=0.005,squareness=40"),
            "verdict against backlash=0.005,squareness=40 (ISO 14253-1, U k = 2): OUT OF "
            "TOLERANCE: backlash 4.0 <= 5.0 um (no U); squareness 50.0 > 40.0 urad (no U)");
  EXPECT_EQ(verdict_line(kResults, "", "backlash=0.005"),
            "verdict against backlash=0.005 (ISO 14253-1, U k = 2): OUT OF TOLERANCE: backlash "
            "not measured");
  EXPECT_EQ(verdict_line(kResults, kDiagnosis, ""),
            "no acceptance limits set (circtest run --limits H=MM,G=MM,F=MM): no verdict");
}

// run keeps its limits in the session folder; verify reads them, or overrides them.
TEST(SessionVerdict, TheLimitsAreKeptInTheSessionFolder) {
  ScratchDir dir;
  EXPECT_EQ(session_limits(dir.path(), ""), "");
  EXPECT_EQ(session_limits(dir.path(), "H=0.015,G=0.02"), "H=0.015,G=0.02");
  EXPECT_EQ(dir.read("limits.txt"), "H=0.015,G=0.02\n");
  EXPECT_EQ(session_limits(dir.path(), ""), "H=0.015,G=0.02");
  EXPECT_EQ(session_limits(dir.path(), "G=0.01"), "G=0.01");
  EXPECT_EQ(session_limits(dir.path(), ""), "G=0.01");
  dir.write("limits.txt", "G=lots\n");
  EXPECT_THROW(session_limits(dir.path(), ""), UsageError);
  EXPECT_NO_THROW(check_limits("H=0.015,G=0.02,F=0.01,backlash=0.005,squareness=50"));
  for (const char* bad : {"H=abc", "X=0.01", "H=0", "H=0.015,", "G=20"}) {
    EXPECT_THROW(check_limits(bad), UsageError) << bad;
  }
}

// verify's exit status is its verdict, by circana history --limits' rule (the README's exit
// 9, tolerance): 9 unless every limit passes; 0 within them and without limits.
TEST(SessionVerdict, VerifyExitsNineUnlessEveryLimitPasses) {
  using W = SessionVerdict::Word;
  const struct {
    const char* diagnosis;
    const char* limits;
    W word;
    int exit_code;
  } cases[] = {{"", "H=0.015,G=0.0125,F=0.005", W::out_of_tolerance, 9},
               {"", "G=0.0125", W::not_decided, 9},
               {"", "backlash=0.005", W::out_of_tolerance, 9},  // not measured
               {"", "H=0.0069,G=0.0131", W::within, 0},
               {kDiagnosis, "", W::none, 0}};
  for (const auto& c : cases) {
    const SessionVerdict verdict = session_verdict(kResults, c.diagnosis, c.limits);
    EXPECT_EQ(verdict.word, c.word) << c.limits;
    EXPECT_EQ(verify_exit_code(verdict.word), c.exit_code) << c.limits;
    EXPECT_EQ(verdict.line, verdict_line(kResults, c.diagnosis, c.limits));
  }
}

// verify's end in its session folder: the table (verify.txt), the report, the verdict line
// printed, then the exit status of that verdict.
TEST(SessionVerdict, VerifyEndsWithItsVerdictThenItsExitStatus) {
  ScratchDir dir;
  // Before the corrections: H 25.3 um, G 35.3 um; after: kResults (H 5.6, G 12.0 um).
  dir.write("results.json", R"({"H": 0.0253, "U_H": 0.0012, "runs": [{"G": 0.0353}]})");
  dir.write("verify-results.json", kResults);
  dir.write("verify-diagnosis.json", kDiagnosis);
  const std::string said_within =
      "circtest: verdict against H=0.0069,G=0.0131 (ISO 14253-1, U k = 2): within the limits: H "
      "5.6 + U 1.2 <= 6.9 um; G 12.0 + U 1.0 <= 13.1 um\n";
  const struct {
    const char* limits;
    const char* word;
    int exit_code;
  } cases[] = {{"H=0.015,G=0.0125,F=0.005", ": OUT OF TOLERANCE: ", 9},
               {"G=0.0125", ": NOT DECIDED: ", 9},
               {"H=0.0069,G=0.0131", ": within the limits: ", 0},
               {"", "no acceptance limits set", 0}};
  for (const auto& c : cases) {
    std::ostringstream out;
    const RunOutcome end = verify_end(dir.path(), c.limits, out);
    EXPECT_EQ(end.exit_code, c.exit_code) << c.limits;
    EXPECT_EQ(end.session_dir, dir.path());
    EXPECT_FALSE(end.worse);
    // The verdict is the last line printed, after the table and the report's path.
    const std::string text = out.str();
    const std::size_t verdict = text.rfind("\ncirctest: ");
    ASSERT_NE(verdict, std::string::npos) << text;
    EXPECT_NE(text.find(c.word, verdict), std::string::npos) << text;
    EXPECT_NE(text.find("circtest: the hand-over report: "), std::string::npos) << text;
    EXPECT_EQ(text.substr(0, text.find("circtest: the hand-over report")), dir.read("verify.txt"));
    if (c.exit_code == 0 && *c.limits) EXPECT_EQ(text.substr(verdict + 1), said_within);
  }
}

// Before the marker came on there is nothing in the trace to search: each fault is named from
// the link's events, with the exit code of the same fault mid-run.
TEST(EarlyFault, EachFaultBeforeTheFirstRunIsNamed) {
  const auto limits = limits_xy();
  const std::string program = "/m/circtest-sessions/s/program.ngc";
  const std::string nothing = ": nothing was recorded; nothing analysed or applied";
  EarlyEnd e;
  e.end = "idle";
  e.line = 14;
  auto f = early_fault(e, program, limits);
  EXPECT_EQ(f.line,
            "the test is incomplete (the program was aborted at line 14 of program.ngc, "
            "before its first run was recorded)" +
                nothing);
  EXPECT_EQ(f.exit_code, 5);
  e.end = "estop";
  f = early_fault(e, program, limits);
  EXPECT_EQ(f.line,
            "the test is incomplete (E-stop at line 14 of program.ngc, before its first "
            "run was recorded)" +
                nothing);
  EXPECT_EQ(f.exit_code, 5);
  // LinuxCNC quitting: exit 7 as mid-run; the line unknown.
  e = EarlyEnd{};
  e.servo_stopped = true;
  f = early_fault(e, program, limits);
  EXPECT_EQ(f.line,
            "the test is incomplete (LinuxCNC quit in program.ngc, before its first run "
            "was recorded)" +
                nothing);
  EXPECT_EQ(f.exit_code, 7);
  e = EarlyEnd{};
  e.end = "gone";
  EXPECT_EQ(early_fault(e, program, limits).exit_code, 7);
}

// The machine off with joint 0's high mark 0.0523 over its MIN_FERROR 0.01: a following
// error of X; a high mark within MIN_FERROR, or none, is no following error.
TEST(EarlyFault, AFollowingErrorFromTheLinksHighMark) {
  const auto limits = limits_xy();
  EarlyEnd e;
  e.end = "off";
  e.line = 9;
  e.ferror = parse_ferror_event("0 0.052300");
  ASSERT_TRUE(e.ferror);
  auto f = early_fault(e, "program.ngc", limits);
  EXPECT_EQ(f.line,
            "the test is incomplete (joint 0 (X): a following error at line 9 of program.ngc, "
            "before its first run was recorded: its error reached 0.0523 mm, over [JOINT_0] "
            "MIN_FERROR 0.0100 (FERROR 0.0500 at MAX_VELOCITY); LinuxCNC switched the machine "
            "off): nothing was recorded; nothing analysed or applied");
  EXPECT_EQ(f.exit_code, 5);
  e.ferror = parse_ferror_event("0 0.009");
  f = early_fault(e, "program.ngc", limits);
  EXPECT_NE(f.line.find("the machine was switched off at line 9"), std::string::npos) << f.line;
  EXPECT_NE(f.line.find("no joint's following error high mark rose above its MIN_FERROR"),
            std::string::npos)
      << f.line;
  EXPECT_EQ(f.exit_code, 5);
  e.ferror.reset();
  EXPECT_EQ(early_fault(e, "program.ngc", limits).line, f.line);
  EXPECT_FALSE(parse_ferror_event("x 0.1"));
  EXPECT_FALSE(parse_ferror_event("0 0.1 2"));
  EXPECT_FALSE(parse_ferror_event("-1 0.1"));
  EXPECT_FALSE(parse_ferror_event("0 nan"));
}

// verify refuses a moved offset and says why it may have moved and what the session's was.
TEST(OffsetMoved, SaysTheSavedOffsetsAndTheSessionsOrigin) {
  const std::string m = offset_moved_message({10.0, 20.0, -5.0}, {10.0, 21.5, -5.0},
                                             "/m/s/work-origin.txt", "sim.var");
  EXPECT_NE(m.find("(Y was 20.0000 mm, is 21.5000 mm)"), std::string::npos) << m;
  EXPECT_EQ(m.find("X was"), std::string::npos) << m;
  EXPECT_NE(m.find("may not have saved its work offsets at the last shutdown"), std::string::npos);
  EXPECT_NE(m.find("parameter file sim.var"), std::string::npos) << m;
  EXPECT_NE(m.find("touch off again as for the first run"), std::string::npos) << m;
  EXPECT_NE(m.find("/m/s/work-origin.txt): X 10.0000 Y 20.0000 Z -5.0000"), std::string::npos) << m;
  EXPECT_NE(m.find("G10 L2 P1 X10.0000 Y20.0000 Z-5.0000"), std::string::npos) << m;
}
