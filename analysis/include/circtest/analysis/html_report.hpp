#pragma once
// `circana report`: one self-contained HTML file a service engineer hands over (inline CSS
// and SVG, no script, nothing fetched): per plane the clause 6 header, the H/G/F table, the
// polar plot (with a before test overlaid), the diagnosis as a bar chart and the machine's
// trend. A print stylesheet puts each plane on one A4 page. docs/html-report.md.
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
};
DiagnosisChart diagnosis_chart(const Diagnosis& diagnosis);
// From a circtest.diagnosis/1 document (circana diagnose --json); ParseError naming `path`
// when it is another document or its contributions are malformed.
DiagnosisChart diagnosis_chart_from_json(const nlohmann::json& document, const std::string& path);

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
};

std::string html_report(const std::vector<ReportPage>& pages, const PlotOptions& plot = {});

}  // namespace circtest
