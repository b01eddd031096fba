#pragma once
// The steps of a session, shared by run and verify (internal to the session library).
#include <string>
#include <vector>

#include "circtest/session/console.hpp"
#include "circtest/session/run.hpp"

namespace circtest::session {

// What install wrote into the INI ([CIRCTEST]) and where the session lives.
struct SessionSetup {
  std::string ini_path;
  std::string config_dir;
  std::vector<std::string> columns;
  int marker_output = 0;
  int segment_output = 0;
  std::string machine;        // [EMC] MACHINE, as a file name
  std::string machine_title;  // [EMC] MACHINE as it is written (the trace's metadata)
};

// Throws HalError when circtest install has not been applied to the INI.
SessionSetup read_setup(const std::string& ini_path);

// circana's column choice: none when the trace has the plane's instrument columns (x, y),
// else the motor feedback ("--columns x_fb,y_fb").
std::vector<std::string> evaluated_columns(const SessionSetup& setup, const std::string& planes);

struct RecordResult {
  int exit_code = 0;  // 0: the program ran to its end and every run was recorded
};

// Opens PROGRAM in LinuxCNC, records it into TRACE while it runs (the operator's cycle start,
// or request.start), and says what happened; a run that ends otherwise (abort, E-stop,
// feed override changed, LinuxCNC gone, samples lost) keeps the trace and returns non-zero.
RecordResult record_program(const SessionSetup& setup, const RunRequest& request,
                            const std::string& program, const std::string& trace,
                            const Console& console);

// circana analyze and diagnose, circcomp plan; asks, applies. APPLIED: corrections written.
int analyse_and_apply(const SessionSetup& setup, const RunRequest& request, const std::string& dir,
                      const Console& console, bool& applied);

// The G (largest of the runs, mm) and H (mm, or negative when none) of a circana result JSON.
struct Figures {
  double h_mm = -1;
  double g_mm = -1;
};
Figures read_figures(const std::string& results_json);
// Whether AFTER is worse than BEFORE in G or H by more than two runs of an unchanged machine
// differ (5 % + 0.5 um).
bool got_worse(const Figures& before, const Figures& after);

}  // namespace circtest::session
