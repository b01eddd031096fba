#pragma once
// `circtest run` and `circtest verify`: the circular test on the LinuxCNC the user runs, in
// one session folder beside the configuration (CONFIGDIR/circtest-sessions/MACHINE-UTC/).
#include <optional>
#include <string>
#include <vector>

#include "circtest/session/console.hpp"

namespace circtest::session {

// The test program circgen writes (its settings; empty/nullopt: circgen's default).
struct TestProgram {
  double diameter_mm = 100;
  double feed_mm_per_min = 1000;
  std::string feeds_mm_per_min;  // "500,1000,2000": a feed sweep instead of the one feed
  std::string planes;            // "XY", or a test set "XY,YZ,ZX"
  std::string centre_mm;         // "X,Y,Z" in the work offset
  std::string clearance_mm;      // on the plane's normal axis, in the work offset
};

struct RunRequest {
  std::string ini_path;
  TestProgram program;
  bool start = false;         // start the program and answer its operator pauses
  double timeout_s = 3600.0;  // the longest the program may take from cycle start
  // Acceptance limits, "H=0.015,G=0.02" as circana report --limits takes them; empty: run
  // sets none, verify takes the session's (limits.txt).
  std::string limits;
};

struct RunOutcome {
  int exit_code = 0;
  std::string session_dir;
  bool applied = false;  // corrections written: LinuxCNC must restart, then verify
  bool worse = false;    // verify: the machine measures worse than before
};

// Checks the machine, writes the program, runs and records it, analyses, diagnoses, plans and
// (asked, or with console.yes) applies. Throws HalError (exit 7) when a check fails or
// LinuxCNC/circlog cannot be reached; the programs' own refusals pass their exit code on.
RunOutcome run_session(const RunRequest& request, const Console& console);

// The latest session of the configuration with corrections applied, its program run again:
// before/after, the hand-over report. Throws DataError when there is no such session. With
// limits its exit code is its verdict: 9 (tolerance) unless every limit passes, once
// everything is written and printed.
RunOutcome verify_session(const RunRequest& request, const Console& console);

}  // namespace circtest::session
