#pragma once
// The steps of a session, shared by run and verify (internal to the session library).
#include <array>
#include <cstddef>
#include <iosfwd>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "circtest/core/ini.hpp"
#include "circtest/core/progress.hpp"
#include "circtest/core/trace.hpp"
#include "circtest/session/console.hpp"
#include "circtest/session/run.hpp"

namespace circtest::session {

// The words of a line or an INI value, split at white space (as halcmd and the linuxcnc
// script split them).
std::vector<std::string> words_of(const std::string& line);

// What install wrote into the INI ([CIRCTEST]) and where the session lives.
struct SessionSetup {
  std::string ini_path;
  std::string config_dir;
  std::vector<std::string> columns;
  int marker_output = 0;
  int segment_output = 0;
  std::string machine;                    // [EMC] MACHINE, as a file name
  std::string machine_title;              // [EMC] MACHINE as it is written (the trace's metadata)
  std::optional<double> servo_period_ns;  // [EMCMOT] SERVO_PERIOD
  // [CIRCTEST] LATE_SERVO_PERIODS = note: late periods are said but do not stop the session
  // (a simulated machine, whose motion is computed per servo period: a late period delays
  // the run but changes nothing it measures); absent or `refuse`: they stop it.
  bool late_periods_noted = false;
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
// STEP ("run", "verify") and the session folder's name go into the trace's metadata
// (circtest_step, circtest_session), and so into the history's conditions.
RecordResult record_program(const SessionSetup& setup, const RunRequest& request,
                            const std::string& program, const std::string& trace,
                            const std::string& step, const Console& console);

// A joint's following-error limit as LinuxCNC's motion applies it ([JOINT_n] FERROR at
// MAX_VELOCITY, never below MIN_FERROR; machine units, [TRAJ] LINEAR_UNITS).
struct FerrorLimit {
  int joint = 0;
  char axis = 'X';
  double ferror = 1.0;
  double min_ferror = 1.0;
  double max_velocity = 1.0;
  std::string units = "mm";
};
// Each joint's limit (LinuxCNC's defaults where a key is absent); ParseError for a value that
// is not a number of 0 or more.
std::vector<FerrorLimit> ferror_limits(const IniDocument& ini, const std::string& ini_path);
struct FollowingError {
  int joint = 0;
  char axis = 'X';
  double error = 0;  // |x_cmd - x_fb|, machine units
  double limit = 0;  // the limit at that sample's commanded velocity
  double time_s = 0;
  std::size_t line = 0;  // the trace's line of the sample
  std::string units;
};
// The sample whose following error is furthest over its limit (x_cmd - x_fb of each logged
// axis, the command's velocity from one sample to the next), none when every one is within;
// none also when the trace has no t column or no sample_period_s.
std::optional<FollowingError> find_following_error(const Trace& trace,
                                                   const std::vector<FerrorLimit>& limits);
// What the session says of it, in one line (without the "circtest: " prefix).
std::string following_error_line(const FollowingError& error, const std::string& trace);

// The LinuxCNC link's `ferror JOINT ERROR` event: a joint whose following error high mark
// (LinuxCNC's ferror_highmark) rose during the program above its MIN_FERROR, said before
// `end off`.
struct LinkFerror {
  int joint = 0;
  double error = 0;  // machine units
};
// None when REST is not "JOINT ERROR".
std::optional<LinkFerror> parse_ferror_event(const std::string& rest);
// How a program ended before its first run was recorded (the trace's runs: 0).
struct EarlyEnd {
  std::string end;             // the link's end event: idle, estop, off, gone, timeout, error ...
  bool servo_stopped = false;  // the recorder stopped with the servo thread: LinuxCNC quit
  int line = 0;                // the program's line LinuxCNC last reported, 0 none
  std::optional<LinkFerror> ferror;
};
struct EarlyFault {
  std::string line;   // what the session says, without the "circtest: " prefix
  int exit_code = 5;  // as the same fault mid-run: 7 LinuxCNC quit, else 5
};
// Names the fault in one line: an abort (idle), an E-stop, a following error (off with the
// link's ferror over the joint's MIN_FERROR of LIMITS), the machine off otherwise, LinuxCNC
// quitting, a timeout.
EarlyFault early_fault(const EarlyEnd& end, const std::string& program,
                       const std::vector<FerrorLimit>& limits);

// verify's refusal when the work offset is not the session's (per axis more than
// kSameOriginMm apart): which axes moved, that LinuxCNC may not have saved its offsets at the
// last shutdown (PARAMETER_FILE: [RS274NGC] PARAMETER_FILE), what to do, and the session's
// offset (ORIGIN_FILE: work-origin.txt).
inline constexpr double kSameOriginMm = 1e-6;
std::string offset_moved_message(const std::array<double, 3>& recorded_mm,
                                 const std::array<double, 3>& now_mm,
                                 const std::string& origin_file, const std::string& parameter_file);

// circana report's options for LIMITS: none when empty.
std::vector<std::string> limits_args(const std::string& limits);

// The session's acceptance limits: `--limits` as circana report takes them
// (H=MM,G=MM,F=MM,backlash=MM,squareness=URAD), kept as limits.txt in the session folder.
inline constexpr const char* kLimitsFile = "limits.txt";
// Throws UsageError (exit 2) naming --limits for text circana report would refuse.
void check_limits(const std::string& text);
// GIVEN not empty: written to DIR/limits.txt (run's, or verify's override) and returned;
// else the limits kept there, empty when none.
std::string session_limits(const std::string& dir, const std::string& given);
// The verdict of a test (circana analyze's result JSON text, circana diagnose's JSON text or
// empty) against LIMITS, by ISO 14253-1 with U as the report decides it: "verdict against
// H=0.015 (ISO 14253-1, U k = 2): within the limits: H 5.6 + U 1.2 <= 15.0 um"; OUT OF
// TOLERANCE when one fails or is not measured (as the report's banner), NOT DECIDED when one
// is not decided; a line saying there is none without limits.
std::string verdict_line(const std::string& results_text, const std::string& diagnosis_text,
                         const std::string& limits);
// The same verdict with its word: none (no limits), within the limits, NOT DECIDED, OUT OF
// TOLERANCE; LINE is verdict_line's.
struct SessionVerdict {
  enum class Word { none, within, not_decided, out_of_tolerance };
  Word word = Word::none;
  std::string line;
};
SessionVerdict session_verdict(const std::string& results_text, const std::string& diagnosis_text,
                               const std::string& limits);
// verify's exit status by its verdict, by circana history --limits' rule: 9 (tolerance) unless
// every limit passes (NOT DECIDED and a limit not measured fail too); 0 within the limits and
// without limits. run's verdict (of the machine before any correction) leaves its exit at 0.
int verify_exit_code(SessionVerdict::Word word);

// The servo thread's periods in a trace: the servo_period channel (circtest install:
// motion.servo.last-period, CPU clocks in LinuxCNC 2.9, ns later) against the thread's own
// period. A period longer than kLatePeriodFactor times it is late: the thread
// woke late (a latency problem of the PC), so the samples around it are not a servo period
// apart and the run does not measure the machine.
inline constexpr double kLatePeriodFactor = 1.5;
struct ServoPeriods {
  bool logged = false;  // the trace has the channel
  std::size_t samples = 0;
  double nominal_ns = 0;  // the thread's period
  std::size_t late = 0;   // periods longer than kLatePeriodFactor * nominal_ns
  double longest_ns = 0;
  bool unit_is_ns = true;      // the column's mean is the nominal period in ns
  double units_per_us = 1000;  // else CPU clocks: the column's mean over the nominal period
};
// The nominal period is the trace's sample_period_s, else INI_PERIOD_NS. Throws DataError when
// the channel is there and neither is known.
ServoPeriods servo_periods(const Trace& trace, std::optional<double> ini_period_ns);
// What the session says of them, in one line (without the "circtest: " prefix); NOTED: late
// periods are noted only (SessionSetup::late_periods_noted).
std::string servo_period_line(const ServoPeriods& periods, bool noted = false);
// The session folder's record of them (servo-period.json).
std::string servo_period_json(const ServoPeriods& periods, const std::string& trace_name,
                              bool noted = false);
// Reads TRACE's periods, writes servo-period.json beside it (verify-servo-period.json for
// verify-trace.csv), says the line; exit 5 (data) when a period was late (and they are not
// noted only), else 0.
int check_servo_periods(const SessionSetup& setup, const std::string& trace, std::ostream& out);

// What the operator sees while the program runs: "XY run 1 of 2 (CCW F1000): 37 % of the
// path", from the program's header (its runs, radius, arc, feeds) and the LinuxCNC link's
// `run SEGMENT` / `run-end` events. On a terminal (TERMINAL not null) one line redrawn in
// place; else a plain line on OUT at the start of each run, at each quarter of its path and at
// its end. The share of the path is the time since the run's start against its measured arc
// at its feed (the override is at 100 %), held below 100 until the run ends.
class RunProgress {
 public:
  RunProgress(const std::string& program, std::ostream& out, std::FILE* terminal, double now_s);
  void started(int segment, double now_s);
  void ended(double now_s);  // says the run is recorded
  void update(double now_s);
  void clear();  // before another message
  std::string status(double now_s) const;
  std::string what(int segment) const;  // "XY run 1 of 2 (CCW F1000)"

 private:
  struct Run {
    int segment = 0;
    std::string what;  // "XY run 1 of 2 (CCW F1000)"
    double duration_s = 0;
  };
  static constexpr int kPlainStep = 25;
  const Run* find(int segment) const;
  std::optional<int> percent(double now_s) const;
  std::ostream& out_;
  ProgressLine line_;
  std::vector<Run> runs_;
  std::optional<int> current_;
  double started_s_ = 0;
  int next_step_ = kPlainStep;
};

// The figures of each run as soon as it has finished (run_figures.cpp): TEXT, a live copy of
// a trace, through the last row of SEGMENT's run (its marker on), whole lines only; none when
// that run has no row in it or the text no segment column.
std::optional<std::string> trace_through_run(const std::string& text, int segment);
// "G 12.3 um (U 0.8 um)" of SEGMENT's run in circana's result JSON, with ", H ..." when the
// run completes a CCW/CW pair; none when the result has no G for it.
std::optional<std::string> run_figures_line(const std::string& result_json, int segment);
// At a run's end: the live copy LIVE through that run, evaluated by circana analyze (with
// COLUMNS, its column options) from the snapshot file SCRATCH (removed again); none when
// circana cannot evaluate it (then the figures come with the evaluation after the program).
class RunFigures {
 public:
  RunFigures(std::string live, std::vector<std::string> columns, std::string scratch)
      : live_(std::move(live)), columns_(std::move(columns)), scratch_(std::move(scratch)) {}
  std::optional<std::string> finished(int segment) const;

 private:
  std::string live_;
  std::vector<std::string> columns_;
  std::string scratch_;
};

// circana analyze and diagnose, circcomp plan; asks, applies. APPLIED: corrections written.
int analyse_and_apply(const SessionSetup& setup, const RunRequest& request, const std::string& dir,
                      const Console& console, bool& applied);

// The G (largest of the runs, mm) and H (mm, or negative when none) of a circana result JSON,
// with their expanded uncertainties U (k = 2; empty when the document has none).
struct Figures {
  double h_mm = -1;
  double g_mm = -1;
  std::optional<double> u_h_mm;
  std::optional<double> u_g_mm;
};
Figures read_figures(const std::string& results_json);
// The verify's table: H and G before and after, each with its U (k = 2), "not known" where
// the document has none, "-" where the value is missing.
std::string verify_table(const Figures& before, const Figures& after);
// Whether AFTER is worse than BEFORE in G or H by more than two runs of an unchanged machine
// differ (5 % + 0.5 um).
bool got_worse(const Figures& before, const Figures& after);
// verify's end, its test evaluated in the session folder SESSION_DIR (results.json,
// verify-results.json, verify-diagnosis.json, report.html): prints the before/after table
// (written to verify.txt), the report's path, the verdict line against LIMITS and whether the
// machine got worse; exit code by the verdict (verify_exit_code).
RunOutcome verify_end(const std::string& session_dir, const std::string& limits, std::ostream& out);

}  // namespace circtest::session
