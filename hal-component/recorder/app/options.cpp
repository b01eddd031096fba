#include "options.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <boost/program_options.hpp>
#include <cctype>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/core/cli_options.hpp"
#include "circtest/core/conditions.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/core/version.hpp"

namespace circtest::circlog_record {

namespace po = boost::program_options;

namespace {

// The longest --duration: a week of servo time.
constexpr double kMaxDuration_s = 7.0 * 86400.0;

// The columns the recorder writes itself: no channel may take their names.
const std::set<std::string, std::less<>> kFixedColumns = {
    column_name::t, column_name::period, column_name::marker, column_name::segment};

bool valid_name(const std::string& name) {
  if (name.empty()) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
}

// --condition KEY=VALUE: a key the recorder writes itself, a channel's description or one of
// the named condition options (--machine, ...) is refused; the value as those take theirs.
void add_condition(const std::string& item, std::vector<std::pair<std::string, std::string>>& out) {
  const auto eq = item.find('=');
  const std::string key = item.substr(0, eq);
  if (eq == std::string::npos || !valid_name(key)) {
    throw UsageError(fmt::format(
        "--condition '{}': expected KEY=VALUE, KEY of letters, digits, '_', '-', '.'", item));
  }
  if (recorder_key(key) || key.rfind(meta_key::channel_prefix, 0) == 0) {
    throw UsageError(fmt::format("--condition {}: a key circlog-record writes itself", key));
  }
  for (const auto& c : condition_options()) {
    if (key == c.key) {
      throw UsageError(fmt::format("--condition {}: give it as --{}", key, c.option));
    }
  }
  const ConditionOption option{"condition", key.c_str(), "VALUE", "", false};
  const std::string value = condition_value(option, item.substr(eq + 1));
  if (std::any_of(out.begin(), out.end(), [&](const auto& kv) { return kv.first == key; })) {
    throw UsageError(fmt::format("--condition {}: given twice", key));
  }
  out.emplace_back(key, value);
}

}  // namespace

std::optional<RecordRequest> parse_options(int argc, const char* const* argv, std::FILE* out) {
  RecordRequest o;
  std::string columns;
  std::vector<std::string> describe;
  std::vector<std::string> conditions;
  double duration = 0.0;
  double idle = 0.0;
  po::options_description desc(
      "circlog-record: writes what the circlog HAL component logs to a trace file.\n"
      "Usage: circlog-record -o FILE [options]\nOptions");
  desc.add_options()("help,h", "print this help")("version", "print the version")(
      "output,o", po::value(&o.output)->value_name("FILE"), "trace file to write (required)")(
      "columns", po::value(&columns)->value_name("NAME,..."),
      "one name per circlog channel, in pin order (default in-00,in-01,...); axis "
      "positions are x,y,z, commanded positions x_cmd,y_cmd,z_cmd")(
      "describe", po::value(&describe)->value_name("NAME=TEXT")->composing(),
      "a description of a channel, written as metadata channel.NAME (repeatable)")(
      "condition", po::value(&conditions)->value_name("KEY=VALUE")->composing(),
      "another condition of the test (clause 4.4), written as metadata KEY (repeatable; "
      "circtest verify: circtest_step=verify)")("duration", po::value(&duration)->value_name("S"),
                                                "stop after S seconds of servo time")(
      "until-idle", po::value(&idle)->value_name("S"),
      "stop once a run was recorded and enable has then stayed false for S seconds (the "
      "program has finished); with --program, only once every run the program announces "
      "(circgen's segments header) was recorded")(
      "run-wait", po::value<double>()->value_name("S"),
      "with --until-idle and runs still missing: stop after S seconds with enable false and "
      "report them (default: twice the program's longest pause between two runs, plus 10 s)")(
      "ini", po::value(&o.ini)->value_name("FILE.ini"),
      "the machine's LinuxCNC INI: its path and SHA-256 go into the metadata (ini, ini_sha256), "
      "so circcomp can tell whether a correction was measured on the configuration it edits")(
      "program", po::value(&o.program)->value_name("FILE.ngc"),
      "copy the (key: value) header comments of this G-code program into the metadata")(
      "decimals", po::value(&o.decimals)->value_name("N"),
      "decimals of the channel values (default 6: 1 nm in mm)")(
      "poll", po::value(&o.poll_s)->value_name("S"),
      "sleep between polls of an empty ring (default 0.005)")(
      "progress-to", po::value(&o.progress_to)->value_name("TTY"),
      "show the status line on this terminal (default: stderr when it is a terminal)")(
      "live", po::value(&o.live)->value_name("FILE"),
      "also write the trace's text to FILE as it records (every 0.1 s), for a live plot; the "
      "trace (-o) is still written whole at the end");
  // The test conditions of clauses 4.4 and 6, written as metadata (docs/trace-format.md).
  std::vector<std::string> condition_values(condition_options().size());
  for (std::size_t i = 0; i < condition_options().size(); ++i) {
    const auto& c = condition_options()[i];
    desc.add_options()(c.option, po::value(&condition_values[i])->value_name(c.value_name), c.help);
  }
  po::variables_map vm;
  try {
    refuse_option_placeholders(argc, argv);
    po::store(po::command_line_parser(argc, argv).options(desc).run(), vm);
    po::notify(vm);
  } catch (const po::error& e) {
    throw option_usage_error(e, desc);
  }
  if (vm.count("help")) {
    std::ostringstream text;
    text << desc;
    std::fputs(text.str().c_str(), out);
    return std::nullopt;
  }
  if (vm.count("version")) {
    std::fprintf(out, "%s\n", circtest::version_line("circlog-record").c_str());
    return std::nullopt;
  }
  if (o.output.empty()) throw UsageError("-o FILE is required");
  if (vm.count("duration")) {
    if (!(duration > 0.0 && duration <= kMaxDuration_s)) {
      throw UsageError(fmt::format("--duration must be a number of seconds in (0, {:.0f}] (a week)",
                                   kMaxDuration_s));
    }
    o.duration_s = duration;
  }
  if (vm.count("until-idle")) {
    if (!(idle >= 0.0 && idle <= kMaxWait_s)) {
      throw UsageError(
          fmt::format("--until-idle must be a number of seconds in 0..{:.0f} (a day)", kMaxWait_s));
    }
    o.idle_s = idle;
  }
  if (vm.count("run-wait")) {
    const double wait = vm["run-wait"].as<double>();
    if (!o.idle_s) throw UsageError("--run-wait is only used with --until-idle");
    if (!(wait > 0.0 && wait <= kMaxWait_s)) {
      throw UsageError(
          fmt::format("--run-wait must be a number of seconds in (0, {:.0f}] (a day)", kMaxWait_s));
    }
    o.run_wait_s = wait;
  }
  if (o.decimals < 0 || o.decimals > 12) throw UsageError("--decimals must be in 0..12");
  if (!(o.poll_s > 0.0) || o.poll_s > 1.0) throw UsageError("--poll must be in (0, 1] s");
  if (vm.count("columns")) {
    o.columns = split_on(columns, ',');
    std::set<std::string> seen;
    for (const auto& name : o.columns) {
      if (!valid_name(name)) {
        throw UsageError(fmt::format(
            "--columns: '{}' is not a column name (letters, digits, '_', '-', '.')", name));
      }
      if (kFixedColumns.count(name)) {
        throw UsageError(
            fmt::format("--columns: '{}' is a column circlog-record writes itself", name));
      }
      if (!seen.insert(name).second) {
        throw UsageError(fmt::format("--columns: '{}' is given twice", name));
      }
    }
  }
  for (std::size_t i = 0; i < condition_options().size(); ++i) {
    const auto& c = condition_options()[i];
    if (vm.count(c.option))
      o.conditions.emplace_back(c.key, condition_value(c, condition_values[i]));
  }
  for (const auto& c : conditions) add_condition(c, o.conditions);
  for (const auto& d : describe) {
    const auto eq = d.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw UsageError(fmt::format("--describe '{}': expected NAME=TEXT", d));
    }
    o.descriptions.emplace_back(d.substr(0, eq), d.substr(eq + 1));
  }
  // Before any HAL work: a program that cannot be read, or announces runs that cannot be
  // told apart, is refused before the recording starts.
  if (!o.program.empty()) o.program_plan = read_program_plan(o.program);
  return o;
}
}  // namespace circtest::circlog_record
