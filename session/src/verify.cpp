#include <fmt/format.h>
#include <filesystem>
#include <ostream>
#include <sstream>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
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
void require_same_origin(const fs::path& dir, const MachineState& state) {
  std::istringstream in(read_file((dir / "work-origin.txt").string()));
  for (std::size_t i = 0; i < 3; ++i) {
    double v = 0;
    in >> v;
    if (std::abs(v - state.work_origin_machine_mm[i]) > 1e-6) {
      throw HalError(
          fmt::format("the work offset moved since the session's run ({} of axis {} "
                      "was {:.4f} mm, is {:.4f} mm): set it back",
                      "origin", "XYZ"[i], v, state.work_origin_machine_mm[i]));
    }
  }
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

RunOutcome verify_session(const RunRequest& request, const Console& console) {
  std::ostream& out = console.print();
  const SessionSetup setup = read_setup(request.ini_path);
  const fs::path dir = latest_applied(setup);
  const MachineState state = machine_state();
  require_ready(state, request.ini_path);
  require_circlog(setup.columns.size());
  require_same_origin(dir, state);
  out << "circtest: verifying session " << dir.string() << ": its program again\n";
  RunOutcome outcome;
  outcome.session_dir = dir.string();
  const std::string after = (dir / "verify-trace.csv").string();
  const RecordResult rec =
      record_program(setup, request, (dir / "program.ngc").string(), after, console);
  if (rec.exit_code != 0) {
    outcome.exit_code = rec.exit_code;
    return outcome;
  }
  std::vector<std::string> columns = evaluated_columns(setup, request.program.planes);
  const std::string circana = tool_path("circana");
  std::vector<std::string> analyze = {circana, "analyze", after, "--json"};
  analyze.insert(analyze.end(), columns.begin(), columns.end());
  if (const int rc = run_program(analyze, (dir / "verify-results.json").string()); rc != 0) {
    outcome.exit_code = rc;
    return outcome;
  }
  std::vector<std::string> report = {
      circana, "report", after, (dir / "trace.csv").string(), "-o", (dir / "report.html").string()};
  report.insert(report.end(), columns.begin(), columns.end());
  if (const int rc = run_program(report, (dir / "report.txt").string()); rc != 0) {
    outcome.exit_code = rc;
    return outcome;
  }
  const Figures before = read_figures((dir / "results.json").string());
  const Figures now = read_figures((dir / "verify-results.json").string());
  const std::string table = verify_table(before, now);
  write_file_atomic((dir / "verify.txt").string(), table);
  out << table << "circtest: the hand-over report: " << (dir / "report.html").string() << "\n";
  outcome.worse = got_worse(before, now);
  if (outcome.worse) {
    out << fmt::format(
        "circtest: the machine got worse with the corrections (G {} -> {}, H {} "
        "-> {})\n",
        um(before.g_mm), um(now.g_mm), um(before.h_mm), um(now.h_mm));
  }
  return outcome;
}

}  // namespace circtest::session
