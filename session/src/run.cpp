#include "circtest/session/run.hpp"

#include <signal.h>

#include <fmt/format.h>
#include <algorithm>
#include <cctype>
#include <ctime>
#include <filesystem>
#include <ostream>
#include <sstream>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/session/linuxcnc.hpp"
#include "circtest/session/process.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace fs = std::filesystem;

namespace {

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string w; std::getline(in, w, ',');) out.emplace_back(trim(w));
  return out;
}

std::string utc_stamp() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%dT%H%M%SZ", &tm);
  return buf;
}

std::string safe_name(const std::string& text) {
  std::string out;
  for (char c : text) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.';
    out += ok ? c : '_';
  }
  return out.empty() ? "machine" : out;
}

// circgen's command line for the program.
std::vector<std::string> circgen_args(const RunRequest& r, const MachineState& state,
                                      const SessionSetup& setup, const std::string& program) {
  std::vector<std::string> a = {tool_path("circgen"), "--d",
                                fmt::format("{}", r.program.diameter_mm)};
  if (r.program.feeds_mm_per_min.empty()) {
    a.insert(a.end(), {"--f", fmt::format("{}", r.program.feed_mm_per_min)});
  } else {
    a.insert(a.end(), {"--feeds", r.program.feeds_mm_per_min});
  }
  if (!r.program.planes.empty()) a.insert(a.end(), {"--plane", r.program.planes});
  if (!r.program.centre_mm.empty()) a.insert(a.end(), {"--centre", r.program.centre_mm});
  if (!r.program.clearance_mm.empty()) a.insert(a.end(), {"--clearance", r.program.clearance_mm});
  const auto& o = state.work_origin_machine_mm;
  a.insert(a.end(), {"--ini", r.ini_path, "--offset", fmt::format("{},{},{}", o[0], o[1], o[2]),
                     "--offset-from-linuxcnc", "--marker", std::to_string(setup.marker_output),
                     "--segment-out", std::to_string(setup.segment_output), "-o", program});
  return a;
}

}  // namespace

SessionSetup read_setup(const std::string& ini_path) {
  const IniDocument ini = IniDocument::load(ini_path);
  SessionSetup s;
  s.ini_path = ini_path;
  s.config_dir = fs::absolute(ini_path).parent_path().string();
  const auto columns = ini.get("CIRCTEST", "COLUMNS");
  const bool installed = ini.get("CIRCTEST", "MARKER_OUTPUT").has_value();
  if (!columns || !installed) {
    throw HalError(ini_path +
                   ": circlog is not installed in this configuration ([CIRCTEST] "
                   "COLUMNS and MARKER_OUTPUT missing): circtest install first");
  }
  s.columns = split(*columns);
  s.marker_output = std::stoi(ini.get("CIRCTEST", "MARKER_OUTPUT").value_or("0"));
  s.segment_output = std::stoi(ini.get("CIRCTEST", "SEGMENT_OUTPUT").value_or("0"));
  s.machine_title = ini.get("EMC", "MACHINE").value_or("machine");
  s.machine = safe_name(s.machine_title);
  // Not a number: the trace's sample_period_s gives the period.
  if (const auto period = ini.get("EMCMOT", "SERVO_PERIOD"))
    s.servo_period_ns = parse_finite(*period);
  if (const auto late = ini.find("CIRCTEST", "LATE_SERVO_PERIODS")) {
    if (late->value != "refuse" && late->value != "note") {
      throw DataError(late->file, late->line,
                      "[CIRCTEST] LATE_SERVO_PERIODS = " + late->value +
                          ": expected refuse (a real machine) or note (a simulated one)");
    }
    s.late_periods_noted = late->value == "note";
  }
  return s;
}

std::vector<std::string> evaluated_columns(const SessionSetup& setup, const std::string& planes) {
  const std::string plane = planes.empty() ? "XY" : planes.substr(0, 2);
  if (planes.find(',') != std::string::npos) return {};
  std::string a(1, static_cast<char>(std::tolower(plane[0])));
  std::string b(1, static_cast<char>(std::tolower(plane[1])));
  const auto has = [&](const std::string& c) {
    return std::find(setup.columns.begin(), setup.columns.end(), c) != setup.columns.end();
  };
  if (has(a) && has(b)) return {};
  return {"--columns", a + "_fb," + b + "_fb"};
}

RunOutcome run_session(const RunRequest& request, const Console& console) {
  std::ostream& out = console.print();
  if (!request.limits.empty()) check_limits(request.limits);
  const SessionSetup setup = read_setup(request.ini_path);
  const MachineState state = machine_state();
  require_ready(state, request.ini_path);
  require_circlog(setup.columns.size());
  out << "circtest: LinuxCNC runs " << request.ini_path
      << ": on, homed, idle, feed override 100 %, circlog fed\n";

  RunOutcome outcome;
  const fs::path dir =
      fs::path(setup.config_dir) / "circtest-sessions" / (setup.machine + "-" + utc_stamp());
  fs::create_directories(dir);
  outcome.session_dir = dir.string();
  out << "circtest: session folder " << dir.string() << "\n";
  const std::string program = (dir / "program.ngc").string();
  if (const int rc = run_program(circgen_args(request, state, setup, program)); rc != 0) {
    // circgen refused (its message above): no test took place, no session to keep.
    std::error_code ec;
    fs::remove_all(dir, ec);
    outcome.exit_code = rc;
    outcome.session_dir.clear();
    return outcome;
  }
  write_file_atomic((dir / "work-origin.txt").string(),
                    fmt::format("{} {} {}\n", state.work_origin_machine_mm[0],
                                state.work_origin_machine_mm[1], state.work_origin_machine_mm[2]));
  if (!request.limits.empty()) session_limits(dir.string(), request.limits);
  out << "circtest: program " << program << " (checked against the soft limits from the work "
      << "offset in use)\n";
  const RecordResult rec =
      record_program(setup, request, program, (dir / "trace.csv").string(), "run", console);
  if (rec.exit_code != 0) {
    outcome.exit_code = rec.exit_code;
    return outcome;
  }
  outcome.exit_code = analyse_and_apply(setup, request, dir.string(), console, outcome.applied);
  if (outcome.exit_code == 0) {
    out << "circtest: "
        << verdict_line(read_file((dir / "results.json").string()),
                        read_file((dir / "diagnosis.json").string()), request.limits)
        << "\n";
  }
  return outcome;
}

}  // namespace circtest::session
