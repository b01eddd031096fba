#pragma once
// The pieces of circana report's HTML that more than one of its files write
// (html_report.cpp: the hand-over and the plane pages; html_verdict.cpp: page 1's verdict;
// html_appendix.cpp: the appendix).
#include <string>
#include <vector>

#include "circtest/analysis/html_report.hpp"
#include "circtest/analysis/report.hpp"

namespace circtest::html {

// Micrometres, microradians and degrees Celsius as written, not "um", "urad", "deg C" (the
// library's ASCII words).
std::string units_shown(std::string text);
// A trace's item that is an internal (the recorder's, the files'), shown in the appendix only.
bool internal_item(const ReportItem& item);
// A micrometre amount of U (k = 2) with the exact millimetres in data-mm, as read:
// "<span class="u" data-mm="0.0014">1.4</span>".
std::string u_span(double mm);
// Page 1's verdict: the overall banner and a line per plane and quantity with its U, the
// limit and the result, and the decision rule when limits were agreed.
void verdict_table(std::string& s, const HandOver& h, bool with_before);
// The appendix: versions, where the limits and changes came from, each test's files and
// hashes and its uncertainty budget.
void appendix_html(std::string& s, const std::vector<ReportPage>& pages, const HandOver& h);

}  // namespace circtest::html
