#include <signal.h>

#include <fmt/format.h>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <ostream>

#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/progress.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace.hpp"
#include "circtest/session/linuxcnc.hpp"
#include "circtest/session/process.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// What the LinuxCNC link's event line means for the operator; sets END to the end event.
void show_event(const std::string& line, const RunRequest& request, std::ostream& out,
                RunProgress& progress, std::string& end, bool& override_changed) {
  const auto space = line.find(' ');
  const std::string kind = line.substr(0, space);
  const std::string rest = space == std::string::npos ? "" : line.substr(space + 1);
  if (kind == "run") {
    progress.started(std::atoi(rest.c_str()), now_s());
    return;
  }
  if (kind == "run-end") {
    progress.ended(now_s());
    return;
  }
  if (kind == "line" || kind == "resumed" || kind == "opened") return;
  progress.clear();
  if (kind == "end") {
    end = rest;
  } else if (kind == "waiting") {
    out << "circtest: the program is open in LinuxCNC: press cycle start on the machine\n";
  } else if (kind == "started") {
    out << "circtest: cycle start: the program runs\n";
  } else if (kind == "paused") {
    out << "circtest: operator pause (line " << rest << ")"
        << (request.start ? ": resumed\n"
                          : ": read its message on the machine's screen, press cycle start\n");
  } else if (kind == "override") {
    if (rest != "100") {
      override_changed = true;
      out << "circtest: feed override at " << rest
          << " %: the runs are not at their feed; this test will not be analysed\n";
    }
  }
  out.flush();
}

// The last value of a `# KEY: value` metadata line of the trace ("" when absent).
std::string trace_trailer(const std::string& trace, const std::string& key) {
  std::ifstream in(trace);
  std::string line, value;
  const std::string prefix = "# " + key + ": ";
  while (std::getline(in, line)) {
    if (line.rfind(prefix, 0) == 0) value = line.substr(prefix.size());
  }
  return value;
}

// A following error in what was recorded (the machine went off, or the program ended early),
// said in one line: true when there was one. A trace that cannot be read says nothing here.
bool said_following_error(const SessionSetup& setup, const std::string& trace, std::ostream& out) {
  try {
    TraceReadOptions options;
    options.check_time_monotonic = false;
    const auto error =
        find_following_error(read_trace(trace, options),
                             ferror_limits(IniDocument::load(setup.ini_path), setup.ini_path));
    if (!error) return false;
    out << "circtest: " << following_error_line(*error, trace) << "\n";
    return true;
  } catch (const Error&) {
    return false;
  }
}

// A fault before the first run was recorded (no run event, and the trace's trailer says no
// run, or there is no trace): said in one line; its exit code, none when a run was recorded.
std::optional<int> said_early_fault(const SessionSetup& setup, const std::string& program,
                                    const std::string& trace, const std::optional<int>& segment,
                                    const EarlyEnd& early, std::ostream& out) {
  std::error_code ec;
  const bool traced = std::filesystem::exists(trace, ec);
  const std::string runs = traced ? trace_trailer(trace, "runs") : std::string();
  if (segment || !(runs == "0" || !traced)) {
    return std::nullopt;
  }
  std::vector<FerrorLimit> limits;
  try {
    limits = ferror_limits(IniDocument::load(setup.ini_path), setup.ini_path);
  } catch (const Error&) {
    // Without the limits a following error is said as the machine switched off.
  }
  const EarlyFault fault = early_fault(early, program, limits);
  out << "circtest: " << fault.line << "\n";
  return fault.exit_code;
}

}  // namespace

RecordResult record_program(const SessionSetup& setup, const RunRequest& request,
                            const std::string& program, const std::string& trace,
                            const std::string& step, const Console& console) {
  std::ostream& out = console.print();
  if (clear_markers(setup.marker_output, setup.segment_output)) {
    out << "circtest: the marker output was on (an aborted program): switched off (M65 P"
        << setup.marker_output << ")\n";
  }
  // On a terminal the session's line shows the progress, and the recorder's own status line
  // (on the same terminal) is held back for the recording (its delay set beyond it).
  std::FILE* terminal = &out == &std::cout && is_terminal(stdout) ? stdout : nullptr;
  RunProgress progress(program, out, terminal, now_s());
  std::optional<std::string> delay;
  if (const char* d = std::getenv("CIRCTEST_PROGRESS_AFTER_S")) delay = d;
  if (terminal) ::setenv("CIRCTEST_PROGRESS_AFTER_S", "3600", 1);
  // Beside the trace, its live copy while it records (the panel's live plot): trace.csv's is
  // live.csv, verify-trace.csv's verify-live.csv.
  std::string live = trace;
  if (const auto at = live.rfind("trace.csv"); at != std::string::npos) {
    live.replace(at, 9, "live.csv");
  } else {
    live += ".live.csv";
  }
  Child recorder(
      {tool_path("circlog-record"), "-o", trace, "--live", live, "--columns",
       join(setup.columns, ","), "--program", program, "--ini", setup.ini_path, "--until-idle", "2",
       "--machine", setup.machine_title, "--condition", "circtest_step=" + step, "--condition",
       "circtest_session=" + std::filesystem::path(trace).parent_path().filename().string()},
      "-");
  if (terminal) {
    if (delay) {
      ::setenv("CIRCTEST_PROGRESS_AFTER_S", delay->c_str(), 1);
    } else {
      ::unsetenv("CIRCTEST_PROGRESS_AFTER_S");
    }
  }
  if (const int rc = recorder.wait_for(0.5); rc >= 0) {
    out << "circtest: circlog-record stopped at once (exit " << rc << "): nothing was run\n";
    return {rc == 0 ? 7 : rc};
  }
  std::vector<std::string> link = {tool_path("circtest-linuxcnc"),
                                   "run",
                                   program,
                                   "--timeout",
                                   fmt::format("{}", request.timeout_s),
                                   "--marker",
                                   std::to_string(setup.marker_output),
                                   "--segment",
                                   std::to_string(setup.segment_output)};
  if (request.start) link.push_back("--start");
  Child linuxcnc(link, "");
  const RunFigures figures(
      live, evaluated_columns(setup, request.program.planes),
      (std::filesystem::path(trace).parent_path() / ".run-figures.csv").string());
  std::string line, end;
  std::optional<int> segment;  // the run the marker is on for
  EarlyEnd early;              // what the link said, for a fault before the first run
  bool override_changed = false;
  bool recorder_done = false;  // it ended by itself: every announced run recorded, then idle
  for (;;) {
    const auto got = linuxcnc.read_line_for(line, 0.2);
    if (got && !*got) break;
    if (got) {
      if (line.rfind("run ", 0) == 0) segment = std::atoi(line.c_str() + 4);
      if (line.rfind("line ", 0) == 0) early.line = std::atoi(line.c_str() + 5);
      if (line.rfind("ferror ", 0) == 0) early.ferror = parse_ferror_event(line.substr(7));
      show_event(line, request, out, progress, end, override_changed);
      if (line == "run-end" && segment) {
        if (const auto said = figures.finished(*segment)) {
          out << "circtest: " << progress.what(*segment) << ": " << *said << "\n" << std::flush;
        }
      }
    }
    progress.update(now_s());
    if (got) continue;
    // The recorder stops with the servo thread: LinuxCNC quit (its status may stay as it was);
    // or by itself once every run is in (the program's retract may still run).
    if (!recorder_done && !recorder.running()) {
      recorder_done = trace_trailer(trace, "stop_reason") == "idle";
      if (recorder_done) continue;
      linuxcnc.signal(SIGTERM);
      linuxcnc.wait();
      progress.clear();
      early.servo_stopped = true;
      if (const auto said = said_early_fault(setup, program, trace, segment, early, out)) {
        return {*said};
      }
      out << "circtest: the test is incomplete (the servo thread stopped: LinuxCNC quit?): "
          << trace << " keeps what was recorded; nothing analysed or applied\n";
      return {7};
    }
  }
  const int link_rc = linuxcnc.wait();
  progress.clear();
  early.end = end;
  if (end == "idle" && !segment) {
    // The program ended before the marker came on: an abort before the first run (nothing
    // for the recorder to wait for).
    recorder.signal(SIGINT);
    recorder.wait();
    if (const auto said = said_early_fault(setup, program, trace, segment, early, out)) {
      return {*said};
    }
  }
  if (end == "idle" && !override_changed) {
    // The recorder ends by itself once every announced run is in and the marker stays off.
    int rc = recorder.wait_for(10);
    if (rc < 0) {
      recorder.signal(SIGINT);
      rc = recorder.wait();
    }
    const std::string missing = trace_trailer(trace, "runs_missing");
    if (!missing.empty() && missing != "none") {
      if (said_following_error(setup, trace, out)) return {5};
      out << "circtest: the test is incomplete (the program ended before every run was "
             "recorded: aborted?): runs "
          << missing << "; " << trace << " keeps what was recorded; nothing analysed or applied\n";
      return {5};
    }
    if (rc == 8) {
      out << "circtest: the recorder lost samples (see above): " << trace
          << " is kept; nothing analysed or applied\n";
    } else if (rc != 0) {
      out << "circtest: the recorder failed (exit " << rc << "); nothing analysed or applied\n";
    } else {
      out << "circtest: recorded " << trace << "\n";
      rc = check_servo_periods(setup, trace, out);
    }
    return {rc};
  }
  recorder.signal(SIGINT);
  recorder.wait();
  if (!override_changed) {
    if (const auto said = said_early_fault(setup, program, trace, segment, early, out)) {
      return {*said};
    }
  }
  if (end == "off" && said_following_error(setup, trace, out)) return {5};
  const std::string why = end.empty() ? "the LinuxCNC link stopped" : end;
  out << "circtest: the test is incomplete ("
      << (override_changed ? "feed override not 100 %" : why) << "): " << trace
      << " keeps what was recorded; nothing analysed or applied\n";
  return {link_rc == 7 ? 7 : 5};
}

}  // namespace circtest::session
