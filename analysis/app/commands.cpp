#include "circtest/circana/commands.hpp"

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <set>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/plot.hpp"
#include "circtest/analysis/radial.hpp"
#include "circtest/analysis/remedy.hpp"
#include "circtest/analysis/report.hpp"
#include "circtest/analysis/result_checks.hpp"
#include "circtest/analysis/test_set.hpp"
#include "circtest/circana/history_record.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/progress.hpp"
#include "circtest/core/sha256.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/core/utc_time.hpp"
#include "circtest/history/history.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "evaluation/rows_context.hpp"

namespace circtest {

namespace {
// circana's words for what the library asks the user to give: its options. The messages'
// tests (tests/analysis/test_circana_cli.cpp) hold the text users see.
std::string_view circana_option_words(Remedy remedy) noexcept {
  switch (remedy) {
    case Remedy::give_radius:
      return "--radius";
    case Remedy::give_centre:
      return "--centre";
    case Remedy::f_about_nominal:
      return "--f-centre nominal";
    case Remedy::units_inch:
      return "--units inch";
    case Remedy::units_mm:
      return "--units mm";
    case Remedy::give_plane:
      return "--plane";
    case Remedy::evaluate_anyway:
      return "--warn-inconsistent";
    case Remedy::radius_tolerance:
      return "--radius-tolerance";
    case Remedy::give_machine:
      return "--machine NAME";
  }
  return library_remedy_words(remedy);
}

// The columns the evaluation reads: time, marker, segment, the plane's actual and commanded
// positions, the normal axis's actual position (it must stand still during a run), the radial
// channel, and any named with --columns. The plane is known only at the header (option, else
// metadata), so the reader asks then; an XY trace's z_cmd is never parsed.
TraceReadOptions::KeepFor analysis_columns(const EvaluationOptions& options) {
  return [plane = options.plane, a = options.column_a,
          b = options.column_b](const TraceMetadata& metadata) {
    Plane p = plane.value_or(Plane::XY);
    if (!plane) {
      // An unreadable plane keeps every axis; the evaluation then reports it with its line.
      const std::string* text = metadata.find(meta_key::plane);
      if (text && !parse_plane(*text)) return std::vector<std::string>{};
      if (text) p = *parse_plane(*text);
    }
    const PlaneAxes axes = plane_axes(p);
    std::vector<std::string> keep = {
        column_name::t, column_name::marker, column_name::segment, column_name::actual(axes.first),
        column_name::actual(axes.second), column_name::actual(axes.normal),
        column_name::commanded(axes.first), column_name::commanded(axes.second),
        column_name::feedback(axes.first), column_name::feedback(axes.second),
        std::string(kRadialColumn),
        // Temperatures recorded per sample: the budget's drift.
        meta_key::temperature_machine_C, meta_key::temperature_instrument_C};
    if (!a.empty()) keep.push_back(a);
    if (!b.empty()) keep.push_back(b);
    // A plane option that contradicts the trace's own plane: its axes are kept too, so a
    // refusal can show where the motion really was.
    if (plane) {
      const std::string* text = metadata.find(meta_key::plane);
      const std::optional<Plane> recorded = text ? parse_plane(*text) : std::nullopt;
      if (recorded && *recorded != *plane) {
        const PlaneAxes other = plane_axes(*recorded);
        keep.push_back(column_name::actual(other.first));
        keep.push_back(column_name::actual(other.second));
      }
    }
    return keep;
  };
}

// The metadata goes into every output (the JSON conditions, the plots, the history), which
// must be UTF-8 text: a trace written in another encoding is refused at the line and key
// rather than printed as a document no JSON or XML reader accepts.
void require_utf8_metadata(const TraceMetadata& metadata, const std::string& path) {
  const auto& entries = metadata.entries();
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const auto& [key, value] = entries[i];
    for (const std::string* text : {&key, &value}) {
      const std::size_t bad = invalid_utf8_offset(*text);
      if (bad == std::string::npos) continue;
      throw ParseError(
          path, metadata.line_at(i),
          fmt::format("metadata '{}': not UTF-8 text (byte 0x{:02X} at {} of the {}): "
                      "write the trace in UTF-8 (iconv -f LATIN1 -t UTF-8)",
                      utf8_replacing_invalid(key), static_cast<unsigned char>((*text)[bad]),
                      bad + 1, text == &key ? "key" : "value"));
    }
  }
}

// FN(), whose refusals name `path` when they come from code that sees bare numbers (a circle
// fit, a model fit): the file is the one thing they cannot know, and "<input>" tells the user
// nothing.
template <typename Fn>
auto naming_file(const std::string& path, const Fn& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const InputError& e) {
    if (!e.file().empty()) throw;
    if (e.code() == ExitCode::parse) throw ParseError(path, e.line(), e.detail());
    throw DataError(path, e.line(), e.detail());
  }
}

// The diagnosis of an evaluated trace, errors naming its file.
Diagnosis diagnose_evaluated(const std::string& path, const Trace& trace, const Evaluation& ev,
                             const DiagnosisOptions& options = {}) {
  return naming_file(path, [&] { return diagnose(trace, ev, options); });
}

// Stores a test (its diagnosis too, when given); returns the line that says so.
// `source`: the file the evaluation was read from (a trace or a result document), for messages.
std::string store_result(const Evaluation& ev, const Diagnosis* diagnosis,
                         const std::string& trace_path, const std::string& db_url,
                         const std::string& source) {
  history::TestRecord record = history_record(ev, diagnosis, {}, circana_option_words, source);
  std::error_code ec;
  if (!trace_path.empty() && std::filesystem::is_regular_file(trace_path, ec)) {
    record.trace_sha256 = sha256_of_file(trace_path);
    record.trace_path = utf8_replacing_invalid(std::filesystem::absolute(trace_path, ec).string());
  }
  const auto store = history::open_store(db_url, "--db");
  const std::int64_t id = store->add(record);
  return fmt::format(
      "Stored as test {} of machine {} (tested at {}) in {}{}\n", id, record.machine,
      record.tested_at.empty() ? std::string("the time of storing") : record.tested_at,
      store->name(),
      record.trace_sha256.empty() ? "; the trace file was not found, no SHA-256" : "");
}

// A ball bar's trace (forced, or no position columns named and an `r` channel present): the
// positions from the bar's length along the commanded angle, and the options pointed at them.
std::optional<RadialPositions> radial_set_up(const Trace& read, bool forced,
                                             EvaluationOptions& options) {
  if (!forced &&
      !(options.column_a.empty() && is_radial_trace(read, trace_plane(read, options.plane)))) {
    return std::nullopt;
  }
  RadialOptions ro_radial;
  ro_radial.plane = options.plane;
  ro_radial.centre = options.centre;
  ro_radial.radius_mm = options.nominal_radius_mm;
  RadialPositions radial = radial_positions(read, ro_radial);
  options.column_a = radial.column_a;
  options.column_b = radial.column_b;
  if (!options.centre) options.centre = PlanePoint{radial.centre_a_mm, radial.centre_b_mm};
  return radial;
}
}  // namespace

namespace {

// One plane's trace evaluated: units, a ball bar's positions, the evaluation, finite results.
EvaluatedTrace evaluate_read(const std::string& path, Trace read, const EvaluationOptions& given,
                             bool radial_forced) {
  return naming_file(path, [&] {
    // An inch program's trace: positions in mm or in inch, decided before anything is fitted.
    const std::optional<std::string> units = resolve_units(
        read, trace_plane(read, given.plane), given.nominal_radius_mm, given.input_checks);
    EvaluationOptions options = given;
    // A ball bar's trace: positions from the bar's length along the commanded angle.
    std::optional<RadialPositions> radial = radial_set_up(read, radial_forced, options);
    EvaluatedTrace out;
    out.radial = radial.has_value();
    out.trace = radial ? std::move(radial->trace) : std::move(read);
    out.evaluation = evaluate(out.trace, options);
    if (radial) out.evaluation.notes.insert(out.evaluation.notes.begin(), radial->note);
    if (units) out.evaluation.notes.insert(out.evaluation.notes.begin(), *units);
    if (!out.trace.column(column_name::t)) {
      out.evaluation.notes.push_back(
          "no 't' column: time order not checked, feed not reported (docs/trace-format.md)");
    }
    require_finite_results(out.evaluation, circana_option_words);
    return out;
  });
}

// The planes' names joined: "XY,YZ,ZX".
std::string plane_names(const std::vector<EvaluatedTrace>& planes) {
  std::string s;
  for (const EvaluatedTrace& p : planes) {
    s += (s.empty() ? "" : ",") + std::string(plane_name(p.evaluation.plane));
  }
  return s;
}

// PATH with the plane before its extension: plot.svg -> plot-XY.svg.
std::string plane_path(const std::string& path, Plane plane) {
  const std::filesystem::path p(path);
  std::filesystem::path out = p;
  out.replace_filename(p.stem().string() + "-" + std::string(plane_name(plane)) +
                       p.extension().string());
  return out.string();
}

// Writes a set's plots (path, SVG); every path is checked before the first is written, so
// that a plot path that is a folder or a device leaves no plot of the set behind.
void write_plane_plots(const std::vector<std::pair<std::string, std::string>>& plots) {
  for (const auto& plot : plots) checked_output_target(plot.first);
  for (const auto& [path, svg] : plots) write_file_atomic(path, svg);
}

}  // namespace

std::vector<EvaluatedTrace> evaluate_file_planes(const std::string& path,
                                                 const EvaluationOptions& asked,
                                                 bool radial_forced) {
  EvaluationOptions given = asked;
  given.input_checks.remedy_words = circana_option_words;
  TraceReadOptions ro;
  ro.keep_for = analysis_columns(given);
  // Columns asked for by name must exist; the reader's message lists every column found.
  for (const std::string* c : {&given.column_a, &given.column_b}) {
    if (!c->empty()) ro.required.push_back(*c);
  }
  Trace read = read_trace(path, ro);
  require_utf8_metadata(read.metadata, path);
  const std::optional<std::vector<Plane>> set =
      naming_file(path, [&] { return test_set_planes(read); });
  std::vector<EvaluatedTrace> out;
  if (!set) {
    out.push_back(evaluate_read(path, std::move(read), given, radial_forced));
    return out;
  }
  std::vector<PlaneTrace> planes = naming_file(path, [&] { return split_test_set(read, *set); });
  read = Trace();  // the planes hold copies of their rows
  if (given.plane) {
    const auto it = std::find_if(planes.begin(), planes.end(),
                                 [&](const PlaneTrace& p) { return p.plane == *given.plane; });
    if (it == planes.end()) {
      std::string names;
      for (const PlaneTrace& p : planes)
        names += (names.empty() ? "" : ",") + std::string(plane_name(p.plane));
      throw DataError(path, 0,
                      fmt::format("--plane {}: not a plane of this test set (planes {})",
                                  plane_name(*given.plane), names));
    }
    out.push_back(evaluate_read(path, std::move(it->trace), given, radial_forced));
    return out;
  }
  for (PlaneTrace& p : planes) {
    EvaluationOptions options = given;
    options.plane = p.plane;
    out.push_back(evaluate_read(path, std::move(p.trace), options, radial_forced));
  }
  return out;
}

EvaluatedTrace evaluate_file(const std::string& path, const EvaluationOptions& asked,
                             bool radial_forced) {
  std::vector<EvaluatedTrace> planes = evaluate_file_planes(path, asked, radial_forced);
  if (planes.size() > 1) {
    throw DataError(path, 0,
                    fmt::format("a test set of the planes {}: this command reads one plane; "
                                "give --plane with one of them (circana analyze and diagnose "
                                "read the whole set)",
                                plane_names(planes)));
  }
  return std::move(planes.front());
}

namespace {

// circana analyze of a test set: each plane's report in program order, its plot per plane.
int analyze_set(const AnalyzeRequest& request, const std::vector<EvaluatedTrace>& planes,
                std::optional<ProgressTicker>& progress, std::ostream& out) {
  if (!request.compare_path.empty()) {
    throw UsageError(
        fmt::format("--compare: {} is a test set ({}): compare one plane, chosen "
                    "with --plane",
                    request.trace_path, plane_names(planes)));
  }
  std::string text;
  nlohmann::ordered_json doc;
  if (request.json) {
    doc["test_set"] = nlohmann::ordered_json::array();
    doc["planes"] = nlohmann::ordered_json::array();
  } else {
    text = fmt::format("Test set {}: planes {}\n", request.trace_path, plane_names(planes));
  }
  std::vector<std::pair<std::string, std::string>> plots;
  const std::optional<ResultLimits>& limits = request.limits;
  bool pass = true;
  for (const EvaluatedTrace& p : planes) {
    const Plane plane = p.evaluation.plane;
    std::optional<Diagnosis> diagnosis;
    std::string diagnosis_error;
    if (!request.json || !request.svg_path.empty()) {
      try {
        diagnosis = diagnose_evaluated(request.trace_path, p.trace, p.evaluation);
      } catch (const Error& e) {
        diagnosis_error = e.what();
      }
    }
    if (request.json) {
      doc["test_set"].push_back(std::string(plane_name(plane)));
      doc["planes"].push_back(to_json(p.evaluation));
      if (limits) pass &= add_limit_verdicts(p.evaluation, *limits, nullptr, &doc["planes"].back());
    } else {
      text += fmt::format("\n=== Plane {} ===\n", plane_name(plane)) + text_report(p.evaluation);
      if (limits) pass &= add_limit_verdicts(p.evaluation, *limits, &text, nullptr);
      text += diagnosis ? short_text_report(*diagnosis)
                        : std::string("\nDiagnosis: not available (") + diagnosis_error + ")\n";
    }
    if (!request.svg_path.empty()) {
      PlotOptions plot = request.plot;
      if (diagnosis) plot.diagnosis = &*diagnosis;
      plots.emplace_back(plane_path(request.svg_path, plane),
                         svg_plot(p.evaluation, p.trace, plot));
    }
  }
  write_plane_plots(plots);
  if (request.store) {
    for (const EvaluatedTrace& p : planes) {
      const std::string stored = store_result(p.evaluation, nullptr, request.trace_path,
                                              request.db_url, request.trace_path);
      if (!request.json) text += "\n" + stored;
    }
  }
  progress.reset();
  out << (request.json ? json_text(doc, 2) + "\n" : text);
  out.flush();
  return pass ? 0 : static_cast<int>(ExitCode::tolerance);
}

}  // namespace

int run_analyze(const AnalyzeRequest& request, std::ostream& out) {
  if (!request.compare_path.empty() && request.svg_path.empty()) {
    throw UsageError("--compare: draws into the plot, so it needs --svg");
  }
  // A status line on a terminal while a large trace is read and fitted; gone before the
  // report is printed.
  std::optional<ProgressTicker> progress(std::in_place, "circana analyze");
  progress->stage("reading and evaluating " + request.trace_path);
  const std::vector<EvaluatedTrace> planes =
      evaluate_file_planes(request.trace_path, request.options, request.radial);
  if (planes.size() > 1) return analyze_set(request, planes, progress, out);
  const EvaluatedTrace& evaluated = planes.front();
  const Trace& trace = evaluated.trace;
  const Evaluation& ev = evaluated.evaluation;
  progress->stage("diagnosing " + request.trace_path);
  nlohmann::ordered_json doc = request.json ? to_json(ev) : nlohmann::ordered_json();
  std::string text = request.json ? std::string() : text_report(ev);
  const bool pass = !request.limits || add_limit_verdicts(ev, *request.limits, &text, &doc);
  if (request.json) text = json_text(doc, 2) + "\n";
  // The diagnosis is a summary here (text, and a panel of the plot); a trace it cannot handle
  // still gets its H, G and F.
  std::optional<Diagnosis> diagnosis;
  std::string diagnosis_error;
  if (!request.json || !request.svg_path.empty()) {
    try {
      diagnosis = diagnose_evaluated(request.trace_path, trace, ev);
    } catch (const Error& e) {
      diagnosis_error = e.what();
    }
  }
  if (!request.json) {
    text += diagnosis ? short_text_report(*diagnosis)
                      : std::string("\nDiagnosis: not available (") + diagnosis_error + ")\n";
  }
  if (!request.svg_path.empty() && !request.compare_path.empty()) {
    const EvaluatedTrace before =
        evaluate_file(request.compare_path, request.options, request.radial);
    write_file_atomic(request.svg_path, svg_plot({{&before.evaluation, &before.trace, "before"},
                                                  {&ev, &trace, "after"}},
                                                 request.plot));
  } else if (!request.svg_path.empty()) {
    PlotOptions plot = request.plot;
    if (diagnosis) plot.diagnosis = &*diagnosis;
    write_file_atomic(request.svg_path, svg_plot(ev, trace, plot));
  }
  if (request.store) {
    const std::string stored =
        store_result(ev, nullptr, request.trace_path, request.db_url, request.trace_path);
    if (!request.json) text += "\n" + stored;
  }
  progress.reset();
  out << text;
  out.flush();
  return pass ? 0 : static_cast<int>(ExitCode::tolerance);
}

namespace {

// The options a plane's diagnosis runs with: a ball bar's trace measures no absolute length
// along an axis.
DiagnosisOptions plane_options(const DiagnoseRequest& request, const EvaluatedTrace& evaluated) {
  DiagnosisOptions options = request.options;
  if (evaluated.radial) options.absolute_channels = false;
  return options;
}

// What was evaluated: the units and radial notes lead the evaluation's notes.
void lead_with_evaluation_notes(const EvaluatedTrace& evaluated, Diagnosis& d) {
  const auto& en = evaluated.evaluation.notes;
  const std::size_t lead =
      (evaluated.radial ? 1u : 0u) + (!en.empty() && en.front().starts_with("units: ") ? 1u : 0u);
  d.notes.insert(d.notes.begin(), en.begin(),
                 en.begin() + static_cast<std::ptrdiff_t>(std::min(lead, en.size())));
}

// The diagnosis of one evaluated plane, with the notes on what was evaluated leading.
Diagnosis diagnose_plane(const DiagnoseRequest& request, const EvaluatedTrace& evaluated) {
  const DiagnosisOptions options = plane_options(request, evaluated);
  Diagnosis d =
      diagnose_evaluated(request.trace_path, evaluated.trace, evaluated.evaluation, options);
  lead_with_evaluation_notes(evaluated, d);
  return d;
}

// Stores each plane's result when asked (its summary after a text report), ends the progress
// line and writes the report.
int finish_diagnose(const DiagnoseRequest& request, std::string text,
                    const std::vector<std::pair<const Evaluation*, const Diagnosis*>>& results,
                    std::optional<ProgressTicker>& progress, std::ostream& out) {
  if (request.store) {
    for (const auto& [evaluation, diagnosis] : results) {
      const std::string stored = store_result(*evaluation, diagnosis, request.trace_path,
                                              request.db_url, request.trace_path);
      if (!request.json) text += "\n" + stored;
    }
  }
  progress.reset();
  out << text;
  out.flush();
  return 0;
}

int diagnose_set_command(const DiagnoseRequest& request, const std::vector<EvaluatedTrace>& planes,
                         std::optional<ProgressTicker>& progress, std::ostream& out) {
  std::vector<SetPlaneInput> inputs;
  for (const EvaluatedTrace& p : planes)
    inputs.push_back({&p.trace, &p.evaluation, plane_options(request, p)});
  SetDiagnosis set =
      naming_file(request.trace_path, [&] { return diagnose_set(request.trace_path, inputs); });
  for (std::size_t k = 0; k < planes.size(); ++k) {
    lead_with_evaluation_notes(planes[k], set.plane_diagnoses[k]);
  }
  if (!request.svg_path.empty()) {
    std::vector<std::pair<std::string, std::string>> plots;
    for (std::size_t k = 0; k < planes.size(); ++k) {
      PlotOptions plot = request.plot;
      plot.diagnosis = &set.plane_diagnoses[k];
      plots.emplace_back(plane_path(request.svg_path, planes[k].evaluation.plane),
                         svg_plot(planes[k].evaluation, planes[k].trace, plot));
    }
    write_plane_plots(plots);
  }
  std::vector<std::pair<const Evaluation*, const Diagnosis*>> results;
  for (std::size_t k = 0; k < planes.size(); ++k)
    results.emplace_back(&planes[k].evaluation, &set.plane_diagnoses[k]);
  return finish_diagnose(request,
                         request.json ? json_text(to_json(set), 2) + "\n" : text_report(set),
                         results, progress, out);
}

}  // namespace

int run_diagnose(const DiagnoseRequest& request, std::ostream& out) {
  std::optional<ProgressTicker> progress(std::in_place, "circana diagnose");
  progress->stage("reading and evaluating " + request.trace_path);
  const std::vector<EvaluatedTrace> planes =
      evaluate_file_planes(request.trace_path, request.options.evaluation, request.radial);
  progress->stage("diagnosing " + request.trace_path);
  if (planes.size() > 1) return diagnose_set_command(request, planes, progress, out);
  const EvaluatedTrace& evaluated = planes.front();
  Diagnosis d = diagnose_plane(request, evaluated);
  if (!request.svg_path.empty()) {
    PlotOptions plot = request.plot;
    plot.diagnosis = &d;
    write_file_atomic(request.svg_path, svg_plot(evaluated.evaluation, evaluated.trace, plot));
  }
  return finish_diagnose(request, request.json ? json_text(to_json(d), 2) + "\n" : text_report(d),
                         {{&evaluated.evaluation, &d}}, progress, out);
}

namespace {

// The evaluation document given to circana store, when `path` holds one (its first byte that
// is not blank is '{'); nullopt for a trace. A regular file is peeked at; anything else (a
// pipe) can be read once only, so it must hold a document.
std::optional<nlohmann::ordered_json> store_document(const std::string& path) {
  std::error_code ec;
  std::string text;
  if (std::filesystem::is_regular_file(path, ec)) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path, "cannot open for reading");
    std::string head(4096, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
    const auto first = head.find_first_not_of(" \t\r\n");
    if (first == std::string::npos || head[first] != '{') return std::nullopt;
    text = read_input_text(path, kMaxJsonDocumentBytes);
  } else {
    text = read_input_text(path, kMaxJsonDocumentBytes);
    const auto first = text.find_first_not_of(" \t\r\n");
    if (first == std::string::npos || text[first] != '{') {
      throw IoError(path,
                    "not a regular file: circana store reads a trace from a regular file (a "
                    "result document may come through a pipe)");
    }
  }
  return parse_ordered_json_text(text, path);
}

}  // namespace

int run_store(const StoreRequest& request, std::ostream& out) {
  if (std::optional<nlohmann::ordered_json> document = store_document(request.path)) {
    if (!document->is_object()) throw ParseError(request.path, 0, "expected a JSON object");
    const auto schema = document->find(diagnosis_json::key::schema);
    if (schema != document->end() && schema->is_string() &&
        schema->get<std::string>().starts_with(diagnosis_json::kSchemaFamily)) {
      throw DataError(request.path, 0,
                      "a diagnosis document: store the trace (circana diagnose --store) or its "
                      "evaluation (circana analyze --json)");
    }
    // Conditions are optional in a hand-made document; the command line adds to them.
    if (!document->contains("conditions")) {
      (*document)["conditions"] = nlohmann::ordered_json::object();
    }
    Evaluation ev = evaluation_from_json(*document, request.path);
    for (const auto& [key, value] : request.options.conditions) ev.conditions.set(key, value);
    out << store_result(ev, nullptr, ev.source, request.db_url, request.path);
    out.flush();
    return 0;
  }
  // A trace: evaluated and stored as analyze --store does (no diagnosis: diagnose --store).
  std::optional<ProgressTicker> progress(std::in_place, "circana store");
  progress->stage("reading and evaluating " + request.path);
  const EvaluatedTrace evaluated = evaluate_file(request.path, request.options, request.radial);
  progress->stage("storing " + request.path);
  std::string stored =
      store_result(evaluated.evaluation, nullptr, request.path, request.db_url, request.path);
  progress.reset();
  out << stored;
  out.flush();
  return 0;
}

int run_history(const HistoryRequest& request, std::ostream& out) {
  std::string since;
  if (!request.since.empty()) {
    const auto canonical = canonical_utc_iso8601(request.since);
    if (!canonical) {
      throw UsageError(
          "--since: expected a real date YYYY-MM-DD or date-time "
          "YYYY-MM-DDTHH:MM[:SS][Z|+HH:MM], got '" +
          request.since + "'");
    }
    since = *canonical;
  }
  const history::Limits limits = request.limits.empty()
                                     ? history::Limits{}
                                     : history::parse_limits(request.limits, "--limits");
  const auto store = history::open_store(request.db_url, "--db");
  const auto machines = store->machines();
  if (std::find(machines.begin(), machines.end(), request.machine) == machines.end()) {
    throw Error(
        ExitCode::data,
        fmt::format("{}: no tests of machine '{}' (machines in the history: {})", store->name(),
                    request.machine, machines.empty() ? "none" : join(machines, ", ")));
  }
  const auto tests = store->tests(request.machine, since);
  if (tests.empty() && !limits.empty()) {
    throw Error(ExitCode::data,
                fmt::format("{}: no tests of machine '{}' since {}: nothing to check",
                            store->name(), request.machine, since));
  }
  if (!request.svg_path.empty()) {
    write_file_atomic(request.svg_path, history::history_svg(request.machine, tests, limits));
  }
  out << (request.json ? json_text(history::history_json(request.machine, tests, limits), 2) + "\n"
                       : history::history_text(request.machine, tests, limits));
  out.flush();
  if (!limits.empty() && !history::breaches(tests.back(), limits).empty()) {
    return static_cast<int>(ExitCode::tolerance);
  }
  return 0;
}

int run_fit(const FitRequest& request, std::ostream& out) {
  TraceReadOptions ro;
  ro.keep = {request.column_a, request.column_b};
  ro.required = ro.keep;
  ro.check_time_monotonic = false;
  const Trace trace = read_trace(request.points_path, ro);
  if (trace.rows() < 3) {
    throw DataError(request.points_path,
                    trace.rows() ? trace.line_of_row.back() : trace.header_line,
                    fmt::format("too few points: {}, expected at least 3", trace.rows()));
  }
  const auto& a = *trace.column(request.column_a);
  const auto& b = *trace.column(request.column_b);
  const FitReport report = naming_file(request.points_path, [&] {
    return detail::with_rows_context(trace, 0, trace.rows(), "the points",
                                     [&] { return fit_all(request.points_path, a, b); });
  });
  out << (request.json ? json_text(to_json(report), 2) + "\n" : text_report(report));
  out.flush();
  return 0;
}

namespace {

// An output that is the input would be replaced by what was read from it.
void refuse_output_over_input(const std::string& input, const std::string& output) {
  std::error_code ec;
  if (std::filesystem::equivalent(input, output, ec)) {
    throw UsageError(
        fmt::format("-o {}: the same file as the input {}: name another output", output, input));
  }
}

}  // namespace

int run_import(const ImportRequest& request, std::ostream& out) {
  refuse_output_over_input(request.input_path, request.output_path);
  std::optional<ProgressTicker> progress(std::in_place, "circana import");
  progress->stage("reading " + request.input_path);
  const Trace trace = import_export_text(read_input_text(request.input_path, kMaxPolarExportBytes),
                                         request.input_path, request.options);
  progress->stage("writing " + request.output_path);
  write_trace(request.output_path, trace);
  progress.reset();
  // The segment column holds whole run ids from 1 (checked on reading), so this is exact.
  std::set<double> runs;
  if (const auto* segment = trace.column(column_name::segment)) {
    runs.insert(segment->begin(), segment->end());
  }
  out << fmt::format("{}: {} rows, {} -> {}\n", request.input_path, trace.rows(),
                     runs.empty() ? std::string("runs found by the analysis")
                                  : fmt::format("{} run(s)", runs.size()),
                     request.output_path);
  out.flush();
  return 0;
}

int run_export_polar(const ExportPolarRequest& request, std::ostream& out) {
  refuse_output_over_input(request.trace_path, request.output_path);
  std::optional<ProgressTicker> progress(std::in_place, "circana export-polar");
  progress->stage("reading and evaluating " + request.trace_path);
  EvaluatedTrace evaluated = evaluate_file(request.trace_path, request.options, request.radial);
  // Conditions stated on the command line are the test's, as in analyze's report.
  for (const auto& [key, value] : request.options.conditions) {
    evaluated.trace.metadata.set(key, value);
  }
  progress->stage("writing " + request.output_path);
  write_file_atomic(request.output_path, polar_export_text(evaluated.trace, evaluated.evaluation));
  progress.reset();
  std::size_t points = 0;
  for (const RunResult& r : evaluated.evaluation.runs) points += r.run.size();
  out << fmt::format("{}: {} run(s), {} points -> {}\n", request.trace_path,
                     evaluated.evaluation.runs.size(), points, request.output_path);
  out.flush();
  return 0;
}

}  // namespace circtest
