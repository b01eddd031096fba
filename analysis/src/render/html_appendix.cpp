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

// The tests whose budgets have the same contributions (names, distributions, sources and
// sensitivities) and profile: one table, a column of standard uncertainties per test.
struct BudgetGroup {
  std::vector<std::string> tests;  // "XY", "XY before"
  std::vector<UncertaintyBudget> budgets;
};

bool same_shape(const UncertaintyBudget& a, const UncertaintyBudget& b) {
  if (a.profile != b.profile || a.profile_note != b.profile_note || a.k != b.k ||
      a.contributions.size() != b.contributions.size())
    return false;
  for (std::size_t i = 0; i < a.contributions.size(); ++i) {
    const auto &x = a.contributions[i], &y = b.contributions[i];
    if (x.name != y.name || x.distribution != y.distribution || x.source != y.source ||
        x.c_g != y.c_g || x.c_h != y.c_h || x.c_f != y.c_f)
      return false;
  }
  return true;
}

// A micrometre cell of a number in mm, with the exact millimetres in data-mm.
std::string um_cell(double mm, const char* css = "num") {
  return fmt::format("<td class=\"{}\"><span data-mm=\"{:.12g}\">{:.3f}</span></td>", css, mm,
                     mm * 1000.0);
}

// One group's table: each contribution with its distribution, sensitivities and source, and
// its standard uncertainty in each test; then U (k = 2) of G, H and F of each test.
void group_table(std::string& s, const BudgetGroup& g) {
  auto out = std::back_inserter(s);
  const UncertaintyBudget& first = g.budgets.front();
  fmt::format_to(out, "<p class=\"profile\">{}: instrument profile {}: {}</p>\n",
                 xml_escape(join(g.tests, ", ")),
                 xml_escape(std::string(instrument_profile_name(first.profile))),
                 xml_escape(units_shown(first.profile_note)));
  s += "<table class=\"budget\">\n<tr><th rowspan=\"2\" style=\"width: 26%\">Contribution</th>"
       "<th rowspan=\"2\" style=\"width: 12%\">distribution</th><th rowspan=\"2\" "
       "class=\"num\">c<sub>G</sub></th><th rowspan=\"2\" class=\"num\">c<sub>H</sub></th><th "
       "rowspan=\"2\" class=\"num\">c<sub>F</sub></th><th rowspan=\"2\" style=\"width: "
       "17%\">source</th>";
  fmt::format_to(out, "<th colspan=\"{}\" class=\"num\">standard uncertainty u, µm</th></tr>\n<tr>",
                 g.tests.size());
  for (const auto& t : g.tests) fmt::format_to(out, "<th class=\"num\">{}</th>", xml_escape(t));
  s += "</tr>\n";
  for (std::size_t i = 0; i < first.contributions.size(); ++i) {
    const UncertaintyContribution& c = first.contributions[i];
    fmt::format_to(out,
                   "<tr class=\"contribution\"><td>{}</td><td>{}</td><td class=\"num\">{:.3g}</td>"
                   "<td class=\"num\">{:.3g}</td><td class=\"num\">{:.3g}</td><td>{}</td>",
                   xml_escape(units_shown(c.name)), distribution_name(c.distribution), c.c_g, c.c_h,
                   c.c_f, xml_escape(c.source));
    for (const auto& b : g.budgets) s += um_cell(b.contributions[i].standard_mm());
    s += "</tr>\n";
  }
  for (const auto& [name, field] : {std::pair{"G", &UncertaintyBudget::u_g_mm},
                                    {"H", &UncertaintyBudget::u_h_mm},
                                    {"F", &UncertaintyBudget::u_f_mm}}) {
    fmt::format_to(out,
                   "<tr class=\"expanded\" data-quantity=\"{0}\"><th colspan=\"6\">Expanded "
                   "uncertainty U<sub>{0}</sub> (k = {1:g}), µm</th>",
                   name, first.k);
    for (const auto& b : g.budgets) s += um_cell(b.*field, "num u");
    s += "</tr>\n";
  }
  s += "</table>\n";
}

// The budgets of the report's tests: one table per group of tests alike.
void budgets_html(std::string& s, const std::vector<ReportPage>& pages) {
  s += "<section class=\"appendix budgets\">\n<h1>Appendix: the uncertainty of H, G and F</h1>\n"
       "<p>Each contribution's standard uncertainty u (a stated standard uncertainty, or the "
       "half-width a of a range: u = a/&#8730;3) enters G, H and F with its sensitivity c; the "
       "combined standard uncertainty is the root sum of squares of c&#160;u, and U = k u with "
       "k = 2 (ISO/TR 230-9, GUM); a bias (an effect of at most the stated size that is not "
       "corrected: the noise's widening of the zone, a measured drift) is added to U as it is "
       "(c&#160;b). Verdicts follow ISO 14253-1: pass when value + U &#8804; "
       "limit, fail when value &#8722; U &gt; limit, otherwise not decided.</p>\n";
  std::vector<BudgetGroup> groups;
  for (const auto& p : pages) {
    for (const auto& [ev, suffix] : {std::pair{p.evaluation, ""}, std::pair{p.before, " before"}}) {
      if (!ev) continue;
      UncertaintyBudget b = uncertainty_budget(*ev, ev->uncertainty_options);
      const std::string name = std::string(plane_name(ev->plane)) + suffix;
      auto g = std::find_if(groups.begin(), groups.end(), [&b](const BudgetGroup& x) {
        return same_shape(x.budgets.front(), b);
      });
      if (g == groups.end()) {
        groups.push_back({{name}, {std::move(b)}});
      } else {
        g->tests.push_back(name);
        g->budgets.push_back(std::move(b));
      }
    }
  }
  for (const auto& g : groups) group_table(s, g);
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
