#pragma once
// `circana report`: one self-contained HTML file a service engineer hands over (inline CSS
// and SVG, no script, nothing fetched). Page 1 is the hand-over: the machine, the test, the
// verdict per plane and quantity against the limits, what was changed between before and
// after, the signatures. Then a page of evidence per plane: H/G/F, the polar plot (a before
// test overlaid), the diagnosis before and after, the recorded conditions, the trend. Last an
// appendix of internals (files, hashes, logger settings, versions) and the uncertainty budget
// of each test. A print stylesheet puts
// each part on its own A4 portrait page. docs/html-report.md.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/plot.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

// What the report shows of a diagnosis: its ranked contributions to G.
struct DiagnosisChart {
  std::string source;
  Plane plane = Plane::XY;
  std::vector<Contribution> contributions;  // ranked, largest first
  double model_g_mm = 0.0;
  double residual_g_mm = 0.0;
  std::optional<double> backlash_mm;      // the larger |backlash| of the plane's axes
  std::optional<double> squareness_urad;  // as measured (signed)
  // The largest G of the runs (least squares centre): the residual's share is of it.
  std::optional<double> measured_g_mm;
};
DiagnosisChart diagnosis_chart(const Diagnosis& diagnosis);
// From a plane's diagnosis document (read_diagnosis_document: circana diagnose --json);
// ParseError naming `path` for a test set's, DataError for a G or percentage no page holds.
DiagnosisChart diagnosis_chart_from_document(const DiagnosisDocument& document,
                                             const std::string& path);

// One plane's page.
struct ReportPage {
  const Evaluation* evaluation = nullptr;  // required
  const Trace* trace = nullptr;            // the trace it was made from (for the plot)
  const Evaluation* before = nullptr;      // an earlier test of the same plane, or null
  const Trace* before_trace = nullptr;
  std::optional<DiagnosisChart> diagnosis;
  std::string diagnosis_note;  // why there is none, when there is none
  std::string trend_svg;       // the machine's trend (history), inline SVG; may be empty
  std::string trend_note;      // what the trend shows, or why there is none
  std::optional<DiagnosisChart> before_diagnosis;  // of the before test
  std::string before_diagnosis_note;
  std::string trace_sha256;   // of the trace file; empty when not at hand
  std::string before_sha256;  // of the before trace file
};

// One line of the verdict: a quantity of a plane against its limit, by ISO 14253-1 when it
// has U (H, G, F), else by the value alone (backlash, squareness).
struct VerdictLine {
  enum class Result { pass, fail, not_decided, no_limit, not_measured };
  std::string plane;
  std::string quantity;                      // "H", "G", "F", "backlash", "squareness"
  std::string unit;                          // "µm", "µrad"
  std::optional<double> before, now, limit;  // |value| and limit in the unit
  std::optional<double> u;                   // U (k = 2) of `now` in the unit; empty: none
  std::optional<double> u_before;            // U (k = 2) of `before` in the unit; empty: none
  Result result = Result::no_limit;
};

// What the first page holds beyond the tests.
struct HandOver {
  std::vector<VerdictLine> verdict;
  std::string limits_source;           // where the limits come from (for the appendix); empty: none
  std::vector<std::string> changes;    // plain words, from circcomp plan --json
  std::vector<std::string> wiring;     // what makes LinuxCNC use them (HAL files, kinematics)
  std::vector<std::string> advice;     // what the plan could not change
  std::string changes_source;          // the plan document; empty: none given
  std::string tested_by, accepted_by;  // empty: a blank line to write the name on
};

std::string html_report(const std::vector<ReportPage>& pages, const HandOver& handover = {},
                        const PlotOptions& plot = {});

}  // namespace circtest
