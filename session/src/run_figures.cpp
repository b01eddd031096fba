// The figures of each run as soon as it has finished: the live copy of the trace
// (circlog-record --live) up to the run's last row, evaluated by circana analyze as the whole
// trace is after the program, its G (and H once a CCW/CW pair is in) said in one line.
#include <fmt/format.h>
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/session/process.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace fs = std::filesystem;

namespace {

std::vector<std::string> fields_of(std::string_view line) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in{std::string(line)};
  while (std::getline(in, field, ',')) out.emplace_back(trim(field));
  return out;
}

std::optional<std::size_t> index_of(const std::vector<std::string>& names, const char* name) {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name || names[i] == std::string("\"") + name + "\"") return i;
  }
  return std::nullopt;
}

// The value of field I of a row, none when the row has no such number.
std::optional<double> field_value(const std::vector<std::string>& fields, std::size_t i) {
  return i < fields.size() ? parse_finite(fields[i]) : std::nullopt;
}

std::string micrometres(const nlohmann::json& value_mm, const nlohmann::json& u_mm) {
  std::string text = fmt::format("{:.1f} um", value_mm.get<double>() * 1e3);
  if (u_mm.is_number()) text += fmt::format(" (U {:.1f} um)", u_mm.get<double>() * 1e3);
  return text;
}

}  // namespace

std::optional<std::string> trace_through_run(const std::string& text, int segment) {
  std::vector<std::string_view> lines;
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t nl = text.find('\n', at);
    if (nl == std::string::npos) break;  // a row still being written
    lines.emplace_back(text.data() + at, nl - at);
    at = nl + 1;
  }
  std::size_t header = 0;
  while (header < lines.size() && lines[header].starts_with("#")) ++header;
  if (header >= lines.size()) return std::nullopt;
  const auto names = fields_of(lines[header]);
  const auto seg = index_of(names, "segment");
  const auto marker = index_of(names, "marker");
  if (!seg) return std::nullopt;
  std::optional<std::size_t> last;
  for (std::size_t i = header + 1; i < lines.size(); ++i) {
    if (lines[i].starts_with("#")) continue;
    const auto fields = fields_of(lines[i]);
    const auto s = field_value(fields, *seg);
    const auto m = marker ? field_value(fields, *marker) : std::optional<double>(1.0);
    if (s && m && *m != 0 && *s == static_cast<double>(segment)) last = i;
  }
  if (!last) return std::nullopt;
  std::string out;
  for (std::size_t i = 0; i <= *last; ++i) (out += lines[i]) += '\n';
  return out;
}

std::optional<std::string> run_figures_line(const std::string& result_json, int segment) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(result_json);
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;
  }
  const auto& runs = j.value("runs", nlohmann::json::array());
  std::optional<std::size_t> index;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (runs[i].value("segment", -1) == segment) index = i;
  }
  if (!index || !runs[*index].contains("G") || !runs[*index]["G"].is_number()) {
    return std::nullopt;
  }
  const auto& run = runs[*index];
  std::string line = "G " + micrometres(run["G"], run.value("U_G", nlohmann::json()));
  // H once this run completes a CCW/CW pair.
  for (const auto& pair : j.value("pairs", nlohmann::json::array())) {
    const auto& members = pair.value("runs", nlohmann::json::array());
    const bool ours = std::any_of(members.begin(), members.end(), [&](const nlohmann::json& m) {
      return m.is_number_integer() && m.get<std::size_t>() == *index;
    });
    if (ours && pair.contains("H") && pair["H"].is_number()) {
      line += ", H " + micrometres(pair["H"], pair.value("U_H", nlohmann::json()));
    }
  }
  return line;
}

std::optional<std::string> RunFigures::finished(int segment) const {
  // The recorder writes its live copy every kLiveFlush_s (0.1 s): the run's last rows are in
  // well within half a second of LinuxCNC reporting the marker off.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  std::string text;
  try {
    text = read_file(live_);
  } catch (const Error&) {
    return std::nullopt;
  }
  const auto snapshot = trace_through_run(text, segment);
  if (!snapshot) return std::nullopt;
  {
    std::ofstream out(scratch_, std::ios::trunc);
    out << *snapshot;
    if (!out.flush()) return std::nullopt;
  }
  // The runs still to come are missing from it by design: --warn-inconsistent lets circana
  // evaluate the ones in (the evaluation after the program is the strict one).
  std::vector<std::string> args = {tool_path("circana"), "analyze", scratch_, "--json",
                                   "--warn-inconsistent"};
  args.insert(args.end(), columns_.begin(), columns_.end());
  int code = 0;
  const std::string json = program_output(args, code, "/dev/null");
  std::error_code ec;
  fs::remove(scratch_, ec);
  if (code != 0) return std::nullopt;
  return run_figures_line(json, segment);
}

}  // namespace circtest::session
