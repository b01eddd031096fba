// circana: ISO 230-4 evaluation of circular-test traces. Parses options, calls the library.
#include <algorithm>
#include <boost/program_options.hpp>
#include <cctype>
#include <functional>
#include <iostream>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/circana/commands.hpp"
#include "circtest/core/cli.hpp"
#include "circtest/core/cli_options.hpp"
#include "circtest/core/conditions.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/sha256.hpp"
#include "circtest/core/utc_time.hpp"
#include "circtest/core/version.hpp"

namespace po = boost::program_options;
using namespace circtest;

namespace {

// Each command's usage lines: `circana --help` shows them all, `circana COMMAND --help` its own.
struct Usage {
  const char* command;
  const char* text;
};
constexpr Usage kUsages[] = {
    {"analyze",
     "usage: circana analyze TRACE [--radius MM] [--centre A,B] [--plane XY|YZ|ZX]\n"
     "                     [--g-method min-zone|least-squares] [--f-centre auto|nominal|lsc]\n"
     "                     [--columns A,B] [--t-machine C] [--t-instrument C]\n"
     "                     [--alpha-machine PER_K] [--alpha-instrument PER_K] [--json]\n"
     "                     [--svg PLOT.svg] [--compare EARLIER_TRACE] [--scale-um-per-div UM]\n"
     "                     [--radial] [--limits H=MM,G=MM,F=MM]\n"
     "                     [--instrument-profile auto|ballbar|grid-encoder|scales]\n"
     "                     [--uncertainty calibration=MM,resolution=MM,...]\n"
     "                     [--machine NAME] [--serial TEXT] [--instrument TEXT]\n"
     "                     [--operator NAME] [--location TEXT] [--notes TEXT]\n"
     "                     [--units mm|inch] [--radius-tolerance MM] [--warn-inconsistent]\n"
     "                     [--store [--db URL]]\n"},
    {"diagnose",
     "usage: circana diagnose TRACE [the analyze options but --compare] [--pitch A=P,B=P]\n"
     "                        [--json] [--svg F] [--store [--db URL]]\n"},
    {"report",
     "usage: circana report TRACE [BEFORE] -o REPORT.html [the analyze options but --json,\n"
     "                      --svg] [--trace TRACE]... [--before TRACE]...\n"
     "                      [--diagnosis DIAG.json]... [--db URL]\n"
     "                      [--limits H=MM,... | --limits-file FILE]\n"
     "                      [--changes PLAN.json]... [--tested-by NAME] [--accepted-by NAME]\n"},
    {"fit", "usage: circana fit POINTS.csv [--columns A,B] [--json]\n"},
    {"import",
     "usage: circana import EXPORT.txt -o TRACE.csv [--columns "
     "angle_deg,dev_um|t_s,x_mm,y_mm|...]\n"
     "                      [--radius MM] [--plane XY|YZ|ZX] [--feed MM_PER_MIN]\n"
     "                      [--direction ccw|cw] [--date YYYY-MM-DD[THH:MM[:SS]Z]] [--ini INI]\n"
     "                      [--instrument TEXT]        (import-polar: the same)\n"},
    {"export-polar",
     "usage: circana export-polar TRACE -o EXPORT.txt [the analyze options but --json, --svg,\n"
     "                            --scale-um-per-div, --compare]\n"},
    {"store",
     "usage: circana store RESULT.json|TRACE [--db URL] [the analyze options but --json, --svg,\n"
     "                     --scale-um-per-div, --compare]\n"},
    {"summary",
     "usage: circana summary --name NAME --result RESULT.json --diagnosis DIAG.json\n"
     "                       [--name ... --result ... --diagnosis ...]... [--json SUMMARY.json]\n"},
    {"history",
     "usage: circana history --machine NAME [--since DATE] [--json] [--svg TREND.svg]\n"
     "                       [--limits H=MM,G=MM,F=MM,backlash=MM,squareness=URAD] [--db URL]\n"},
};

// The usage of COMMAND ("import-polar" is import's), or of every command.
std::string usage(std::string_view command = {}) {
  if (command == "import-polar") command = "import";
  std::string out;
  for (const Usage& u : kUsages) {
    if (command.empty() || command == u.command) out += u.text;
  }
  return out;
}

// Thrown once `circana COMMAND --help|--version` has printed its text: exit 0, no work.
struct InfoShown {};

// --help and --version are answered by every command before its options are checked.
void answer_info(std::string_view command, const po::options_description& desc,
                 const std::vector<std::string>& args) {
  for (const auto& arg : args) {
    if (arg == "--") break;
    if (arg == "--version") {
      std::cout << version_line("circana") << '\n';
      throw InfoShown{};
    }
    if (arg == "--help" || arg == "-h") {
      std::cout << usage(command) << "(man circana for the details)\n\n" << desc;
      throw InfoShown{};
    }
  }
}

// Options whose values are file names or URLs: any bytes the file system allows. Every other
// value goes into a JSON document, a plot or the history, so it must be UTF-8 text.
bool names_a_file(const std::string& option) {
  static const char* const kFileOptions[] = {"trace",   "before",      "diagnosis", "output", "svg",
                                             "compare", "db",          "input",     "points", "ini",
                                             "changes", "limits-file", "result",    "json"};
  return std::find(std::begin(kFileOptions), std::end(kFileOptions), option) !=
         std::end(kFileOptions);
}

// `shown`: the options --help lists, when the parser knows more (options a command refuses
// with its own message).
po::variables_map parse(std::string_view command, const po::options_description& desc,
                        const po::positional_options_description& pos,
                        const std::vector<std::string>& args,
                        const po::options_description* shown = nullptr) {
  answer_info(command, shown ? *shown : desc, args);
  po::variables_map vm;
  try {
    refuse_option_placeholders(args);
    po::store(po::command_line_parser(args).options(desc).positional(pos).run(), vm);
    po::notify(vm);
    for (const auto& [name, value] : vm) {
      if (names_a_file(name)) continue;
      if (const auto* text = boost::any_cast<std::string>(&value.value())) {
        require_utf8_option("--" + name, *text);
      }
    }
  } catch (const po::unknown_option& e) {
    throw option_usage_error(e, desc);
  } catch (const po::required_option& e) {
    // A missing positional argument is not an option the user could have given as --name.
    const std::string name = e.get_option_name();
    for (unsigned i = 0; i < pos.max_total_count() && i < 8; ++i) {
      const std::string& positional = pos.name_for_position(i);
      if (name == "--" + positional) {
        throw UsageError("missing the " + positional + " argument: expected a file name");
      }
    }
    throw UsageError(e.what());
  } catch (const po::error& e) {
    throw UsageError(e.what());
  }
  return vm;
}

std::pair<std::string, std::string> column_pair(const std::string& text) {
  const auto comma = text.find(',');
  if (comma == std::string::npos || comma == 0 || comma + 1 >= text.size() ||
      text.find(',', comma + 1) != std::string::npos) {
    throw UsageError("--columns: expected two column names A,B, got '" + text + "'");
  }
  return {text.substr(0, comma), text.substr(comma + 1)};
}

// --machine, --operator, ... (core/conditions): the clause 4.4 / 6 conditions.
void add_condition_options(po::options_description& desc) {
  for (const auto& c : condition_options()) {
    desc.add_options()(c.option, po::value<std::string>()->value_name(c.value_name), c.help);
  }
}

std::vector<std::pair<std::string, std::string>> condition_values(const po::variables_map& vm) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& c : condition_options()) {
    if (vm.count(c.option))
      out.emplace_back(c.key, condition_value(c, vm[c.option].as<std::string>()));
  }
  return out;
}

// --uncertainty KEY=VALUE,...: the budget's stated inputs (docs/uncertainty.md).
void parse_uncertainty(const std::string& text, UncertaintyOptions& u) {
  constexpr NumberRange kMm{0.0, 1.0, false, "a length in mm from 0 to 1"};
  constexpr NumberRange kKelvin{0.0, 50.0, false, "a temperature in K from 0 to 50"};
  std::vector<std::string> items;
  for (std::size_t pos = 0; pos <= text.size();) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    items.push_back(text.substr(pos, comma - pos));
    pos = comma + 1;
  }
  for (const std::string& item : items) {
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const std::string value = eq == std::string::npos ? std::string() : item.substr(eq + 1);
    auto mm = [&] { return parse_option_number("--uncertainty " + key, value, kMm); };
    auto kelvin = [&] { return parse_option_number("--uncertainty " + key, value, kKelvin); };
    if (key == "calibration") {
      u.calibration_mm = mm();
    } else if (key == "resolution") {
      u.resolution_mm = mm();
    } else if (key == "centring") {
      u.centring_mm = mm();
    } else if (key == "unseen") {
      u.unseen_mm = mm();
    } else if (key == "repeat-G") {
      u.repeatability_g_mm = mm();
    } else if (key == "repeat-F") {
      u.repeatability_f_mm = mm();
    } else if (key == "repeat-H") {
      u.repeatability_h_mm = mm();
    } else if (key == "thermometer") {
      u.thermometer_K = kelvin();
    } else if (key == "temperature-range") {
      u.assumed_temperature_half_width_K = kelvin();
    } else if (key == "drift-rate") {
      constexpr NumberRange kRate{0.0, 100.0, false, "a drift in K per hour from 0 to 100"};
      u.assumed_drift_K_per_h = parse_option_number("--uncertainty " + key, value, kRate);
    } else {
      throw UsageError(
          "--uncertainty: expected KEY=VALUE items (calibration, resolution, "
          "centring, unseen, repeat-G, repeat-F, repeat-H in mm; thermometer, "
          "temperature-range in K; drift-rate in K/h), got '" +
          item + "'");
    }
  }
}

// The options analyze and diagnose share; `extra` adds a command's own.
struct Parsed {
  po::variables_map vm;
  AnalyzeRequest request;
};
// `several`: --trace may be repeated and a second argument is the before trace (report).
// `refused`: the shared options this command refuses with its own message (left out of --help).
Parsed analyze_options(const std::vector<std::string>& args, const char* command,
                       const std::function<void(po::options_description&)>& extra,
                       bool several = false, std::initializer_list<std::string_view> refused = {}) {
  po::options_description desc(command);
  desc.add_options()("trace", po::value<std::vector<std::string>>()->required(), "trace file")(
      "radius", po::value<std::string>(), "nominal radius, mm")("centre", po::value<std::string>(),
                                                                "nominal (set-up) centre A,B, mm")(
      "plane", po::value<std::string>(), "XY, YZ or ZX")(
      "g-method", po::value<std::string>()->default_value("min-zone"), "")(
      "f-centre", po::value<std::string>()->default_value("auto"), "")(
      "columns", po::value<std::string>(), "position columns A,B")(
      "alpha-machine", po::value<std::string>(), "")("alpha-instrument", po::value<std::string>(),
                                                     "")("json", "JSON on stdout")(
      "svg", po::value<std::string>(), "write the plot of the paths to this SVG file")(
      "scale-um-per-div", po::value<std::string>(), "fixed plot scale, um per division")(
      "compare", po::value<std::string>(), "with --svg: an earlier trace drawn under this one")(
      "radial", "evaluate the length channel r (ball bar) even if the trace has x,y")(
      "units", po::value<std::string>(), "unit of the trace's positions: mm or inch")(
      "radius-tolerance", po::value<std::string>(),
      "largest nominal-to-measured radius difference, mm")(
      "warn-inconsistent", "note a radius mismatch or a short run instead of refusing")(
      "instrument-profile", po::value<std::string>(),
      "uncertainty budget: auto, ballbar, grid-encoder or scales")(
      "uncertainty", po::value<std::string>(),
      "uncertainty budget inputs KEY=VALUE,... (docs/uncertainty.md)");
  add_condition_options(desc);
  extra(desc);
  po::positional_options_description pos;
  pos.add("trace", 1);
  if (several) pos.add("before", 1);
  po::options_description shown(command);
  for (const auto& option : desc.options()) {
    if (std::find(refused.begin(), refused.end(), option->long_name()) == refused.end())
      shown.add(option);
  }
  Parsed parsed;
  parsed.vm = parse(command, desc, pos, args, &shown);
  const auto& vm = parsed.vm;

  // A numeric option's value within its plausible range, when given.
  auto number = [&vm](const char* name, const NumberRange& range) -> std::optional<double> {
    if (!vm.count(name)) return std::nullopt;
    return parse_option_number(std::string("--") + name, vm[name].as<std::string>(), range);
  };
  AnalyzeRequest& req = parsed.request;
  const auto& traces = vm["trace"].as<std::vector<std::string>>();
  if (traces.size() > 1 && !several) {
    throw UsageError(std::string("circana ") + command + ": one trace, got also '" + traces[1] +
                     "'");
  }
  req.trace_path = traces.front();
  req.json = vm.count("json") > 0;
  req.radial = vm.count("radial") > 0;
  if (vm.count("svg")) req.svg_path = vm["svg"].as<std::string>();
  if (vm.count("compare")) req.compare_path = vm["compare"].as<std::string>();
  auto& o = req.options;
  o.nominal_radius_mm = number("radius", kRadiusRangeMm);
  if (vm.count("centre")) {
    const std::string text = vm["centre"].as<std::string>();
    const auto c = parse_option_list("--centre", text, 2);
    if (!kCentreRangeMm.contains(c[0]) || !kCentreRangeMm.contains(c[1])) {
      throw UsageError("--centre: expected " + std::string(kCentreRangeMm.expected) + ", got '" +
                       text + "'");
    }
    o.centre = PlanePoint{c[0], c[1]};
  }
  if (vm.count("plane")) {
    o.plane = parse_plane(vm["plane"].as<std::string>());
    if (!o.plane) {
      throw UsageError("--plane: expected XY, YZ or ZX, got '" + vm["plane"].as<std::string>() +
                       "'");
    }
  }
  const std::string g = vm["g-method"].as<std::string>();
  if (g == "min-zone") {
    o.g_method = GMethod::min_zone;
  } else if (g == "least-squares") {
    o.g_method = GMethod::least_squares;
  } else {
    throw UsageError("--g-method: expected min-zone or least-squares, got '" + g + "'");
  }
  const std::string f = vm["f-centre"].as<std::string>();
  if (f == "auto") {
    o.f_centre = FCentre::automatic;
  } else if (f == "nominal") {
    o.f_centre = FCentre::nominal;
  } else if (f == "lsc") {
    o.f_centre = FCentre::lsc;
  } else {
    throw UsageError("--f-centre: expected auto, nominal or lsc, got '" + f + "'");
  }
  if (vm.count("columns"))
    std::tie(o.column_a, o.column_b) = column_pair(vm["columns"].as<std::string>());
  o.conditions = condition_values(vm);
  o.temperatures.machine_C = number("t-machine", kTemperatureRangeC);
  o.temperatures.instrument_C = number("t-instrument", kTemperatureRangeC);
  if (auto d = number("scale-um-per-div", kPlotScaleRangeUm))
    req.plot.mm_per_division = *d / 1000.0;
  if (vm.count("units")) {
    const std::string u = vm["units"].as<std::string>();
    if (u != "mm" && u != "inch") throw UsageError("--units: expected mm or inch, got '" + u + "'");
    o.input_checks.position_units = u == "mm" ? PositionUnits::mm : PositionUnits::inch;
  }
  if (auto t = number("radius-tolerance", kRadiusToleranceRangeMm)) {
    o.input_checks.radius_tolerance_mm = *t;
  }
  o.input_checks.warn_only = vm.count("warn-inconsistent") > 0;
  if (auto a = number("alpha-machine", kExpansionRangePerK)) {
    o.temperatures.machine_expansion_per_K = *a;
  }
  if (auto a = number("alpha-instrument", kExpansionRangePerK)) {
    o.temperatures.instrument_expansion_per_K = *a;
  }
  if (vm.count("instrument-profile")) {
    const std::string name = vm["instrument-profile"].as<std::string>();
    const auto profile = parse_instrument_profile(name);
    if (!profile) {
      throw UsageError(
          "--instrument-profile: expected auto, ballbar, grid-encoder or scales, got '" + name +
          "'");
    }
    o.uncertainty.profile = *profile;
  }
  if (vm.count("uncertainty"))
    parse_uncertainty(vm["uncertainty"].as<std::string>(), o.uncertainty);
  return parsed;
}

int analyze(const std::vector<std::string>& args) {
  Parsed p = analyze_options(args, "analyze", [](po::options_description& d) {
    d.add_options()("store", "also keep the test in the history")(
        "db", po::value<std::string>(), "the history: SQLite file or postgresql:// URL")(
        "limits", po::value<std::string>(), "H=MM,G=MM,F=MM: verdicts by ISO 14253-1");
  });
  p.request.store = p.vm.count("store") > 0;
  if (p.vm.count("limits")) p.request.limits = result_limits(p.vm["limits"].as<std::string>());
  if (p.vm.count("db")) {
    if (!p.request.store) throw UsageError("--db: only with --store");
    p.request.db_url = p.vm["db"].as<std::string>();
  }
  return run_analyze(p.request, std::cout);
}

int store(const std::vector<std::string>& args) {
  const Parsed p =
      analyze_options(args, "store",
                      [](po::options_description& d) {
                        d.add_options()("db", po::value<std::string>(),
                                        "the history: SQLite file or postgresql:// URL");
                      },
                      false, {"svg", "scale-um-per-div", "json", "compare"});
  if (!p.request.compare_path.empty()) throw UsageError("--compare: only for circana analyze");
  // store only writes the history, and a RESULT.json has no points to draw: refused rather
  // than ignored (analyze --svg --store plots and stores in one call).
  for (const char* o : {"svg", "scale-um-per-div", "json"}) {
    if (p.vm.count(o)) {
      throw UsageError(std::string("--") + o +
                       ": not for circana store (it only stores; analyze --store plots or prints "
                       "and stores)");
    }
  }
  StoreRequest req;
  req.path = p.request.trace_path;
  req.options = p.request.options;
  req.radial = p.request.radial;
  if (p.vm.count("db")) req.db_url = p.vm["db"].as<std::string>();
  return run_store(req, std::cout);
}

int history(const std::vector<std::string>& args) {
  po::options_description desc("history");
  desc.add_options()("machine", po::value<std::string>()->required(), "machine name")(
      "since", po::value<std::string>(), "only tests at or after this date")(
      "json", "JSON on stdout")("svg", po::value<std::string>(), "write the trend as SVG")(
      "limits", po::value<std::string>(), "H=MM,G=MM,...: pass/fail of the latest test")(
      "db", po::value<std::string>(), "the history: SQLite file or postgresql:// URL");
  const auto vm = parse("history", desc, {}, args);
  HistoryRequest req;
  req.machine = vm["machine"].as<std::string>();
  if (vm.count("since")) req.since = vm["since"].as<std::string>();
  req.json = vm.count("json") > 0;
  if (vm.count("svg")) req.svg_path = vm["svg"].as<std::string>();
  if (vm.count("limits")) req.limits = vm["limits"].as<std::string>();
  if (vm.count("db")) req.db_url = vm["db"].as<std::string>();
  return run_history(req, std::cout);
}

// --pitch X=5,Y=5: cyclic-error pitch per axis, mm.
std::map<char, double> pitch_list(const std::string& text) {
  std::map<char, double> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    const auto eq = item.find('=');
    const char axis =
        eq == 1 ? static_cast<char>(std::tolower(static_cast<unsigned char>(item[0]))) : '\0';
    const auto v = axis ? parse_finite(item.substr(2)) : std::nullopt;
    if ((axis != 'x' && axis != 'y' && axis != 'z') || !v || !kPitchRangeMm.contains(*v)) {
      throw UsageError("--pitch: expected " + std::string(kPitchRangeMm.expected) + ", got '" +
                       item + "'");
    }
    out[axis] = *v;
    pos = comma + 1;
  }
  return out;
}

int diagnose(const std::vector<std::string>& args) {
  const Parsed p = analyze_options(
      args, "diagnose",
      [](po::options_description& d) {
        d.add_options()("pitch", po::value<std::string>(), "cyclic-error pitch per axis, X=5,Y=5")(
            "store", "also keep the test and its diagnosis in the history")(
            "db", po::value<std::string>(), "the history: SQLite file or postgresql:// URL");
      },
      false, {"compare"});
  if (!p.request.compare_path.empty()) throw UsageError("--compare: only for circana analyze");
  DiagnoseRequest req;
  req.svg_path = p.request.svg_path;
  req.plot = p.request.plot;
  req.trace_path = p.request.trace_path;
  req.json = p.request.json;
  req.radial = p.request.radial;
  req.options.evaluation = p.request.options;
  if (p.vm.count("pitch")) req.options.pitch_mm = pitch_list(p.vm["pitch"].as<std::string>());
  req.store = p.vm.count("store") > 0;
  if (p.vm.count("db")) {
    if (!req.store) throw UsageError("--db: only with --store");
    req.db_url = p.vm["db"].as<std::string>();
  }
  return run_diagnose(req, std::cout);
}

int report(const std::vector<std::string>& args) {
  const Parsed p = analyze_options(
      args, "report",
      [](po::options_description& d) {
        d.add_options()("output,o", po::value<std::string>()->required(), "the HTML file to write")(
            "before", po::value<std::vector<std::string>>(),
            "an earlier test of a plane, overlaid (also the second argument)")(
            "diagnosis", po::value<std::vector<std::string>>(),
            "a plane's diagnosis (circana diagnose --json) instead of diagnosing here")(
            "db", po::value<std::string>(), "the trend from this history (SQLite file or URL)")(
            "limits", po::value<std::string>(), "H=MM,G=MM,...: the verdict's limits")(
            "limits-file", po::value<std::string>(), "the verdict's limits from a file")(
            "changes", po::value<std::vector<std::string>>(),
            "what was changed (circcomp plan --json; one per round, in order)")(
            "tested-by", po::value<std::string>(), "the name for the signature block")(
            "accepted-by", po::value<std::string>(), "the customer's name for the signature");
      },
      true, {"json", "svg"});
  if (p.request.json) throw UsageError("--json: not for circana report (it writes HTML)");
  if (!p.request.svg_path.empty()) throw UsageError("--svg: only for circana analyze");
  ReportRequest req;
  req.trace_paths = p.vm["trace"].as<std::vector<std::string>>();
  if (p.vm.count("before")) req.before_paths = p.vm["before"].as<std::vector<std::string>>();
  if (p.vm.count("diagnosis"))
    req.diagnosis_paths = p.vm["diagnosis"].as<std::vector<std::string>>();
  req.options = p.request.options;
  req.radial = p.request.radial;
  req.plot = p.request.plot;
  req.output_path = p.vm["output"].as<std::string>();
  if (p.vm.count("db")) req.db_url = p.vm["db"].as<std::string>();
  auto text = [&p](const char* name) {
    return p.vm.count(name) ? p.vm[name].as<std::string>() : std::string();
  };
  req.limits = text("limits");
  req.limits_file = text("limits-file");
  if (p.vm.count("changes")) req.changes_paths = p.vm["changes"].as<std::vector<std::string>>();
  req.tested_by = text("tested-by");
  req.accepted_by = text("accepted-by");
  return run_report(req, std::cout);
}

int fit(const std::vector<std::string>& args) {
  po::options_description desc("fit");
  desc.add_options()("points", po::value<std::string>()->required(), "points file")(
      "columns", po::value<std::string>(), "coordinate columns A,B (default x,y)")("json", "");
  po::positional_options_description pos;
  pos.add("points", 1);
  const auto vm = parse("fit", desc, pos, args);
  FitRequest req;
  req.points_path = vm["points"].as<std::string>();
  req.json = vm.count("json") > 0;
  if (vm.count("columns"))
    std::tie(req.column_a, req.column_b) = column_pair(vm["columns"].as<std::string>());
  return run_fit(req, std::cout);
}

int import_export(const std::vector<std::string>& args) {
  po::options_description desc("import");
  desc.add_options()("input", po::value<std::string>()->required(), "the instrument's export")(
      "output,o", po::value<std::string>()->required(), "trace to write")(
      "columns", po::value<std::string>()->value_name("LIST"),
      "what each column holds, in its unit: angle_deg|angle_rad, dev_um|dev_mm|dev_nm, "
      "ccw_um, cw_um, run, t_s|t_ms, x_mm|x_um (the plane's axes), skip; default: the title "
      "row, else angle_deg,dev_um")("radius", po::value<std::string>(),
                                    "nominal radius, mm (a polar export's deviations)")(
      "plane", po::value<std::string>(), "XY, YZ or ZX (default: the export's, else XY)")(
      "feed", po::value<std::string>()->value_name("MM_PER_MIN"), "the programmed feed")(
      "direction", po::value<std::string>(), "ccw or cw: a polar export of one run")(
      "date", po::value<std::string>(), "when the test ran (ISO 8601, UTC unless given)")(
      "ini", po::value<std::string>(), "the machine's INI the test ran with (its SHA-256 is kept)")(
      "instrument", po::value<std::string>(), "what measured it");
  po::positional_options_description pos;
  pos.add("input", 1);
  const auto vm = parse("import", desc, pos, args);
  ImportRequest req;
  req.input_path = vm["input"].as<std::string>();
  req.output_path = vm["output"].as<std::string>();
  ExportImportOptions& o = req.options;
  if (vm.count("plane")) {
    o.plane = parse_plane(vm["plane"].as<std::string>());
    if (!o.plane) {
      throw UsageError("--plane: expected XY, YZ or ZX, got '" + vm["plane"].as<std::string>() +
                       "'");
    }
  }
  if (vm.count("columns")) o.columns = vm["columns"].as<std::string>();
  if (vm.count("radius")) {
    o.radius_mm = parse_option_number("--radius", vm["radius"].as<std::string>(), kRadiusRangeMm);
  }
  if (vm.count("feed")) {
    o.feed_mm_per_min = parse_option_number("--feed", vm["feed"].as<std::string>(), kFeedRange);
  }
  if (vm.count("direction")) {
    std::string d = vm["direction"].as<std::string>();
    std::transform(d.begin(), d.end(), d.begin(),
                   [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
    o.direction = parse_direction(d);
    if (!o.direction) {
      throw UsageError("--direction: expected ccw or cw, got '" +
                       vm["direction"].as<std::string>() + "'");
    }
  }
  if (vm.count("date")) {
    const std::string text = vm["date"].as<std::string>();
    const auto canonical = canonical_utc_iso8601(text);
    if (!canonical) {
      throw UsageError("--date: expected YYYY-MM-DD or YYYY-MM-DDTHH:MM[:SS][Z|+HH:MM], got '" +
                       text + "'");
    }
    o.date = *canonical;
  }
  if (vm.count("ini")) {
    o.ini_provenance.emplace();
    record_ini_provenance(*o.ini_provenance, vm["ini"].as<std::string>());
  }
  if (vm.count("instrument")) o.instrument = vm["instrument"].as<std::string>();
  return run_import(req, std::cout);
}

int summary(const std::vector<std::string>& args) {
  po::options_description desc("summary");
  desc.add_options()("name", po::value<std::vector<std::string>>()->required(),
                     "a run's column title, in order")(
      "result", po::value<std::vector<std::string>>()->required(),
      "its evaluation (circana analyze --json)")("diagnosis",
                                                 po::value<std::vector<std::string>>()->required(),
                                                 "its diagnosis (circana diagnose --json)")(
      "json", po::value<std::string>(), "also write the table as JSON here");
  const auto vm = parse("summary", desc, {}, args);
  const auto& names = vm["name"].as<std::vector<std::string>>();
  const auto& results = vm["result"].as<std::vector<std::string>>();
  const auto& diagnoses = vm["diagnosis"].as<std::vector<std::string>>();
  if (results.size() != names.size() || diagnoses.size() != names.size()) {
    throw UsageError("--name, --result, --diagnosis: one of each per run");
  }
  SummaryRequest req;
  for (std::size_t k = 0; k < names.size(); ++k)
    req.runs.push_back({names[k], results[k], diagnoses[k]});
  if (vm.count("json")) req.json_path = vm["json"].as<std::string>();
  return run_summary(req, std::cout);
}

int export_polar(const std::vector<std::string>& args) {
  Parsed p = analyze_options(args, "export-polar",
                             [](po::options_description& d) {
                               d.add_options()("output,o", po::value<std::string>()->required(),
                                               "polar export to write");
                             },
                             false, {"svg", "scale-um-per-div", "json", "compare"});
  for (const char* o : {"svg", "scale-um-per-div", "json", "compare"}) {
    if (p.vm.count(o)) {
      throw UsageError(std::string("--") + o +
                       ": not for circana export-polar (it writes the export only)");
    }
  }
  ExportPolarRequest req;
  req.trace_path = p.request.trace_path;
  req.output_path = p.vm["output"].as<std::string>();
  req.options = p.request.options;
  req.radial = p.request.radial;
  return run_export_polar(req, std::cout);
}

}  // namespace

int main(int argc, char** argv) {
  return run_cli("circana", [&]() -> int {
    if (argc < 2)
      throw UsageError(
          "missing command: expected analyze, diagnose, report, fit, import, export-polar, store "
          "or "
          "history "
          "(see circana --help)");
    const std::string command = argv[1];
    const std::vector<std::string> args(argv + 2, argv + argc);
    if (command == "--help" || command == "-h" || command == "help") {
      std::cout << usage();
      return 0;
    }
    if (command == "--version") {
      std::cout << version_line("circana") << '\n';
      return 0;
    }
    try {
      if (command == "analyze") return analyze(args);
      if (command == "diagnose") return diagnose(args);
      if (command == "fit") return fit(args);
      if (command == "import" || command == "import-polar") return import_export(args);
      if (command == "export-polar") return export_polar(args);
      if (command == "store") return store(args);
      if (command == "history") return history(args);
      if (command == "summary") return summary(args);
      if (command == "report") return report(args);
    } catch (const InfoShown&) {
      return 0;
    }
    std::string message = "unknown command '" + command +
                          "': expected analyze, diagnose, report, fit, import, export-polar, "
                          "store, history or summary";
    const std::vector<std::string> commands = {"analyze", "diagnose",     "report",       "fit",
                                               "import",  "import-polar", "export-polar", "store",
                                               "history", "summary"};
    if (const std::string guess = closest_name(command, commands); !guess.empty()) {
      message += "; did you mean " + guess + "?";
    }
    throw UsageError(message);
  });
}
