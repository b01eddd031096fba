// circana report's appendix: the uncertainty budget of each test (ISO/TR 230-9, GUM) and the
// internals of each trace (files, hashes, the logger's and generator's raw items, versions).
#include <fmt/format.h>

#include <algorithm>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "circtest/analysis/uncertainty.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/svg.hpp"
#include "circtest/core/version.hpp"
#include "html_parts.hpp"

namespace circtest::html {

namespace {

// The budget of one evaluation as a table: each contribution with its stated value, its
// distribution, its standard uncertainty, its sensitivities and where it came from; then U.
std::string budget_table(const UncertaintyBudget& b) {
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out, "<p class=\"profile\">Instrument profile {}: {}</p>\n",
                 xml_escape(std::string(instrument_profile_name(b.profile))),
                 xml_escape(units_shown(b.profile_note)));
  s += "<table class=\"budget\">\n<tr><th style=\"width: 30%\">Contribution</th>"
       "<th class=\"num\">value µm</th><th>distribution</th><th class=\"num\">standard u µm</th>"
       "<th class=\"num\">c<sub>G</sub></th><th class=\"num\">c<sub>H</sub></th>"
       "<th class=\"num\">c<sub>F</sub></th><th>source</th></tr>\n";
  for (const UncertaintyContribution& c : b.contributions) {
    fmt::format_to(out,
                   "<tr class=\"contribution\"><td>{}</td><td class=\"num\"><span "
                   "data-mm=\"{:.12g}\">{:.3f}</span></td><td>{}</td><td class=\"num\"><span "
                   "data-mm=\"{:.12g}\">{:.3f}</span></td><td class=\"num\">{:.3g}</td>"
                   "<td class=\"num\">{:.3g}</td><td class=\"num\">{:.3g}</td><td>{}</td></tr>\n",
                   xml_escape(units_shown(c.name)), c.value_mm, c.value_mm * 1000.0,
                   distribution_name(c.distribution), c.standard_mm(), c.standard_mm() * 1000.0,
                   c.c_g, c.c_h, c.c_f, xml_escape(c.source));
  }
  fmt::format_to(out,
                 "<tr class=\"expanded\"><th colspan=\"8\">Expanded uncertainty (k = {:g}): "
                 "U<sub>G</sub> = {} µm, U<sub>H</sub> = {} µm, U<sub>F</sub> = {} µm</th></tr>\n"
                 "</table>\n",
                 b.k, u_span(b.u_g_mm), u_span(b.u_h_mm), u_span(b.u_f_mm));
  return s;
}

// The budgets of the report's tests, each distinct one once with the tests it holds for.
void budgets_html(std::string& s, const std::vector<ReportPage>& pages) {
  auto out = std::back_inserter(s);
  s += "<section class=\"appendix budgets\">\n<h1>Appendix: the uncertainty of H, G and F</h1>\n"
       "<p>Each contribution's standard uncertainty u (a stated value, or a half-width a of a "
       "range: u = a/&#8730;3) enters G, H and F with its sensitivity c; the combined standard "
       "uncertainty is the root sum of squares of c&#160;u, and U = k u with k = 2 (ISO/TR "
       "230-9, GUM). Verdicts follow ISO 14253-1: pass when value + U &#8804; limit, fail when "
       "value &#8722; U &gt; limit, otherwise not decided.</p>\n";
  std::vector<std::pair<std::string, std::vector<std::string>>> tables;  // table, its tests
  for (const auto& p : pages) {
    for (const auto& [ev, what] :
         {std::pair{p.evaluation, p.before ? "after (this test)" : "this test"},
          std::pair{p.before, "before"}}) {
      if (!ev) continue;
      const std::string table = budget_table(uncertainty_budget(*ev, ev->uncertainty_options));
      const std::string name = fmt::format("plane {}, {}", plane_name(ev->plane), what);
      auto same = std::find_if(tables.begin(), tables.end(),
                               [&table](const auto& t) { return t.first == table; });
      if (same == tables.end()) {
        tables.push_back({table, {name}});
      } else {
        same->second.push_back(name);
      }
    }
  }
  for (const auto& [table, names] : tables) {
    fmt::format_to(out, "<h2>Budget of {}</h2>\n{}", xml_escape(join(names, "; ")), table);
  }
  s += "</section>\n";
}

// The internals of one trace: its file, hash and the logger's and generator's raw items.
void internals_of(std::string& s, const char* what, const Evaluation& ev,
                  const std::string& sha256) {
  auto out = std::back_inserter(s);
  fmt::format_to(
      out,
      "<h2>{}, plane {}</h2>\n<table>\n<tr><th style=\"width: 18%\">File</th><td>{}</td></tr>\n"
      "<tr><th>SHA-256</th><td>{}</td></tr>\n",
      what, plane_name(ev.plane), xml_escape(ev.source), sha256.empty() ? "not at hand" : sha256);
  s += "</table>\n<div class=\"raw\">\n";
  for (const ReportSection& section : header_sections(ev)) {
    for (const ReportItem& item : section.items) {
      if (!internal_item(item)) continue;
      fmt::format_to(out, "<p><b>{}</b>: {}</p>\n", xml_escape(item.title),
                     xml_escape(units_shown(item.value)));
    }
  }
  s += "</div>\n";
}

}  // namespace

std::string u_span(double mm) {
  return fmt::format("<span class=\"u\" data-mm=\"{:.12g}\">{:.1f}</span>", mm, mm * 1000.0);
}

void appendix_html(std::string& s, const std::vector<ReportPage>& pages, const HandOver& h) {
  budgets_html(s, pages);
  auto out = std::back_inserter(s);
  s += "<section class=\"appendix\">\n<h1>Appendix: for the service engineer</h1>\n";
  fmt::format_to(out, "<p>{}; acceptance limits: {}; changes: {}</p>\n",
                 xml_escape(version_line("circana report")),
                 xml_escape(h.limits_source.empty() ? "none" : h.limits_source),
                 xml_escape(h.changes_source.empty() ? "none" : h.changes_source));
  for (const auto& p : pages) {
    internals_of(s, p.before ? "After (this test)" : "This test", *p.evaluation, p.trace_sha256);
    if (p.before) internals_of(s, "Before", *p.before, p.before_sha256);
  }
  s += "</section>\n";
}

}  // namespace circtest::html
