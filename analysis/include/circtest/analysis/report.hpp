#pragma once
// The clause 6 text report, and the `circana fit` report. The evaluation's JSON is in
// result_json.hpp.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "circtest/analysis/circle_fit.hpp"
#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/result_json.hpp"

namespace circtest {

std::string text_report(const Evaluation& evaluation);
// The uncertainty budget as the text report's table, its U and each contribution's note.
std::string uncertainty_text(const UncertaintyBudget& budget);
// The decisions against --limits as text (the rule first) and as the `verdicts` object.
std::string limits_text(const std::vector<LimitDecision>& decisions);
nlohmann::ordered_json limits_json(const std::vector<LimitDecision>& decisions);
// The verdicts of an evaluation against `limits` appended to `text` and put into `doc` (an
// object) as `verdicts`, each when given; false unless every limit passes.
bool add_limit_verdicts(const Evaluation& evaluation, const ResultLimits& limits, std::string* text,
                        nlohmann::ordered_json* doc);

// The clause 6 (test) and clause 4.4 (conditions) items of a report in order, each with its
// value or "not recorded": the text and the HTML report list the same items.
struct ReportItem {
  std::string title;
  std::string value;
  bool raw = false;  // a condition of the trace with no line of its own: title is its key
};
struct ReportSection {
  std::string title;
  std::vector<ReportItem> items;
};
std::vector<ReportSection> header_sections(const Evaluation& evaluation);

struct FitReport {
  std::string source;
  std::size_t points = 0;
  Circle lsc;
  MinimumZone mzc;
  ContactCircle mcc;
  std::optional<ContactCircle> mic;  // none when the points do not surround a centre
  std::string mic_note;
};
FitReport fit_all(const std::string& source, std::span<const double> a, std::span<const double> b);
nlohmann::ordered_json to_json(const FitReport& report);
std::string text_report(const FitReport& report);

// "x, y (x: table X, grid encoder; ...)": the channels evaluated, with their descriptions.
std::string channels_text(const Evaluation& evaluation);
// "1000 mm/min", or "feed ?" when the trace had no time column.
std::string feed_text(const std::optional<double>& feed_mm_per_min);

}  // namespace circtest
