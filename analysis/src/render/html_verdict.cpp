// circana report's verdict on page 1: each quantity of each plane against the agreed
// acceptance limits, by ISO 14253-1 with its U (k = 2) when it has one, and the overall verdict.
#include <fmt/format.h>

#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "circtest/core/strings.hpp"
#include "circtest/core/svg.hpp"
#include "html_parts.hpp"

namespace circtest::html {

namespace {

const char* result_word(VerdictLine::Result r) {
  switch (r) {
    case VerdictLine::Result::pass:
      return "PASS";
    case VerdictLine::Result::fail:
      return "FAIL";
    case VerdictLine::Result::not_decided:
      return "not decided: within the uncertainty";
    case VerdictLine::Result::not_measured:
      return "FAIL (not measured)";
    case VerdictLine::Result::no_limit:
      break;
  }
  return "no limit set";
}

std::string amount_cell(const std::optional<double>& v, const std::string& unit) {
  return v ? fmt::format("<td class=\"num\">{:.1f} {}</td>", *v, unit)
           : std::string("<td class=\"num\">&#8211;</td>");
}

// The U of a value: the exact millimetres as in the value cells of the plane pages; a dash
// without a value or for a quantity the diagnosis states without U (backlash, squareness);
// "not known" for an H, G or F without one (a test stored before U was kept).
std::string u_cell(const std::optional<double>& u, bool has_value, const std::string& quantity,
                   const std::string& unit, const char* css) {
  if (u) return fmt::format("<td class=\"{}\">{} {}</td>", css, u_span(*u / 1000.0), unit);
  const bool has_u = quantity == "H" || quantity == "G" || quantity == "F";
  return fmt::format("<td class=\"{}\">{}</td>", css, has_value && has_u ? "not known" : "&#8211;");
}

// The overall verdict: FAIL when any quantity with a limit fails or was not measured, OPEN
// when none fails but one is within the uncertainty of its limit (not shown to conform),
// PASS when every one with a limit passes, NONE when no limit applies.
std::string overall(const std::vector<VerdictLine>& lines) {
  bool any_limit = false, undecided = false;
  for (const auto& l : lines) {
    if (l.result == VerdictLine::Result::fail || l.result == VerdictLine::Result::not_measured)
      return "FAIL";
    undecided |= l.result == VerdictLine::Result::not_decided;
    any_limit |= l.result == VerdictLine::Result::pass;
  }
  return undecided ? "OPEN" : any_limit ? "PASS" : "NONE";
}

}  // namespace

// The limits as agreed, e.g. "H 4.0 µm, G 50.0 µm, F 0.1 µm" (one plane's lines name them).
std::string limits_words(const std::vector<VerdictLine>& lines) {
  std::vector<std::string> words;
  for (const auto& l : lines) {
    if (l.plane != lines.front().plane || !l.limit) continue;
    words.push_back(fmt::format("{} {:.1f} {}", l.quantity, *l.limit, l.unit));
  }
  return join(words, ", ");
}

void verdict_table(std::string& s, const HandOver& h, bool with_before) {
  auto out = std::back_inserter(s);
  const std::string all = overall(h.verdict);
  const bool judged = !h.limits_source.empty();
  fmt::format_to(
      out, "<div class=\"banner {}\" data-verdict=\"{}\">Verdict: {}<small>{}</small></div>\n", all,
      all,
      all == "PASS"   ? "PASS"
      : all == "FAIL" ? "FAIL"
      : all == "OPEN" ? "not decided: within the uncertainty"
                      : "no limit set",
      xml_escape(!judged ? "No acceptance limits were agreed: the values are reported, not judged."
                         : "Against the agreed acceptance limits (" + limits_words(h.verdict) +
                               "), each value with its expanded uncertainty U (k = 2)."));
  fmt::format_to(
      out, "<table class=\"verdict\"><caption>{}</caption>\n<tr><th>Plane</th><th>Quantity</th>",
      judged ? "Results against the agreed acceptance limits" : "Results");
  if (with_before) s += "<th class=\"num\">before</th><th class=\"num\">U (k = 2)</th>";
  s += "<th class=\"num\">this test</th><th class=\"num\">U (k = 2)</th><th "
       "class=\"num\">limit</th><th>result</th></tr>\n";
  bool value_alone = false;
  for (const auto& l : h.verdict) {
    const std::string word = result_word(l.result);
    const char* css = l.result == VerdictLine::Result::pass          ? "PASS"
                      : l.result == VerdictLine::Result::no_limit    ? "NONE"
                      : l.result == VerdictLine::Result::not_decided ? "OPEN"
                                                                     : "FAIL";
    fmt::format_to(
        out,
        "<tr class=\"verdict-line\" data-plane=\"{}\" data-quantity=\"{}\"><td>{}</td><td>{}</td>",
        xml_escape(l.plane), xml_escape(l.quantity), xml_escape(l.plane), xml_escape(l.quantity));
    if (with_before) {
      s += amount_cell(l.before, l.unit);
      s += u_cell(l.u_before, l.before.has_value(), l.quantity, l.unit, "num u before");
    }
    s += amount_cell(l.now, l.unit);
    s += u_cell(l.u, l.now.has_value(), l.quantity, l.unit, "num u");
    value_alone |= !l.u && l.limit.has_value() && l.now.has_value();
    s += amount_cell(l.limit, l.unit);
    fmt::format_to(out, "<td class=\"result {}\">{}</td></tr>\n", css, word);
  }
  s += "</table>\n<p class=\"note\">H: the largest circular hysteresis, G: the largest circular "
       "deviation, F: the largest radial deviation |F<sub>max</sub>|, |F<sub>min</sub>| of the "
       "plane's runs (ISO 230-4); U: the expanded uncertainty (k = 2) of each, its budget in "
       "the appendix.</p>\n";
  if (judged) {
    s += "<p class=\"note rule\">Decision rule (ISO 14253-1): pass when value + U &#8804; limit, "
         "fail when value &#8722; U &gt; limit, otherwise not decided: within the "
         "uncertainty, which has not been shown to conform.";
    if (value_alone) s += " Without U (backlash, squareness): the value alone against the limit.";
    s += "</p>\n";
  }
}

}  // namespace circtest::html
