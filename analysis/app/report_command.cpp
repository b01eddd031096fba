// circana report: the traces evaluated, diagnosed and drawn into one HTML file.
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <optional>
#include <sstream>

#include "circtest/analysis/html_report.hpp"
#include "circtest/circana/commands.hpp"
#include "circtest/circana/history_record.hpp"
#include "circtest/circana/plan_changes.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/sha256.hpp"
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
    page.trend_note = "not shown: the test names no machine";
    return;
  }
  std::vector<history::TestRecord> tests;
  for (auto& t : store.tests(*m, "")) {
    if (t.plane == plane_name(ev.plane)) tests.push_back(std::move(t));
  }
  if (tests.empty()) {
    page.trend_note = fmt::format("not shown: the history holds no test of machine {} in plane {}",
                                  *m, plane_name(ev.plane));
    return;
  }
  page.trend_svg =
      history::history_svg(fmt::format("{}, plane {}", *m, plane_name(ev.plane)), tests, {});
  page.trend_note = fmt::format("{} test(s) of this machine, {} to {}", tests.size(),
                                tests.front().tested_at, tests.back().tested_at);
}

// The limits of a file: NAME=VALUE items as --limits takes them, one or more a line (commas
// between), '#' starts a comment; a byte-order mark, CRLF or CR line ends and blanks are
// allowed. A ParseError names the file and line of a bad item, of a
// quantity given twice, or a file with no limit at all (a check against nothing is no check).
history::Limits read_limits_file(const std::string& path) {
  using L = history::Limits;
  static constexpr std::pair<const char*, std::optional<double> L::*> kFields[] = {
      {"H", &L::h_mm},
      {"G", &L::g_mm},
      {"F", &L::f_mm},
      {"backlash", &L::backlash_mm},
      {"squareness", &L::squareness_urad}};
  // As common editors write it: a UTF-8 byte-order mark, CRLF or CR line ends, blank lines,
  // blanks and tabs anywhere.
  std::string text = read_file(path);
  if (text.starts_with("\xEF\xBB\xBF")) text.erase(0, 3);
  for (std::size_t p = text.find('\r'); p != std::string::npos; p = text.find('\r', p)) {
    if (p + 1 < text.size() && text[p + 1] == '\n') {
      text.erase(p, 1);
    } else {
      text[p] = '\n';
    }
  }
  L limits;
  std::size_t given_on[std::size(kFields)] = {};
  std::istringstream in(text);
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    line = line.substr(0, line.find('#'));
    std::string items;
    for (const char c : line) {
      if (c != ' ' && c != '\t' && c != '\v' && c != '\f') items += c;
    }
    if (items.empty()) continue;
    L one;
    try {
      one = history::parse_limits(items, "limit");
    } catch (const UsageError& e) {
      throw ParseError(path, n, e.what());
    }
    for (std::size_t k = 0; k < std::size(kFields); ++k) {
      const auto& [name, field] = kFields[k];
      if (!(one.*field)) continue;
      if (given_on[k]) {
        throw ParseError(path, n,
                         fmt::format("{} is given twice (also on line {})", name, given_on[k]));
      }
      given_on[k] = n;
      limits.*field = one.*field;
    }
  }
  if (limits.empty()) {
    throw ParseError(path, 0,
                     "no limit in the file: expected NAME=VALUE items (H, G, F, backlash in mm, "
                     "squareness in urad), e.g. H=0.015,G=0.020");
  }
  return limits;
}

// The limits that apply and where they come from, for the verdict.
std::pair<history::Limits, std::string> limits_of(const ReportRequest& request) {
  if (!request.limits.empty() && !request.limits_file.empty()) {
    throw UsageError("--limits and --limits-file: give the limits one way");
  }
  if (!request.limits.empty()) {
    return {history::parse_limits(request.limits, "--limits"),
            "given on the command line as " + request.limits};
  }
  if (!request.limits_file.empty()) {
    return {read_limits_file(request.limits_file), "the file " + request.limits_file};
  }
  return {};
}

// The verdict of one plane: H, G, F always, backlash and squareness when a limit is set for
// them, each of this test and (when there is one) of the before test.
void add_verdict(const ReportPage& page, const history::Limits& limits,
                 std::vector<VerdictLine>& lines) {
  auto record = [](const Evaluation& ev, const std::optional<DiagnosisChart>& d) {
    history::TestRecord r;
    add_measures(ev, r);
    if (d) {
      r.backlash_mm = d->backlash_mm;
      r.squareness_urad = d->squareness_urad;
    }
    return r;
  };
  const auto now = history::verdicts(record(*page.evaluation, page.diagnosis), limits);
  std::vector<history::Verdict> before;
  if (page.before) before = history::verdicts(record(*page.before, page.before_diagnosis), limits);
  for (std::size_t i = 0; i < now.size(); ++i) {
    const history::Verdict& v = now[i];
    const std::string q = v.quantity;
    if (!v.limit && (q == "backlash" || q == "squareness")) continue;
    VerdictLine l;
    l.plane = plane_name(page.evaluation->plane);
    l.quantity = q;
    l.unit = std::string_view(v.unit) == "urad" ? "µrad" : "µm";
    if (!before.empty()) {
      l.before = before[i].value;
      l.u_before = before[i].u;
    }
    l.now = v.value;
    l.u = v.u;
    l.limit = v.limit;
    using R = history::Verdict::Result;
    l.result = v.result == R::pass           ? VerdictLine::Result::pass
               : v.result == R::fail         ? VerdictLine::Result::fail
               : v.result == R::not_decided  ? VerdictLine::Result::not_decided
               : v.result == R::not_measured ? VerdictLine::Result::not_measured
                                             : VerdictLine::Result::no_limit;
    lines.push_back(std::move(l));
  }
}

bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  return a == b || std::filesystem::equivalent(a, b, ec);
}

std::string sha256_if_file(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec) ? sha256_of_file(path) : std::string();
}

// A diagnosis computed here, or the reason there is none.
void diagnose_here(const EvaluatedTrace& t, const ReportRequest& request,
                   std::optional<DiagnosisChart>& chart, std::string& note) {
  DiagnosisOptions options;
  options.evaluation = request.options;
  // A ball bar measures no absolute length along an axis (as circana diagnose).
  options.absolute_channels = !t.radial;
  try {
    chart = diagnosis_chart(diagnose(t.trace, t.evaluation, options));
  } catch (const Error& e) {
    // H, G and F stand without a diagnosis; the page says why there is none.
    note = e.what();
  }
}

}  // namespace

int run_report(const ReportRequest& request, std::ostream& out) {
  if (request.trace_paths.empty()) throw UsageError("missing the TRACE argument");
  if (request.output_path.empty()) throw UsageError("-o: the HTML file to write is required");
  const auto [limits, limits_source] = limits_of(request);
  HandOver handover;
  handover.limits_source = limits_source;
  handover.tested_by = request.tested_by;
  handover.accepted_by = request.accepted_by;
  std::vector<PlanChange> plan_changes;
  for (const std::string& path : request.changes_paths) {
    read_plan_changes(path, plan_changes, handover.advice);
    handover.changes_source += (handover.changes_source.empty() ? "" : ", ") + path;
  }
  NetChanges net = net_changes(plan_changes);
  handover.changes = std::move(net.settings);
  handover.wiring = std::move(net.wiring);
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
    DiagnosisChart chart =
        diagnosis_chart_from_document(read_diagnosis_document(path, "circana"), path);
    const std::size_t i = page_of(tests, chart.plane, path, "a diagnosis");
    // A diagnosis of the before trace (its source names that file) goes with the before test.
    const bool of_before = befores[i] && same_file(chart.source, befores[i]->evaluation.source);
    auto& slot = of_before ? pages[i].before_diagnosis : pages[i].diagnosis;
    if (slot) {
      throw DataError(path, 0,
                      fmt::format("a second diagnosis of plane {}{}", plane_name(chart.plane),
                                  of_before ? " of the before trace" : ""));
    }
    slot = std::move(chart);
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
    page.trace_sha256 = sha256_if_file(tests[i].evaluation.source);
    if (!page.diagnosis) diagnose_here(tests[i], request, page.diagnosis, page.diagnosis_note);
    if (befores[i]) {
      page.before_sha256 = sha256_if_file(befores[i]->evaluation.source);
      if (!page.before_diagnosis)
        diagnose_here(*befores[i], request, page.before_diagnosis, page.before_diagnosis_note);
    }
    add_verdict(page, limits, handover.verdict);
    if (store) {
      trend(page, *store, tests[i].evaluation);
    } else {
      page.trend_note = "not shown: no history of this machine's tests was given";
    }
  }
  write_file_atomic(request.output_path, html_report(pages, handover, request.plot));
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
