#include "circtest/analysis/html_report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>

#include "circtest/analysis/report.hpp"
#include "circtest/analysis/result_json.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/svg.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/core/version.hpp"

namespace circtest {

namespace {

// Screen: pages one below the other. Print: each plane's section is one A4 page; the
// figures have a bounded height so that a section never spills onto a second page.
constexpr const char* kStyle = R"(
@page { size: A4 portrait; margin: 10mm; }
* { box-sizing: border-box; }
body { font-family: "DejaVu Sans", Arial, sans-serif; font-size: 10pt; color: #111;
       margin: 0; background: #eee; }
section.plane { background: white; width: 190mm; margin: 8mm auto; padding: 6mm; }
h1 { font-size: 14pt; margin: 0 0 1mm 0; }
h2 { font-size: 10.5pt; margin: 3mm 0 1mm 0; }
p { margin: 0.5mm 0; }
.source { color: #444; word-break: break-all; }
table { border-collapse: collapse; width: 100%; }
th, td { border: 0.2mm solid #bbb; padding: 0.3mm 1.2mm; text-align: left; vertical-align: top; }
th { background: #f2f2f2; font-weight: 600; }
td.num, th.num { text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
table.header th { width: 20%; font-weight: normal; background: #f7f7f7; }
table.header td { width: 30%; }
table.header caption, table.results caption { text-align: left; font-weight: bold;
       padding: 1mm 0 0.5mm 0; }
.unrecorded { color: #a33; }
.change { color: #555; }
.figures { display: grid; grid-template-columns: 58% 42%; gap: 3mm; align-items: start;
       margin-top: 2mm; }
figure { margin: 0; }
figcaption { font-weight: bold; margin-bottom: 0.5mm; }
figure svg { width: 100%; height: auto; display: block; }
figure.plot svg { max-height: 150mm; }
figure.diagnosis svg { max-height: 60mm; }
figure.trend svg { max-height: 95mm; }
.note { color: #444; font-size: 90%; }
footer { color: #666; font-size: 80%; margin-top: 2mm; }
@media print {
  body { background: white; font-size: 7.5pt; }
  h1 { font-size: 11pt; }
  h2 { font-size: 8.5pt; }
  section.plane { width: auto; margin: 0; padding: 0; break-after: page;
                  break-inside: avoid; }
  section.plane:last-of-type { break-after: auto; }
  figure.plot svg { max-height: 125mm; }
  figure.trend svg { max-height: 80mm; }
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
    fmt::format_to(out, "<th class=\"num\">{} um</th>", h);
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

void header_table(std::string& s, const Evaluation& ev) {
  auto out = std::back_inserter(s);
  for (const ReportSection& section : header_sections(ev)) {
    fmt::format_to(out, "<table class=\"header\"><caption>{}</caption>\n",
                   xml_escape(section.title));
    for (std::size_t i = 0; i < section.items.size(); i += 2) {
      s += "<tr>";
      for (std::size_t k = i; k < i + 2; ++k) {
        if (k >= section.items.size()) {
          s += "<th></th><td></td>";
          continue;
        }
        const ReportItem& item = section.items[k];
        const bool unknown = item.value == "not recorded";
        fmt::format_to(out, "<th>{}</th><td{}>{}</td>", xml_escape(item.title),
                       unknown ? " class=\"unrecorded\"" : "", xml_escape(item.value));
      }
      s += "</tr>\n";
    }
    s += "</table>\n";
  }
}

// Horizontal bars, one per contribution, longest first.
std::string diagnosis_svg(const DiagnosisChart& d) {
  const double w = 390, label_w = 130, value_w = 110, row_h = 18, top = 6;
  const double bar_w = w - label_w - value_w;
  const double height =
      top + row_h * static_cast<double>(std::max<std::size_t>(1, d.contributions.size())) + 6;
  double gmax = 0;
  for (const auto& c : d.contributions) gmax = std::max(gmax, c.g_mm);
  std::string s;
  auto out = std::back_inserter(s);
  s += svg_open(w, height, 11, false);
  if (d.contributions.empty()) {
    fmt::format_to(out,
                   "<text x=\"4\" y=\"{}\">no error source found above its detection "
                   "threshold</text>\n",
                   top + 12);
  }
  double y = top;
  for (const auto& c : d.contributions) {
    const double len = gmax > 0 ? c.g_mm / gmax * bar_w : 0.0;
    fmt::format_to(out,
                   "<g class=\"contribution\"><text x=\"{:.1f}\" y=\"{:.1f}\" "
                   "text-anchor=\"end\">{}</text>"
                   "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" "
                   "fill=\"#1f5fbf\"/>"
                   "<text x=\"{:.1f}\" y=\"{:.1f}\" data-mm=\"{:.12g}\">{:.1f} um ({:.0f} %)</text>"
                   "</g>\n",
                   label_w - 4, y + 12.5, xml_escape(c.source), label_w, y + 3, std::max(len, 0.5),
                   row_h - 6, label_w + len + 4, y + 12.5, c.g_mm, c.g_mm * 1000.0, c.percent);
    y += row_h;
  }
  return s + "</svg>\n";
}

std::string machine_of(const Evaluation& ev) {
  const std::string* m = ev.conditions.find(meta_key::machine);
  return m && !m->empty() ? *m : std::string();
}

void page_html(std::string& s, const ReportPage& page, const PlotOptions& plot_options) {
  auto out = std::back_inserter(s);
  const Evaluation& ev = *page.evaluation;
  fmt::format_to(out, "<section class=\"plane\" data-plane=\"{}\">\n", plane_name(ev.plane));
  fmt::format_to(out, "<h1>ISO 230-4 / JIS B 6194 circular test, plane {}</h1>\n",
                 plane_name(ev.plane));
  fmt::format_to(out, "<p class=\"source\">Trace {}</p>\n", xml_escape(ev.source));
  if (page.before) {
    fmt::format_to(out, "<p class=\"source\">Before: {}</p>\n", xml_escape(page.before->source));
  }
  header_table(s, ev);

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

  s += "<div class=\"figures\">\n<figure class=\"plot\">";
  std::vector<PlotLayer> layers{{page.evaluation, page.trace, page.before ? "this test" : ""}};
  if (page.before) layers.push_back({page.before, page.before_trace, "before"});
  s += svg_plot(layers, plot_options);
  s += "</figure>\n<div>\n";
  s += "<figure class=\"diagnosis\"><figcaption>Diagnosis: contributions to G</figcaption>\n";
  if (page.diagnosis) {
    s += diagnosis_svg(*page.diagnosis);
    fmt::format_to(out,
                   "<p class=\"note\">Model G {:.1f} um, residual G {:.1f} um "
                   "(docs/diagnosis.md)</p>\n",
                   page.diagnosis->model_g_mm * 1000.0, page.diagnosis->residual_g_mm * 1000.0);
  } else {
    fmt::format_to(out, "<p class=\"note\">Not available: {}</p>\n",
                   xml_escape(page.diagnosis_note.empty() ? "no diagnosis" : page.diagnosis_note));
  }
  s += "</figure>\n<figure class=\"trend\"><figcaption>Trend of this machine</figcaption>\n";
  s += page.trend_svg;
  if (!page.trend_note.empty()) {
    fmt::format_to(out, "<p class=\"note\">{}</p>\n", xml_escape(page.trend_note));
  }
  s += "</figure>\n</div>\n</div>\n";
  for (const auto& n : ev.notes)
    fmt::format_to(out, "<p class=\"note\">Note: {}</p>\n", xml_escape(n));
  fmt::format_to(out, "<footer>{}; values in um, exact mm in the data-mm attributes</footer>\n",
                 xml_escape(version_line("circana report")));
  s += "</section>\n";
}

}  // namespace

DiagnosisChart diagnosis_chart(const Diagnosis& d) {
  return {d.source, d.plane, d.contributions, d.model_g_mm, d.residual_g_mm};
}

DiagnosisChart diagnosis_chart_from_json(const nlohmann::json& j, const std::string& path) {
  // A bar of the chart is at most as long as the page: a percentage beyond +-1000 or a G of
  // more than a metre is no diagnosis of a circular test.
  constexpr double kMaxPercent = 1000.0, kMaxGmm = 1000.0;
  const JsonReader<nlohmann::json> rd(path, "diagnosis JSON", kMaxGmm);
  const JsonReader<nlohmann::json> percent(path, "diagnosis JSON", kMaxPercent);
  namespace K = diagnosis_json::key;
  if (!j.is_object() || !j.contains(K::schema) || !j[K::schema].is_string() ||
      j[K::schema].get<std::string>() != diagnosis_json::kSchema) {
    throw ParseError(
        path, 0,
        fmt::format("expected a {} document (circana diagnose --json)", diagnosis_json::kSchema));
  }
  if (j.contains(K::version))
    diagnosis_json::check_version(rd.text(j, K::version, ""), path, "circana");
  DiagnosisChart d;
  if (j.contains(K::source)) d.source = rd.text(j, K::source, "");
  const auto plane = parse_plane(rd.text(j, K::plane, ""));
  if (!plane) rd.fail(K::plane, "XY, YZ or ZX");
  d.plane = *plane;
  const auto& contributions = rd.array(j, K::contributions, "");
  for (std::size_t i = 0; i < contributions.size(); ++i) {
    const std::string at = fmt::format("{}[{}]", K::contributions, i);
    const auto& c = contributions[i];
    Contribution k;
    k.source = rd.text(c, K::source, at);
    k.g_mm = rd.number(c, K::g_mm, at);
    k.percent = percent.number(c, K::percent, at);
    if (c.is_object() && c.contains(K::share_mm)) k.share_mm = rd.number(c, K::share_mm, at);
    d.contributions.push_back(std::move(k));
  }
  d.model_g_mm = rd.number(j, K::model_g_mm, "");
  d.residual_g_mm = rd.number(rd.at(j, K::residual, ""), K::g_mm, K::residual);
  return d;
}

std::string html_report(const std::vector<ReportPage>& pages, const PlotOptions& plot) {
  std::string machine;
  for (const auto& p : pages) {
    if (machine.empty()) machine = machine_of(*p.evaluation);
  }
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out,
                 "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
                 "<meta name=\"generator\" content=\"{}\">\n<title>Circular test report{}</title>\n"
                 "<style>{}</style>\n</head>\n<body>\n",
                 xml_escape(version_line("circana")),
                 machine.empty() ? std::string() : " - " + xml_escape(machine), kStyle);
  for (const auto& p : pages) page_html(s, p, plot);
  s += "</body>\n</html>\n";
  return s;
}

}  // namespace circtest
