#pragma once
// circlog-record without HAL: the G-code header, and the loop that drains a circlog ring into
// a trace, run from a RecordRequest (app/options.cpp turns the command line into one). The
// executable supplies the ring (shared memory of the loaded module, hal_recording.cpp) and the
// clock; the unit tests supply a ring in heap memory and a fake clock.
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "circlog_kernel.hpp"
#include "circtest/core/plane.hpp"

namespace circtest::circlog_record {

// A measured run a program announces: circgen's `segments` header ("1:CCW:F500,2:CW:F500"),
// one entry per run in program order; a test set's entries name their plane
// ("1:CCW:F500:XY,...,5:CCW:F500:YZ").
struct AnnouncedRun {
  int segment_id = 0;
  Direction direction = Direction::CCW;
  double feed_per_min = 0.0;   // in the program's units
  std::string label;           // "CCW F500", as the header writes it ("CCW F500 XY" in a set)
  std::optional<Plane> plane;  // a test set's entry: its plane
};

// What the recorder takes from the G-code program (--program).
struct ProgramPlan {
  std::vector<std::pair<std::string, std::string>> header;  // (key: value) comments, in order
  std::vector<AnnouncedRun> runs;                           // empty: none announced
  // The longest pause the program plans between the end of one run and the start of the
  // next of the same plane (lead arcs, radial moves, the way back, the dwell at the feeds
  // written), when the header says enough to compute it.
  std::optional<double> longest_pause_s;
};

// Whether the program pauses for the operator before announced run K: a test set's first run
// of a plane after another plane's runs (the operator mounts or re-orients the instrument).
bool operator_pause_before(const ProgramPlan& plan, std::size_t k);

// How long --until-idle waits with enable false while an announced run is still missing,
// when the header does not say enough to compute it.
inline constexpr double kDefaultRunWait_s = 120.0;
// The largest wait the recorder accepts (--until-idle, --run-wait): a day.
inline constexpr double kMaxWait_s = 86400.0;

// What to record and how: circlog-record's command line (app/options.cpp) parsed and checked.
struct RecordRequest {
  std::string output;
  std::vector<std::string> columns;                               // empty: in-00, in-01, ...
  std::vector<std::pair<std::string, std::string>> descriptions;  // channel name, text
  std::optional<double> duration_s;
  std::optional<double> idle_s;  // --until-idle
  std::string program;           // G-code file whose (key: value) header is copied
  ProgramPlan program_plan;      // read from `program` (read_program_plan)
  // --run-wait: with enable false this long while an announced run is missing, the program
  // has ended without it; unset: twice the program's longest pause plus 10 s.
  std::optional<double> run_wait_s;
  std::string ini;  // the machine's INI: its path and SHA-256 go into the metadata
  // --machine, --operator, ...: metadata key and value; they win over the program header.
  std::vector<std::pair<std::string, std::string>> conditions;
  int decimals = 6;
  double poll_s = 0.005;
  // --progress-to: a terminal for the status line when stderr is not one (circtest-run, whose
  // LinuxCNC output goes to a log, passes its own terminal).
  std::string progress_to;
  // --live: a copy of the trace's text that grows while it records, every kLiveFlush_s (the
  // QtVCP panel's live plot reads it); the trace at `output` is still written whole at the end.
  std::string live;
};

// How often the live copy (--live) gets the rows recorded since the last time.
inline constexpr double kLiveFlush_s = 0.1;

// Whether KEY is a metadata key the recorder writes itself (sample_period_s, rows, ...): a
// program header or --condition may not state it.
bool recorder_key(std::string_view key);

// TEXT cut at each SEPARATOR, empty items kept ("a,,b," gives a, "", b, "").
std::vector<std::string> split_on(const std::string& text, char separator);

// The `(key: value)` comments at the top of a G-code program (before its first line of
// code), in file order. Throws IoError.
std::vector<std::pair<std::string, std::string>> read_program_header(const std::string& path);

// The header, the announced runs and the planned pauses of a program. Throws IoError, and
// ParseError (file and line) for a `segments` entry that is not ID:DIRECTION:FFEED or
// ID:DIRECTION:FFEED:PLANE (XY, YZ or ZX) with a positive whole ID given once.
ProgramPlan read_program_plan(const std::string& path);

// How long --until-idle waits, enable false, for a run that is still missing.
double run_wait_s(const RecordRequest& options);
// The same for announced run K: before a test set's plane (operator_pause_before) the
// operator's pause has no planned length, so the wait is --run-wait when given, else
// kMaxWait_s (end it with Ctrl-C).
double run_wait_s(const RecordRequest& options, std::size_t k);

// What the loop needs from the world outside the ring.
class Environment {
 public:
  virtual ~Environment() = default;
  virtual void sleep(double seconds) = 0;
  virtual double monotonic_s() = 0;
  virtual bool stop_requested() = 0;  // SIGINT/SIGTERM arrived
  virtual bool process_alive(std::int32_t pid) = 0;
  virtual std::string utc_now_iso8601() = 0;
};

struct Summary {
  std::size_t rows = 0;
  std::uint64_t runs = 0;
  std::uint64_t overruns = 0;  // the module's overrun counter over the recording
  std::uint64_t gaps = 0;      // places where records are missing
  std::uint64_t lost = 0;      // records missing in all
  std::string stop_reason;
  // Announced runs (ProgramPlan::runs) the trace does not hold whole, e.g. "2 (CW F1000)";
  // the caller reports them and exits non-zero.
  std::vector<std::string> missing_runs;
};

// The terminal at PATH (--progress-to), opened for writing without creating or truncating
// anything; UsageError when it is not a terminal.
std::FILE* open_progress_terminal(const std::string& path);

// Claims the ring, writes request.output (an unnamed temporary that appears there when complete)
// and returns what happened. Lost records are reported on `log` and in the trailer metadata; the
// caller decides the exit code. Throws HalError when the ring cannot be used (no servo thread,
// another reader), IoError for the file.
// While it records, a status line (elapsed, samples, runs, the run it waits for) goes to
// PROGRESS, else to `log` when that is a terminal.
Summary record(circlog::Consumer& ring, std::int32_t pid, const RecordRequest& request,
               Environment& env, std::FILE* log, std::FILE* progress = nullptr);

// Records REQUEST from the circlog module loaded in the running HAL (hal_recording.cpp, linked
// only into circlog-record): the ring, the signals, the summary line on stderr. Throws HalError
// when HAL or circlog is not there, and an Error with ExitCode::data_loss when samples or
// announced runs are missing (the trace is then complete up to where it stopped).
void record_from_hal(const RecordRequest& request);

}  // namespace circtest::circlog_record
