#include "circtest/analysis/commands.hpp"

#include <fmt/format.h>

#include "circtest/analysis/plot.hpp"
#include "circtest/analysis/report.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"

namespace circtest {

namespace {
std::vector<std::string> analysis_columns(const std::string& a, const std::string& b) {
  std::vector<std::string> keep = {"t", "marker", "segment", "x",    "y",
                                   "z", "x_cmd",  "y_cmd",   "z_cmd"};
  if (!a.empty()) keep.push_back(a);
  if (!b.empty()) keep.push_back(b);
  return keep;
}
}  // namespace

int run_analyze(const AnalyzeRequest& request, std::ostream& out) {
  TraceReadOptions ro;
  ro.keep = analysis_columns(request.options.column_a, request.options.column_b);
  const Trace trace = read_trace(request.trace_path, ro);
  const Evaluation ev = evaluate(trace, request.options);
  const std::string text = request.json ? to_json(ev).dump(2) + "\n" : text_report(ev);
  if (!request.svg_path.empty())
    write_file_atomic(request.svg_path, svg_plot(ev, trace, request.plot));
  out << text;
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

}  // namespace circtest
