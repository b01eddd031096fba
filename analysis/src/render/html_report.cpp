#include "circtest/analysis/html_report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <regex>
#include <set>

#include "circtest/analysis/report.hpp"
#include "circtest/analysis/result_json.hpp"
#include "circtest/analysis/uncertainty.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/svg.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/core/version.hpp"
#include "html_parts.hpp"

namespace circtest {

namespace html {

std::string units_shown(std::string text) {
  static const std::regex um(R"(\bum\b)"), urad(R"(\burad\b)"), deg_c(R"(\bdeg C\b)");
  text = std::regex_replace(text, um, "µm");
  text = std::regex_replace(text, urad, "µrad");
  return std::regex_replace(text, deg_c, "°C");
}

}  // namespace html

namespace {

using html::u_span;
using html::units_shown;

// Screen: pages one below the other, each as wide as A4. Print: the hand-over, each plane's
// evidence and the appendix each start an A4 portrait page; nothing is wider than the page
// (190 mm inside the margins), long words wrap, figures have a bounded height.
constexpr const char* kStyle = R"(
@page { size: A4 portrait; margin: 10mm; }
* { box-sizing: border-box; }
html, body { overflow-wrap: anywhere; }
body { font-family: "DejaVu Sans", Arial, sans-serif; font-size: 10pt; color: #111;
       margin: 0; background: #eee; }
section { background: white; width: 190mm; max-width: 100%; margin: 8mm auto; padding: 6mm; }
h1 { font-size: 14pt; margin: 0 0 1mm 0; }
h2 { font-size: 11pt; margin: 4mm 0 1mm 0; }
p { margin: 0.5mm 0; }
table { border-collapse: collapse; width: 100%; table-layout: fixed; }
th, td { border: 0.2mm solid #bbb; padding: 0.4mm 1.2mm; text-align: left; vertical-align: top; }
th { background: #f2f2f2; font-weight: 600; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
caption { text-align: left; font-weight: bold; padding: 1.5mm 0 0.5mm 0; }
table.facts th { width: 22%; font-weight: normal; background: #f7f7f7; }
table.conditions th { width: 20%; font-weight: normal; background: #f7f7f7; }
.banner { font-size: 16pt; font-weight: bold; padding: 2mm 3mm; margin: 3mm 0; border: 0.6mm solid; }
.banner.PASS { color: #14622b; border-color: #14622b; background: #eaf6ec; }
.banner.FAIL { color: #a11; border-color: #a11; background: #fbeaea; }
.banner.NONE { color: #444; border-color: #888; background: #f4f4f4; }
.banner.OPEN { color: #8a5a00; border-color: #8a5a00; background: #fdf3e1; }
.banner small { font-size: 9pt; font-weight: normal; display: block; }
td.result { font-weight: bold; }
td.PASS { color: #14622b; } td.FAIL { color: #a11; } td.NONE { color: #666; font-weight: normal; }
td.OPEN { color: #8a5a00; }
ul { margin: 0.5mm 0; padding-left: 5mm; }
.signatures { display: grid; grid-template-columns: 1fr 1fr; gap: 10mm; margin-top: 6mm; }
.signatures div p { border-bottom: 0.3mm solid #333; height: 9mm; margin: 0; padding-top: 3mm; }
.signatures div p span { color: #666; font-size: 85%; }
.grey, .note { color: #666; }
.note { font-size: 90%; }
table.results { table-layout: auto; }
.figures { display: grid; grid-template-columns: minmax(0, 1fr) minmax(0, 1fr); gap: 3mm; align-items: start;
           margin-top: 2mm; }
figure { margin: 0; min-width: 0; }
figcaption { font-weight: bold; margin-bottom: 0.5mm; }
figure svg { width: 100%; height: auto; display: block; }
figure.plot svg { max-height: 95mm; }
figure.trend svg { max-height: 60mm; }
ul.legend { list-style: none; padding: 0; font-size: 9pt; }
ul.legend li { margin: 0.3mm 0; }
ul.legend .swatch { display: inline-block; width: 4mm; height: 1.2mm; margin-right: 1.5mm;
                    vertical-align: middle; }
.bar { display: inline-block; height: 2mm; background: #1f5fbf; vertical-align: middle;
       margin-left: 1mm; }
.appendix td, .appendix th { font-size: 8pt; word-break: break-all; }
.appendix table.budget td, .appendix table.budget th { word-break: normal; }
.appendix .raw { columns: 2; column-gap: 6mm; font-size: 7.5pt; }
.appendix .raw p { break-inside: avoid; }
.appendix .raw b { font-weight: 600; }
footer { color: #666; font-size: 80%; margin-top: 2mm; }
@media print {
  body { background: white; font-size: 8pt; }
  h1 { font-size: 12pt; }
  h2 { font-size: 9.5pt; }
  section { width: auto; margin: 0; padding: 0; break-after: page; }
  section.plane { break-inside: avoid; }
  section:last-of-type { break-after: auto; }
  ul.legend { font-size: 6.5pt; }
  ul.legend li { margin: 0; }
  /* A plane page is one A4 page: before and after with four runs each, the diagnosis of both
     and a dozen conditions leave about 20 mm to spare. */
  section.plane .figures { grid-template-columns: 78mm minmax(0, 1fr); margin-top: 1mm; }
  section.plane th, section.plane td { padding: 0.2mm 1mm; }
  section.plane caption { padding: 1mm 0 0.3mm 0; }
  section.plane table.conditions { font-size: 7pt; }
  section.plane table.conditions th { width: 16%; }
  table.diagnosis tr:first-child th:first-child { width: 22%; }
  .appendix .raw { font-size: 6.5pt; }
}
)";

std::string um_text(double mm, bool sign) {
  return sign ? fmt::format("{:+.1f}", mm * 1000.0) : fmt::format("{:.1f}", mm * 1000.0);
}

// A number cell: the micrometres people read, and the exact millimetres in data-mm.
std::string value_cell(double mm, bool sign) {
  return fmt::format("<td class=\"num\"><span class=\"value\" data-mm=\"{:.12g}\">{}</span></td>",
                     mm, um_text(mm, sign));
}

struct Row {
  std::string key;  // matches a row of the before test
  std::vector<std::string> cells;
  std::vector<std::pair<std::optional<double>, bool>> values;  // mm, signed
};

// H per CCW/CW pair.
std::vector<Row> h_rows(const Evaluation& ev) {
  std::vector<Row> rows;
  for (const auto& h : ev.hysteresis) {
    const RunResult& ccw = ev.runs[h.run_ccw];
    const std::string feed = feed_text(ccw.feed_mm_per_min);
    rows.push_back(
        {ccw.label + "|" + feed,
         {"H<sub>" + xml_escape(ccw.label) + "</sub>", feed,
          fmt::format("{}/{}", h.run_ccw + 1, h.run_cw + 1), fmt::format("{:.1f}", h.at_angle_deg)},
         {{h.h_mm, false}}});
  }
  return rows;
}

// G and F per run.
std::vector<Row> run_rows(const Evaluation& ev) {
  std::vector<Row> rows;
  for (std::size_t i = 0; i < ev.runs.size(); ++i) {
    const RunResult& r = ev.runs[i];
    const std::string dir(direction_name(r.run.direction));
    const std::string feed = feed_text(r.feed_mm_per_min);
    rows.push_back({r.label + "|" + dir + "|" + feed,
                    {fmt::format("{}", i + 1), dir + " (" + xml_escape(r.label) + ")", feed},
                    {{r.g_mm(ev.g_method), false}, {r.f_max_mm, true}, {r.f_min_mm, true}}});
  }
  return rows;
}

// A table of `rows`; with `before`, each value is followed by the before test's value and
// the change (matched by label, direction and feed).
void results_table(std::string& s, const std::string& caption, const std::string& css_class,
                   const std::vector<std::string>& heads,
                   const std::vector<std::string>& value_heads, const std::vector<Row>& rows,
                   const std::vector<Row>* before) {
  auto out = std::back_inserter(s);
  fmt::format_to(out, "<table class=\"results {}\"><caption>{}</caption>\n<tr>", css_class,
                 caption);
  for (const auto& h : heads) fmt::format_to(out, "<th>{}</th>", h);
  for (const auto& h : value_heads) {
    fmt::format_to(out, "<th class=\"num\">{} µm</th>", h);
    if (before) fmt::format_to(out, "<th class=\"num\">before</th><th class=\"num\">change</th>");
  }
  s += "</tr>\n";
  std::vector<bool> used(before ? before->size() : 0, false);
  for (const Row& row : rows) {
    const Row* match = nullptr;
    if (before) {
      for (std::size_t k = 0; k < before->size(); ++k) {
        if (!used[k] && (*before)[k].key == row.key) {
          used[k] = true;
          match = &(*before)[k];
          break;
        }
      }
    }
    s += "<tr>";
    for (const auto& c : row.cells) fmt::format_to(out, "<td>{}</td>", c);
    for (std::size_t v = 0; v < row.values.size(); ++v) {
      const auto& [mm, sign] = row.values[v];
      s += mm ? value_cell(*mm, sign) : "<td class=\"num\">n/a</td>";
      if (!before) continue;
      const std::optional<double> old = match ? match->values[v].first : std::nullopt;
      if (old) {
        fmt::format_to(out, "<td class=\"num before\">{}</td>", um_text(*old, sign));
      } else {
        s += "<td class=\"num before\">&#8211;</td>";
      }
      if (old && mm) {
        fmt::format_to(out, "<td class=\"num change\">{}</td>", um_text(*mm - *old, true));
      } else {
        s += "<td class=\"num change\">&#8211;</td>";
      }
    }
    s += "</tr>\n";
  }
  s += "</table>\n";
}

// The clause 6 items that page 1 shows and the logger's items that belong to the appendix.
bool on_handover(const std::string& title) {
  static const std::set<std::string, std::less<>> kTitles = {
      "Date", "Machine", "Machine serial", "Location", "Operator", "Instrument"};
  return kTitles.count(title) > 0;
}
// The test program's settings a customer may ask about, with their titles; every other raw
// key of the trace (recorder, module, ring, files, hashes, periods) is an internal.
const char* program_title(std::string_view key) {
  static constexpr std::pair<const char*, const char*> kProgram[] = {
      {meta_key::arc_deg, "Arc (deg)"},
      {meta_key::start_deg, "Start angle (deg)"},
      {meta_key::lead_deg, "Lead-in and lead-out (deg)"},
      {meta_key::dwell_s, "Dwell where the direction reverses (s)"},
      {"motion_mode", "Path mode during the runs"},
      {"feed_override", "Feed override"},
      {"work_offset", "Work offset"},
      {"tool_length_offset", "Tool length offset"}};
  for (const auto& [k, title] : kProgram) {
    if (key == k) return title;
  }
  return nullptr;
}
constexpr const char* kNotRecorded = "not recorded";

// The clause 4.4 conditions that were recorded, two to a row; the items not recorded once,
// in grey, below.
void conditions_table(std::string& s, const Evaluation& ev) {
  auto out = std::back_inserter(s);
  std::vector<const ReportItem*> shown;
  std::vector<std::string> missing;
  const auto sections = header_sections(ev);
  for (const ReportSection& section : sections) {
    for (const ReportItem& item : section.items) {
      // Page 1 shows the clause 6 facts (and which of them were not recorded).
      if (html::internal_item(item) || on_handover(item.title)) continue;
      if (item.value == kNotRecorded) {
        missing.push_back(item.title);
      } else {
        shown.push_back(&item);
      }
    }
  }
  s += "<table class=\"conditions\"><caption>Conditions of the test (clause 4.4)</caption>\n";
  for (std::size_t i = 0; i < shown.size(); i += 2) {
    s += "<tr>";
    for (std::size_t k = i; k < i + 2; ++k) {
      if (k >= shown.size()) {
        s += "<th></th><td></td>";
        continue;
      }
      const char* program = shown[k]->raw ? program_title(shown[k]->title) : nullptr;
      fmt::format_to(out, "<th>{}</th><td>{}</td>",
                     xml_escape(units_shown(program ? program : shown[k]->title)),
                     xml_escape(units_shown(shown[k]->value)));
    }
    s += "</tr>\n";
  }
  s += "</table>\n";
  if (!missing.empty()) {
    fmt::format_to(out, "<p class=\"grey unrecorded\">Not recorded: {}</p>\n",
                   xml_escape(join(missing, ", ")));
  }
}

// "12.3 µm (45 %)" cells of one diagnosis; dashes when the source is not in it.
void contribution_cells(std::string& s, const DiagnosisChart* d, const std::string& source) {
  auto out = std::back_inserter(s);
  const Contribution* c = nullptr;
  if (d) {
    for (const auto& k : d->contributions) {
      if (k.source == source) c = &k;
    }
  }
  if (!c) {
    s += "<td class=\"num\">&#8211;</td><td class=\"num\">&#8211;</td>";
    return;
  }
  const double bar_mm = std::clamp(std::abs(c->percent), 0.0, 100.0) * 0.12;
  // Rounded to what is shown first, so that a tiny negative share reads 0.0, not -0.0.
  auto shown = [](double v, double step) { return std::round(v / step) * step + 0.0; };
  fmt::format_to(out,
                 "<td class=\"num\"><span data-mm=\"{:.12g}\">{:.1f}</span></td>"
                 "<td class=\"num\"><span data-mm=\"{:.12g}\">{:.1f}</span> ({:.0f} %)"
                 "<span class=\"bar\" style=\"width: {:.1f}mm\"></span></td>",
                 c->g_mm, shown(c->g_mm * 1000.0, 0.1), c->share_mm,
                 shown(c->share_mm * 1000.0, 0.1), shown(c->percent, 1.0), bar_mm);
}

// The residual's G of each diagnosis and its share of the measured G, that G with the U_G
// (k = 2) of its test's evaluation, as every G of the report.
void residual_row(std::string& s,
                  const std::vector<std::pair<const DiagnosisChart*, const Evaluation*>>& tests) {
  auto out = std::back_inserter(s);
  s += "<tr class=\"total residual\"><th>Residual G (not explained)</th>";
  for (const auto& [d, ev] : tests) {
    if (!d) {
      s += "<td class=\"num\" colspan=\"2\">&#8211;</td>";
      continue;
    }
    fmt::format_to(out,
                   "<td class=\"num\" colspan=\"2\"><span data-mm=\"{:.12g}\">{:.1f}</span> µm",
                   d->residual_g_mm, d->residual_g_mm * 1000.0);
    if (d->measured_g_mm && *d->measured_g_mm > 0 && ev) {
      fmt::format_to(out,
                     " ({:.0f} % of the measured G <span data-mm=\"{:.12g}\">{:.1f}</span> µm, "
                     "U = {} µm (k = 2))",
                     d->residual_g_mm / *d->measured_g_mm * 100.0, *d->measured_g_mm,
                     *d->measured_g_mm * 1000.0,
                     u_span(uncertainty_budget(*ev, ev->uncertainty_options).u_g_mm));
    }
    s += "</td>";
  }
  s += "</tr>\n";
}

// The diagnosis before and after side by side: each source's G alone and its share of the
// modelled G.
void diagnosis_table(std::string& s, const ReportPage& page) {
  auto out = std::back_inserter(s);
  const DiagnosisChart* after = page.diagnosis ? &*page.diagnosis : nullptr;
  const DiagnosisChart* before =
      page.before && page.before_diagnosis ? &*page.before_diagnosis : nullptr;
  const bool two = page.before != nullptr;
  s += "<table class=\"diagnosis\"><caption>Diagnosis: the error sources and their share of "
       "G</caption>\n<tr><th rowspan=\"2\">Source</th>";
  if (two) s += "<th colspan=\"2\">before</th>";
  fmt::format_to(out, "<th colspan=\"2\">{}</th></tr>\n<tr>",
                 two ? "after (this test)" : "this test");
  for (int k = 0; k < (two ? 2 : 1); ++k) {
    s += "<th class=\"num\">G alone µm</th><th class=\"num\">share of G µm (%)</th>";
  }
  s += "</tr>\n";
  std::vector<std::string> sources;
  for (const DiagnosisChart* d : {after, before}) {
    if (!d) continue;
    for (const auto& c : d->contributions) {
      if (std::find(sources.begin(), sources.end(), c.source) == sources.end())
        sources.push_back(c.source);
    }
  }
  for (const auto& source : sources) {
    fmt::format_to(out, "<tr class=\"contribution\"><td>{}</td>", xml_escape(source));
    if (two) contribution_cells(s, before, source);
    contribution_cells(s, after, source);
    s += "</tr>\n";
  }
  if (sources.empty() && (after || before)) {
    fmt::format_to(out,
                   "<tr><td colspan=\"{}\">no error source found above its detection "
                   "threshold</td></tr>\n",
                   two ? 5 : 3);
  }
  auto totals = [&](const char* title, double DiagnosisChart::*mm) {
    fmt::format_to(out, "<tr class=\"total\"><th>{}</th>", title);
    for (const DiagnosisChart* d : two ? std::vector{before, after} : std::vector{after}) {
      if (d) {
        fmt::format_to(
            out, "<td class=\"num\" colspan=\"2\"><span data-mm=\"{:.12g}\">{:.1f}</span> µm</td>",
            d->*mm, d->*mm * 1000.0);
      } else {
        s += "<td class=\"num\" colspan=\"2\">&#8211;</td>";
      }
    }
    s += "</tr>\n";
  };
  totals("Modelled G", &DiagnosisChart::model_g_mm);
  residual_row(s,
               two ? std::vector{std::pair{before, page.before}, std::pair{after, page.evaluation}}
                   : std::vector{std::pair{after, page.evaluation}});
  s += "</table>\n";
  for (const auto& [d, note, which] :
       {std::tuple{before, &page.before_diagnosis_note, "before"},
        std::tuple{after, &page.diagnosis_note, two ? "after" : "this test"}}) {
    if (d || (std::string_view(which) == "before" && !two)) continue;
    fmt::format_to(out, "<p class=\"note\">No diagnosis of {}: {}</p>\n", which,
                   xml_escape(note->empty() ? "none given" : *note));
  }
}

std::string machine_of(const Evaluation& ev) {
  const std::string* m = ev.conditions.find(meta_key::machine);
  return m && !m->empty() ? *m : std::string();
}

// A condition of the test, or "".
std::string condition(const Evaluation& ev, const char* key) {
  const std::string* v = ev.conditions.find(key);
  return v ? *v : std::string();
}

// When the test ran: the recorder's start time, else the program's date; "2026-11-26 16:31
// UTC" when it is an ISO 8601 UTC time, else as recorded.
std::string test_date(const Evaluation& ev) {
  std::string t = condition(ev, meta_key::start_time);
  if (t.empty()) t = condition(ev, meta_key::date);
  static const std::regex iso(R"((\d{4}-\d{2}-\d{2})T(\d{2}:\d{2})(:\d{2}(\.\d+)?)?Z)");
  std::smatch m;
  if (std::regex_match(t, m, iso)) return m[1].str() + " " + m[2].str() + " UTC";
  return t;
}

void legend_list(std::string& s, const std::vector<std::pair<std::string, std::string>>& legend) {
  auto out = std::back_inserter(s);
  s += "<ul class=\"legend\">\n";
  for (const auto& [text, colour] : legend) {
    fmt::format_to(out, "<li><span class=\"swatch\" style=\"background: {}\"></span>{}</li>\n",
                   colour == "black" ? "transparent" : colour, xml_escape(units_shown(text)));
  }
  s += "</ul>\n";
}

void page_html(std::string& s, const ReportPage& page, const PlotOptions& plot_options) {
  auto out = std::back_inserter(s);
  const Evaluation& ev = *page.evaluation;
  fmt::format_to(out, "<section class=\"plane\" data-plane=\"{}\">\n", plane_name(ev.plane));
  fmt::format_to(out, "<h1>Plane {}: the measurement{}</h1>\n", plane_name(ev.plane),
                 page.before ? ", before and after" : "");

  const auto hb = page.before ? h_rows(*page.before) : std::vector<Row>{};
  const auto rb = page.before ? run_rows(*page.before) : std::vector<Row>{};
  if (ev.hysteresis.empty()) {
    s += "<p>Circular hysteresis H: not available (no CCW/CW pair)</p>\n";
  } else {
    results_table(s, "a) Circular hysteresis H", "hysteresis", {"H", "Feed", "Runs", "at deg"},
                  {"H"}, h_rows(ev), page.before ? &hb : nullptr);
  }
  results_table(
      s,
      fmt::format("b) Circular deviation G ({}), c) radial deviation F (centre: {})",
                  g_method_name(ev.g_method),
                  ev.runs.empty() ? std::string_view("-")
                                  : f_centre_method_name(ev.runs.front().f_centre_method)),
      "runs", {"Run", "Direction", "Feed"}, {"G", "F<sub>max</sub>", "F<sub>min</sub>"},
      run_rows(ev), page.before ? &rb : nullptr);
  const UncertaintyBudget budget = uncertainty_budget(ev, ev.uncertainty_options);
  std::string before_u;
  if (page.before) {
    const UncertaintyBudget b = uncertainty_budget(*page.before, page.before->uncertainty_options);
    before_u = fmt::format("; of each value of the before test: H {} µm, G {} µm, F {} µm",
                           u_span(b.u_h_mm), u_span(b.u_g_mm), u_span(b.u_f_mm));
  }
  fmt::format_to(out,
                 "<p class=\"uncertainty\">Expanded uncertainty U (k = 2) of each value of this "
                 "test: H {} µm, G {} µm, F {} µm{} (the budgets are in the appendix).</p>\n",
                 u_span(budget.u_h_mm), u_span(budget.u_g_mm), u_span(budget.u_f_mm), before_u);

  s += "<div class=\"figures\">\n<figure class=\"plot\">";
  std::vector<PlotLayer> layers{{page.evaluation, page.trace, page.before ? "after" : ""}};
  if (page.before) layers.push_back({page.before, page.before_trace, "before"});
  std::vector<std::pair<std::string, std::string>> legend;
  PlotOptions options = plot_options;
  options.legend_out = &legend;
  s += svg_plot(layers, options);
  s += "</figure>\n<div>\n";
  legend_list(s, legend);
  if (!page.trend_svg.empty()) {
    s += "<figure class=\"trend\"><figcaption>Trend of this machine</figcaption>\n";
    s += page.trend_svg;
    s += "</figure>\n";
  }
  if (!page.trend_note.empty()) {
    fmt::format_to(out, "<p class=\"note\">Trend: {}</p>\n", xml_escape(page.trend_note));
  }
  s += "</div>\n</div>\n";
  diagnosis_table(s, page);
  conditions_table(s, ev);
  for (const auto& n : ev.notes)
    fmt::format_to(out, "<p class=\"note\">Note: {}</p>\n", xml_escape(units_shown(n)));
  s += "<footer>Values in µm; the exact millimetres are in the data-mm attributes</footer>\n";
  s += "</section>\n";
}

// The instrument as recorded, else what the trace says of it: the file it was imported from,
// or the kind of instrument the program was made for (circgen --instrument).
std::string instrument_of(const Evaluation& ev) {
  std::string i = condition(ev, meta_key::instrument);
  if (!i.empty()) return i;
  if (const auto from = condition(ev, meta_key::imported_from); !from.empty())
    return "imported from " + from;
  if (const auto profile = condition(ev, "instrument_profile"); !profile.empty())
    return profile + " (the test program's instrument profile)";
  return {};
}

// The facts of the hand-over: the machine, the test, who tested it and with what.
void facts_table(std::string& s, const std::vector<ReportPage>& pages, const HandOver& h) {
  auto out = std::back_inserter(s);
  const Evaluation& ev = *pages.front().evaluation;
  auto or_blank = [](const std::string& v) { return v.empty() ? std::string(kNotRecorded) : v; };
  std::string machine = or_blank(machine_of(ev));
  if (const auto serial = condition(ev, meta_key::machine_serial); !serial.empty())
    machine += ", serial " + serial;
  std::string date = or_blank(test_date(ev));
  if (pages.front().before) {
    const std::string d0 = test_date(*pages.front().before);
    if (!d0.empty()) date += " (before: " + d0 + ")";
  }
  std::string planes, feeds, diameters;
  for (const auto& p : pages) {
    const Evaluation& e = *p.evaluation;
    planes += (planes.empty() ? "" : ", ") + std::string(plane_name(e.plane));
    std::vector<std::string> f;
    for (const auto& r : e.runs) {
      const std::string t = feed_text(r.feed_mm_per_min);
      if (std::find(f.begin(), f.end(), t) == f.end()) f.push_back(t);
    }
    feeds += fmt::format("{}{}: {}", feeds.empty() ? "" : "; ", plane_name(e.plane), join(f, ", "));
    const std::string d = e.nominal_radius_mm ? fmt::format("{:g} mm", 2 * *e.nominal_radius_mm)
                                              : std::string(kNotRecorded);
    if (diameters.find(d) == std::string::npos) diameters += (diameters.empty() ? "" : ", ") + d;
  }
  const std::string tested_by =
      h.tested_by.empty() ? condition(ev, meta_key::operator_name) : h.tested_by;
  const std::pair<const char*, std::string> rows[] = {
      {"Machine", machine},
      {"Location", or_blank(condition(ev, meta_key::location))},
      {"Date of the test", date},
      {"Tested by", or_blank(tested_by)},
      {"Instrument", or_blank(instrument_of(ev))},
      {"Plane(s)", planes},
      {"Feed(s)", feeds},
      {"Diameter", diameters},
  };
  s += "<table class=\"facts\">\n";
  for (const auto& [title, value] : rows) {
    fmt::format_to(out, "<tr><th>{}</th><td{}>{}</td></tr>\n", title,
                   value == kNotRecorded ? " class=\"grey\"" : "", xml_escape(value));
  }
  s += "</table>\n";
}

void summary_html(std::string& s, const std::vector<ReportPage>& pages, const HandOver& h) {
  auto out = std::back_inserter(s);
  bool with_before = false;
  for (const auto& p : pages) with_before |= p.before != nullptr;
  s += "<section class=\"summary\">\n<h1>Circular test of the machine: hand-over report</h1>\n"
       "<p class=\"note\">ISO 230-4 / JIS B 6194 circular test.</p>\n";
  facts_table(s, pages, h);
  html::verdict_table(s, h, with_before);
  if (with_before || !h.changes_source.empty()) {
    s += "<h2>Changed between the tests</h2>\n";
    if (h.changes_source.empty()) {
      s += "<p class=\"grey\">Not stated: no record of the changes was given.</p>\n";
    } else if (h.changes.empty()) {
      s += "<p>No setting: the plan corrects nothing.</p>\n";
    } else {
      s += "<ul class=\"changes\">\n";
      for (const auto& c : h.changes)
        fmt::format_to(out, "<li>{}</li>\n", xml_escape(units_shown(c)));
      s += "</ul>\n";
    }
    if (!h.wiring.empty()) {
      std::vector<std::string> w;
      for (const auto& x : h.wiring) w.push_back(units_shown(x));
      fmt::format_to(out, "<p class=\"note wiring\">To put them to work: {}.</p>\n",
                     xml_escape(join(w, "; ")));
    }
    if (!h.advice.empty()) {
      s += "<p>Not changed, advised:</p>\n<ul class=\"advice\">\n";
      for (const auto& a : h.advice)
        fmt::format_to(out, "<li>{}</li>\n", xml_escape(units_shown(a)));
      s += "</ul>\n";
    }
  }
  s += "<div class=\"signatures\">\n";
  for (const auto& [role, name] :
       {std::pair{"Tested by", h.tested_by.empty()
                                   ? condition(*pages.front().evaluation, meta_key::operator_name)
                                   : h.tested_by},
        std::pair{"Accepted by", h.accepted_by}}) {
    fmt::format_to(out,
                   "<div class=\"signature\"><h2>{}</h2><p><span>Name:</span> {}</p>"
                   "<p><span>Signature:</span></p><p><span>Date:</span></p></div>\n",
                   role, xml_escape(name));
  }
  s += "</div>\n</section>\n";
}

}  // namespace

bool html::internal_item(const ReportItem& item) {
  static const std::set<std::string, std::less<>> kTitles = {"Channels evaluated", "Data capture"};
  if (item.raw) return program_title(item.title) == nullptr;
  return kTitles.count(item.title) > 0;
}

DiagnosisChart diagnosis_chart(const Diagnosis& d) {
  DiagnosisChart c{d.source, d.plane, d.contributions, d.model_g_mm, d.residual_g_mm, {}, {}, {}};
  for (const Estimate& b : d.backlash_mm) {
    if (b.value) c.backlash_mm = std::max(c.backlash_mm.value_or(0.0), std::abs(*b.value));
  }
  c.squareness_urad = d.squareness_urad.value;
  c.measured_g_mm = d.measured_g_mm;
  return c;
}

DiagnosisChart diagnosis_chart_from_document(const DiagnosisDocument& document,
                                             const std::string& path) {
  if (document.planes.size() != 1) {
    throw ParseError(path, 0,
                     fmt::format("\"{}\": a test set ({} planes): give the diagnosis of each "
                                 "plane (circana diagnose --plane P --json)",
                                 diagnosis_json::key::plane, document.planes.size()));
  }
  if (!document.absent.empty()) {
    throw ParseError(
        path, 0,
        fmt::format("diagnosis JSON '{}': expected a value (missing)", document.absent.front()));
  }
  const Diagnosis& d = document.planes.front();
  // A bar of the chart is at most as long as the page: a percentage beyond +-1000 or a G of
  // more than a metre is no diagnosis of a circular test.
  constexpr double kMaxPercent = 1000.0, kMaxGmm = 1000.0;
  const auto bounded = [&path](double v, double max, const std::string& key) {
    if (std::abs(v) <= max) return;
    throw DataError(path, 0,
                    fmt::format("diagnosis JSON '{}': {:g} is not a usable number (at most {:g} "
                                "in size)",
                                key, v, max));
  };
  namespace K = diagnosis_json::key;
  for (std::size_t i = 0; i < d.contributions.size(); ++i) {
    const std::string at = fmt::format("{}[{}].", K::contributions, i);
    bounded(d.contributions[i].g_mm, kMaxGmm, at + K::g_mm);
    bounded(d.contributions[i].share_mm, kMaxGmm, at + K::share_mm);
    bounded(d.contributions[i].percent, kMaxPercent, at + K::percent);
  }
  bounded(d.model_g_mm, kMaxGmm, K::model_g_mm);
  bounded(d.residual_g_mm, kMaxGmm, std::string(K::residual) + "." + K::g_mm);
  for (const Estimate& b : d.backlash_mm) {
    if (b.value) bounded(*b.value, kMaxGmm, K::backlash_mm);
  }
  return diagnosis_chart(d);
}

std::string html_report(const std::vector<ReportPage>& pages, const HandOver& handover,
                        const PlotOptions& plot) {
  if (pages.empty()) throw Error(ExitCode::usage, "a report needs at least one test");
  const std::string machine = machine_of(*pages.front().evaluation);
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out,
                 "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
                 "<meta name=\"generator\" content=\"{}\">\n<title>Circular test report{}</title>\n"
                 "<style>{}</style>\n</head>\n<body>\n",
                 xml_escape(version_line("circana")),
                 machine.empty() ? std::string() : " - " + xml_escape(machine), kStyle);
  summary_html(s, pages, handover);
  for (const auto& p : pages) page_html(s, p, plot);
  html::appendix_html(s, pages, handover);
  s += "</body>\n</html>\n";
  return s;
}

}  // namespace circtest
