#include <fmt/format.h>
#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <ostream>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/session/process.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace fs = std::filesystem;

namespace {

// Runs circana/circcomp with its output into DIR/NAME; shows the file when SHOW.
int step(const std::vector<std::string>& argv, const fs::path& file, std::ostream& out, bool show) {
  const int rc = run_program(argv, file.string());
  if (show && fs::exists(file)) out << read_file(file.string());
  out.flush();
  return rc;
}

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& more) {
  a.insert(a.end(), more.begin(), more.end());
  return a;
}

}  // namespace

std::vector<std::string> limits_args(const std::string& limits) {
  if (limits.empty()) return {};
  return {"--limits", limits};
}

Figures read_figures(const std::string& results_json) {
  Figures f;
  const auto j = nlohmann::json::parse(read_file(results_json));
  if (j.contains("H") && j["H"].is_number()) f.h_mm = j["H"].get<double>();
  if (j.contains("U_H") && j["U_H"].is_number()) f.u_h_mm = j["U_H"].get<double>();
  if (j.contains("runs")) {
    for (const auto& r : j["runs"]) {
      if (!r.contains("G") || !r["G"].is_number() || !(r["G"].get<double>() > f.g_mm)) continue;
      f.g_mm = r["G"].get<double>();
      f.u_g_mm.reset();
      if (r.contains("U_G") && r["U_G"].is_number()) f.u_g_mm = r["U_G"].get<double>();
    }
  }
  return f;
}

int analyse_and_apply(const SessionSetup& setup, const RunRequest& request,
                      const std::string& dir_text, const Console& console, bool& applied) {
  std::ostream& out = console.print();
  const fs::path dir = dir_text;
  const std::string trace = (dir / "trace.csv").string();
  const auto columns = evaluated_columns(setup, request.program.planes);
  const std::string circana = tool_path("circana");
  const std::string circcomp = tool_path("circcomp");
  out << "\ncirctest: the evaluation (ISO 230-4)\n";
  if (const int rc =
          step(with({circana, "analyze", trace, "--svg", (dir / "plot.svg").string()}, columns),
               dir / "analysis.txt", out, true);
      rc != 0) {
    return rc;
  }
  if (const int rc = step(with({circana, "analyze", trace, "--json"}, columns),
                          dir / "results.json", out, false);
      rc != 0) {
    return rc;
  }
  out << "\ncirctest: the diagnosis\n";
  if (const int rc =
          step(with({circana, "diagnose", trace}, columns), dir / "diagnosis.txt", out, true);
      rc != 0) {
    return rc;
  }
  const std::string diagnosis = (dir / "diagnosis.json").string();
  if (const int rc =
          step(with({circana, "diagnose", trace, "--json"}, columns), diagnosis, out, false);
      rc != 0) {
    return rc;
  }
  step(with(with({circana, "report", trace, "-o", (dir / "report.html").string()}, columns),
            limits_args(request.limits)),
       dir / "report.txt", out, false);
  // Into the machine's history (circana's database): a failure there is said, not fatal.
  if (const int rc = step(with({circana, "diagnose", trace, "--store"}, columns),
                          dir / "history.txt", out, false);
      rc != 0) {
    out << "circtest: note: not stored in the history (circana exit " << rc << ", see above)\n";
  }
  out << "\ncirctest: the corrections circcomp would write\n";
  if (const int rc = step({circcomp, "plan", "--ini", setup.ini_path, diagnosis}, dir / "plan.diff",
                          out, true);
      rc != 0) {
    return rc;
  }
  if (read_file((dir / "plan.diff").string()).find("\n+++ ") == std::string::npos &&
      read_file((dir / "plan.diff").string()).rfind("+++ ", 0) != 0) {
    out << "circtest: nothing to correct; the session is in " << dir.string() << "\n";
    return 0;
  }
  if (!console.confirm("circtest: apply these corrections to " + setup.ini_path + "?")) {
    out << "circtest: nothing applied (answer y on a terminal, or give the yes option); the "
           "session is in "
        << dir.string() << "\n";
    return 0;
  }
  if (const int rc = step({circcomp, "apply", "--ini", setup.ini_path, diagnosis},
                          dir / "apply.txt", out, true);
      rc != 0) {
    return rc;
  }
  applied = true;
  out << "circtest: corrections applied (originals in .circcomp/); restart LinuxCNC so that it "
         "loads them\n";
  return 0;
}

}  // namespace circtest::session
