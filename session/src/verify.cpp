#include <fmt/format.h>
#include <array>
#include <cmath>
#include <filesystem>
#include <ostream>
#include <sstream>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/session/linuxcnc.hpp"
#include "circtest/session/process.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace fs = std::filesystem;

namespace {

// The latest session folder (their names sort by UTC time) whose corrections were applied.
fs::path latest_applied(const SessionSetup& setup) {
  const fs::path root = fs::path(setup.config_dir) / "circtest-sessions";
  fs::path best;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec)) {
    if (!fs::exists(e.path() / "apply.txt") || !fs::exists(e.path() / "program.ngc")) continue;
    if (best.empty() || e.path().filename() > best.filename()) best = e.path();
  }
  if (best.empty()) {
    throw DataError(root.string(), 0,
                    "no session with corrections applied: run the test first (circtest run)");
  }
  return best;
}

// The same work offset as the session's run: the program's soft-limit check holds for it.
void require_same_origin(const fs::path& dir, const MachineState& state,
                         const SessionSetup& setup) {
  const fs::path file = dir / "work-origin.txt";
  std::istringstream in(read_file(file.string()));
  std::array<double, 3> recorded{};
  for (double& v : recorded) {
    if (!(in >> v)) throw ParseError(file.string(), 1, "expected the X, Y and Z of the offset");
  }
  for (std::size_t i = 0; i < 3; ++i) {
    if (std::abs(recorded[i] - state.work_origin_machine_mm[i]) > kSameOriginMm) {
      const IniDocument ini = IniDocument::load(setup.ini_path);
      throw HalError(offset_moved_message(recorded, state.work_origin_machine_mm, file.string(),
                                          ini.get("RS274NGC", "PARAMETER_FILE").value_or("")));
    }
  }
}

// verify-trace.csv evaluated (verify-results.json), diagnosed (verify-diagnosis.json),
// stored in the history as run's test is (verify-history.txt; a failure there is a note),
// and the hand-over report of after and before with LIMITS.
int evaluate_verify(const SessionSetup& setup, const RunRequest& request, const fs::path& dir,
                    const std::string& limits, std::ostream& out) {
  const std::string after = (dir / "verify-trace.csv").string();
  std::vector<std::string> columns = evaluated_columns(setup, request.program.planes);
  const std::string circana = tool_path("circana");
  const auto with_columns = [&columns](std::vector<std::string> argv) {
    argv.insert(argv.end(), columns.begin(), columns.end());
    return argv;
  };
  if (const int rc = run_program(with_columns({circana, "analyze", after, "--json"}),
                                 (dir / "verify-results.json").string());
      rc != 0) {
    return rc;
  }
  if (const int rc = run_program(with_columns({circana, "diagnose", after, "--json"}),
                                 (dir / "verify-diagnosis.json").string());
      rc != 0) {
    return rc;
  }
  if (const int rc = run_program(with_columns({circana, "diagnose", after, "--store"}),
                                 (dir / "verify-history.txt").string());
      rc != 0) {
    out << "circtest: note: the verify test is not stored in the history (circana exit " << rc
        << ", see above)\n";
  }
  std::vector<std::string> report =
      with_columns({circana, "report", after, (dir / "trace.csv").string(), "-o",
                    (dir / "report.html").string()});
  const auto l = limits_args(limits);
  report.insert(report.end(), l.begin(), l.end());
  return run_program(report, (dir / "report.txt").string());
}

std::string um(double mm) {
  return mm < 0 ? "-" : fmt::format("{:.1f} um", mm * 1000);
}

}  // namespace

std::string verify_table(const Figures& before, const Figures& after) {
  const auto u = [](double value_mm, const std::optional<double>& u_mm) {
    if (value_mm < 0) return std::string("-");
    return u_mm ? fmt::format("{:.1f}", *u_mm * 1000) : std::string("not known");
  };
  return fmt::format(
      "            before  U (k = 2)      after  U (k = 2)\n"
      "H       {:>10} {:>10} {:>10} {:>10}\n"
      "G       {:>10} {:>10} {:>10} {:>10}\n",
      um(before.h_mm), u(before.h_mm, before.u_h_mm), um(after.h_mm), u(after.h_mm, after.u_h_mm),
      um(before.g_mm), u(before.g_mm, before.u_g_mm), um(after.g_mm), u(after.g_mm, after.u_g_mm));
}

bool got_worse(const Figures& before, const Figures& after) {
  const auto worse = [](double b, double a) { return b >= 0 && a > b * 1.05 + 0.0005; };
  return worse(before.g_mm, after.g_mm) || worse(before.h_mm, after.h_mm);
}

RunOutcome verify_end(const std::string& session_dir, const std::string& limits,
                      std::ostream& out) {
  const fs::path dir(session_dir);
  const Figures before = read_figures((dir / "results.json").string());
  const Figures now = read_figures((dir / "verify-results.json").string());
  const std::string table = verify_table(before, now);
  write_file_atomic((dir / "verify.txt").string(), table);
  out << table << "circtest: the hand-over report: " << (dir / "report.html").string() << "\n";
  const SessionVerdict verdict =
      session_verdict(read_file((dir / "verify-results.json").string()),
                      read_file((dir / "verify-diagnosis.json").string()), limits);
  out << "circtest: " << verdict.line << "\n";
  RunOutcome outcome;
  outcome.session_dir = session_dir;
  outcome.worse = got_worse(before, now);
  if (outcome.worse) {
    out << fmt::format(
        "circtest: the machine got worse with the corrections (G {} -> {}, H {} "
        "-> {})\n",
        um(before.g_mm), um(now.g_mm), um(before.h_mm), um(now.h_mm));
  }
  outcome.exit_code = verify_exit_code(verdict.word);
  return outcome;
}

RunOutcome verify_session(const RunRequest& request, const Console& console) {
  std::ostream& out = console.print();
  if (!request.limits.empty()) check_limits(request.limits);
  const SessionSetup setup = read_setup(request.ini_path);
  const fs::path dir = latest_applied(setup);
  // The session's limits (limits.txt) unless given again: checked before any motion.
  const std::string limits =
      request.limits.empty() ? session_limits(dir.string(), "") : request.limits;
  const MachineState state = machine_state();
  require_ready(state, request.ini_path);
  require_circlog(setup.columns.size());
  require_same_origin(dir, state, setup);
  out << "circtest: verifying session " << dir.string() << ": its program again\n";
  RunOutcome outcome;
  outcome.session_dir = dir.string();
  const std::string after = (dir / "verify-trace.csv").string();
  const RecordResult rec =
      record_program(setup, request, (dir / "program.ngc").string(), after, "verify", console);
  if (rec.exit_code != 0) {
    outcome.exit_code = rec.exit_code;
    return outcome;
  }
  if (!request.limits.empty()) session_limits(dir.string(), request.limits);
  if (const int rc = evaluate_verify(setup, request, dir, limits, out); rc != 0) {
    outcome.exit_code = rc;
    return outcome;
  }
  return verify_end(dir.string(), limits, out);
}

}  // namespace circtest::session
