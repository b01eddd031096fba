// circana report: the traces evaluated, diagnosed and drawn into one HTML file.
#include <fmt/format.h>

#include <algorithm>
#include <optional>

#include "circtest/analysis/html_report.hpp"
#include "circtest/circana/commands.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/history/history.hpp"

namespace circtest {

namespace {

// The index of the page of `plane`; a DataError naming `path` when there is none.
std::size_t page_of(const std::vector<EvaluatedTrace>& tests, Plane plane, const std::string& path,
                    const char* what) {
  for (std::size_t i = 0; i < tests.size(); ++i) {
    if (tests[i].evaluation.plane == plane) return i;
  }
  std::string planes;
  for (const auto& t : tests) {
    planes += (planes.empty() ? "" : ", ") + std::string(plane_name(t.evaluation.plane));
  }
  throw DataError(path, 0,
                  fmt::format("{} of plane {}, but the report's traces are of plane(s) {}", what,
                              plane_name(plane), planes));
}

void trend(ReportPage& page, history::Store& store, const Evaluation& ev) {
  const std::string* m = ev.conditions.find(meta_key::machine);
  if (!m || m->empty()) {
    page.trend_note = "no trend: the trace names no machine (--machine NAME or # machine:)";
    return;
  }
  std::vector<history::TestRecord> tests;
  for (auto& t : store.tests(*m, "")) {
    if (t.plane == plane_name(ev.plane)) tests.push_back(std::move(t));
  }
  if (tests.empty()) {
    page.trend_note = fmt::format("no tests of machine {} in plane {} in {}", *m,
                                  plane_name(ev.plane), store.name());
    return;
  }
  page.trend_svg =
      history::history_svg(fmt::format("{}, plane {}", *m, plane_name(ev.plane)), tests, {});
  page.trend_note = fmt::format("{} test(s) from {}, {} to {}", tests.size(), store.name(),
                                tests.front().tested_at, tests.back().tested_at);
}

}  // namespace

int run_report(const ReportRequest& request, std::ostream& out) {
  if (request.trace_paths.empty()) throw UsageError("missing the TRACE argument");
  if (request.output_path.empty()) throw UsageError("-o: the HTML file to write is required");
  auto eval = [&request](const std::string& path) {
    return evaluate_file(path, request.options, request.radial);
  };
  std::vector<EvaluatedTrace> tests;
  for (const auto& path : request.trace_paths) {
    tests.push_back(eval(path));
    for (std::size_t i = 0; i + 1 < tests.size(); ++i) {
      if (tests[i].evaluation.plane == tests.back().evaluation.plane) {
        throw DataError(
            path, 0,
            fmt::format("plane {} twice in one report (also {}): one trace per plane",
                        plane_name(tests.back().evaluation.plane), request.trace_paths[i]));
      }
    }
  }
  std::vector<std::optional<EvaluatedTrace>> befores(tests.size());
  for (const auto& path : request.before_paths) {
    EvaluatedTrace b = eval(path);
    const std::size_t i = page_of(tests, b.evaluation.plane, path, "a before trace");
    if (befores[i]) {
      throw DataError(
          path, 0,
          fmt::format("a second before trace of plane {}", plane_name(b.evaluation.plane)));
    }
    befores[i] = std::move(b);
  }
  std::vector<ReportPage> pages(tests.size());
  for (const auto& path : request.diagnosis_paths) {
    DiagnosisChart chart = diagnosis_chart_from_json(read_json_file(path), path);
    const std::size_t i = page_of(tests, chart.plane, path, "a diagnosis");
    if (pages[i].diagnosis) {
      throw DataError(path, 0,
                      fmt::format("a second diagnosis of plane {}", plane_name(chart.plane)));
    }
    pages[i].diagnosis = std::move(chart);
  }
  std::unique_ptr<history::Store> store;
  if (!request.db_url.empty()) store = history::open_store(request.db_url, "--db");
  for (std::size_t i = 0; i < tests.size(); ++i) {
    ReportPage& page = pages[i];
    page.evaluation = &tests[i].evaluation;
    page.trace = &tests[i].trace;
    if (befores[i]) {
      page.before = &befores[i]->evaluation;
      page.before_trace = &befores[i]->trace;
    }
    if (!page.diagnosis) {
      DiagnosisOptions options;
      options.evaluation = request.options;
      // A ball bar measures no absolute length along an axis (as circana diagnose).
      options.absolute_channels = !tests[i].radial;
      try {
        page.diagnosis = diagnosis_chart(diagnose(tests[i].trace, tests[i].evaluation, options));
      } catch (const Error& e) {
        // H, G and F stand without a diagnosis; the page says why there is none.
        page.diagnosis_note = e.what();
      }
    }
    if (store) {
      trend(page, *store, tests[i].evaluation);
    } else {
      page.trend_note = "not shown: give the history with --db (circana store, docs/history.md)";
    }
  }
  write_file_atomic(request.output_path, html_report(pages, request.plot));
  out << fmt::format("Wrote {}: {} plane page(s) ({})\n", request.output_path, pages.size(), [&] {
    std::string planes;
    for (const auto& t : tests) {
      planes += (planes.empty() ? "" : ", ") + std::string(plane_name(t.evaluation.plane));
    }
    return planes;
  }());
  out.flush();
  return 0;
}

}  // namespace circtest
