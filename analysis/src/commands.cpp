#include "circtest/analysis/commands.hpp"

#include <fmt/format.h>

#include <cmath>
#include <optional>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/plot.hpp"
#include "circtest/analysis/radial.hpp"
#include "circtest/analysis/report.hpp"
#include "circtest/analysis/result_checks.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"

namespace circtest {

namespace {
std::vector<std::string> analysis_columns(const std::string& a, const std::string& b) {
  std::vector<std::string> keep = {"t", "marker", "segment", "x",     "y",
                                   "z", "x_cmd",  "y_cmd",   "z_cmd", std::string(kRadialColumn)};
  if (!a.empty()) keep.push_back(a);
  if (!b.empty()) keep.push_back(b);
  return keep;
}
}  // namespace

int run_analyze(const AnalyzeRequest& request, std::ostream& out) {
  TraceReadOptions ro;
  ro.keep = analysis_columns(request.options.column_a, request.options.column_b);
  // Columns asked for by name must exist; the reader's message lists every column found.
  for (const std::string* c : {&request.options.column_a, &request.options.column_b}) {
    if (!c->empty()) ro.required.push_back(*c);
  }
  const Trace read = read_trace(request.trace_path, ro);
  EvaluationOptions options = request.options;
  // A ball bar's trace: positions from the bar's length along the commanded angle.
  std::optional<RadialPositions> radial;
  if (request.radial ||
      (options.column_a.empty() && is_radial_trace(read, trace_plane(read, options.plane)))) {
    RadialOptions ro_radial;
    ro_radial.plane = options.plane;
    ro_radial.centre = options.centre;
    ro_radial.radius_mm = options.nominal_radius_mm;
    radial = radial_positions(read, ro_radial);
    options.column_a = radial->column_a;
    options.column_b = radial->column_b;
    if (!options.centre) options.centre = PlanePoint{radial->centre_a_mm, radial->centre_b_mm};
  }
  const Trace& trace = radial ? radial->trace : read;
  Evaluation ev = evaluate(trace, options);
  if (radial) ev.notes.insert(ev.notes.begin(), radial->note);
  if (!read.column("t")) {
    ev.notes.push_back(
        "no 't' column: time order not checked, feed not reported (docs/trace-format.md)");
  }
  require_finite_results(ev);
  std::string text = request.json ? to_json(ev).dump(2) + "\n" : text_report(ev);
  if (!request.json) {
    // The diagnosis is a summary here; a trace it cannot handle still gets its H, G and F.
    try {
      text += short_text_report(diagnose(trace, ev));
    } catch (const Error& e) {
      text += std::string("\nDiagnosis: not available (") + e.what() + ")\n";
    }
  }
  if (!request.svg_path.empty())
    write_file_atomic(request.svg_path, svg_plot(ev, trace, request.plot));
  out << text;
  out.flush();
  return 0;
}

int run_diagnose(const DiagnoseRequest& request, std::ostream& out) {
  TraceReadOptions ro;
  ro.keep =
      analysis_columns(request.options.evaluation.column_a, request.options.evaluation.column_b);
  const Trace read = read_trace(request.trace_path, ro);
  DiagnosisOptions options = request.options;
  EvaluationOptions& eo = options.evaluation;
  // A ball bar's trace, as for analyze: it measures no absolute length along an axis.
  std::optional<RadialPositions> radial;
  if (request.radial ||
      (eo.column_a.empty() && is_radial_trace(read, trace_plane(read, eo.plane)))) {
    RadialOptions ro_radial;
    ro_radial.plane = eo.plane;
    ro_radial.centre = eo.centre;
    ro_radial.radius_mm = eo.nominal_radius_mm;
    radial = radial_positions(read, ro_radial);
    eo.column_a = radial->column_a;
    eo.column_b = radial->column_b;
    if (!eo.centre) eo.centre = PlanePoint{radial->centre_a_mm, radial->centre_b_mm};
    options.absolute_channels = false;
  }
  Diagnosis d = diagnose(radial ? radial->trace : read, options);
  if (radial) d.notes.insert(d.notes.begin(), radial->note);
  out << (request.json ? to_json(d).dump(2) + "\n" : text_report(d));
  out.flush();
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
  const FitReport report = fit_all(request.points_path, a, b);
  out << (request.json ? to_json(report).dump(2) + "\n" : text_report(report));
  out.flush();
  return 0;
}

int run_import_polar(const ImportPolarRequest& request, std::ostream& out) {
  if (!(request.radius_mm > 0.0) || !std::isfinite(request.radius_mm)) {
    throw UsageError("--radius: the nominal radius of the test must be positive");
  }
  const std::vector<PolarPoint> points =
      parse_polar_text(read_file(request.input_path), request.input_path);
  const Trace trace = polar_to_trace(points, request.plane, request.radius_mm, request.input_path);
  write_trace(request.output_path, trace);
  // polar_to_trace numbers the runs 1, 2, ... itself, so the last id is a small whole number.
  const auto runs = trace.values[4].empty() ? 0.0 : trace.values[4].back();
  out << fmt::format("{}: {} points, {} run(s) -> {}\n", request.input_path, points.size(), runs,
                     request.output_path);
  out.flush();
  return 0;
}

}  // namespace circtest
