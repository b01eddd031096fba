// `circana history`: the trend of H, G, F (each with its stored U, k = 2), backlash and
// squareness of one machine, and the check of its latest test against limits by ISO 14253-1
// (the value alone where no U is stored).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <iterator>

#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/svg.hpp"
#include "circtest/history/history.hpp"

namespace circtest::history {

namespace {

using ojson = nlohmann::ordered_json;

struct Quantity {
  const char* name;  // as in --limits
  const char* unit;
  double scale;  // to the display unit
  std::optional<double> TestRecord::*value;
  std::optional<double> TestRecord::*u;  // its U (k = 2); null: stated without one
  std::optional<double> Limits::*limit;
  double max_limit;  // the largest limit that means anything for a circular test
  const char* limit_words;
};

// Limits and values of H, G, F and backlash in mm (shown in um), squareness in urad. A limit
// of 10 mm or 10,000 urad (0.57 deg) is far beyond any machine worth testing.
constexpr const char* kMmLimitWords = "a limit in mm above 0 and at most 10";
constexpr Quantity kQuantities[] = {
    {"H", "um", 1000.0, &TestRecord::h_mm, &TestRecord::u_h_mm, &Limits::h_mm, 10.0, kMmLimitWords},
    {"G", "um", 1000.0, &TestRecord::g_mm, &TestRecord::u_g_mm, &Limits::g_mm, 10.0, kMmLimitWords},
    {"F", "um", 1000.0, &TestRecord::f_mm, &TestRecord::u_f_mm, &Limits::f_mm, 10.0, kMmLimitWords},
    {"backlash", "um", 1000.0, &TestRecord::backlash_mm, nullptr, &Limits::backlash_mm, 10.0,
     kMmLimitWords},
    {"squareness", "urad", 1.0, &TestRecord::squareness_urad, nullptr, &Limits::squareness_urad,
     10000.0, "a limit in urad above 0 and at most 10000"},
};

// A value in its display unit: "-" when not measured, "n/a" when not a finite number (a row
// stored by another program), never "inf".
std::string cell(const std::optional<double>& v, double scale) {
  if (!v) return "-";
  const double shown = *v * scale;
  return std::isfinite(shown) ? fmt::format("{:.1f}", shown) : std::string("n/a");
}
// H, G or F with its U: "12.0 +-1.4", or "12.0 (no U)" for a test stored without U.
std::string cell_with_u(const std::optional<double>& v, const std::optional<double>& u) {
  if (!v) return "-";
  return cell(v, 1000.0) + (u ? " +-" + cell(u, 1000.0) : std::string(" (no U)"));
}

std::optional<double> u_of(const TestRecord& t, const Quantity& q) {
  return q.u ? t.*(q.u) : std::nullopt;
}

// |VALUE| (with U when stated) against LIMIT, all in the stored unit: ISO 14253-1 with U, the
// value alone without; no limit: no_limit; no value: not_measured. A value that is not a
// finite number never passes.
Verdict::Result judge(const std::optional<double>& value, const std::optional<double>& u,
                      const std::optional<double>& limit) {
  using R = Verdict::Result;
  if (!limit) return R::no_limit;
  if (!value) return R::not_measured;
  const double v = std::abs(*value);
  if (!std::isfinite(v)) return R::fail;
  if (!u) return v <= *limit ? R::pass : R::fail;
  if (v + *u <= *limit) return R::pass;
  if (v - *u > *limit) return R::fail;
  return R::not_decided;
}

// The test's check in a word: FAIL when a quantity fails or was not measured, NOT DECIDED
// when one is within the uncertainty of its limit, else ok.
const char* check_word(const std::vector<Verdict>& vs) {
  bool undecided = false;
  for (const Verdict& v : vs) {
    if (v.result == Verdict::Result::fail || v.result == Verdict::Result::not_measured)
      return "FAIL";
    undecided |= v.result == Verdict::Result::not_decided;
  }
  return undecided ? "NOT DECIDED" : "ok";
}

// The quantities with a limit judged on the value alone for want of a stored U.
bool judged_without_u(const std::vector<Verdict>& vs) {
  return std::any_of(vs.begin(), vs.end(), [](const Verdict& v) {
    const std::string_view q = v.quantity;
    return v.limit && v.value && !v.u && (q == "H" || q == "G" || q == "F");
  });
}

// Seconds since the epoch of an ISO 8601 date or date-time (UTC), when it parses.
std::optional<double> epoch_s(const std::string& iso) {
  tm t{};
  const char* end = strptime(iso.c_str(), "%Y-%m-%dT%H:%M:%S", &t);
  if (!end) {
    t = {};
    end = strptime(iso.c_str(), "%Y-%m-%d", &t);
  }
  if (!end) return std::nullopt;
  return static_cast<double>(timegm(&t));
}

}  // namespace

Limits parse_limits(const std::string& text, std::string_view setting) {
  Limits l;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const auto comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    const auto eq = item.find('=');
    const Quantity* q = nullptr;
    if (eq != std::string::npos) {
      for (const auto& k : kQuantities) {
        if (item.substr(0, eq) == k.name) q = &k;
      }
    }
    if (!q) {
      throw UsageError(
          fmt::format("{}: expected NAME=VALUE,... with NAME one of H, G, F, backlash (mm), "
                      "squareness (urad), got '{}'",
                      setting, item));
    }
    const NumberRange range{0.0, q->max_limit, true, q->limit_words};
    l.*(q->limit) =
        parse_option_number(fmt::format("{} {}", setting, q->name), item.substr(eq + 1), range);
    pos = comma + 1;
  }
  return l;
}

std::vector<Verdict> verdicts(const TestRecord& t, const Limits& limits) {
  std::vector<Verdict> out;
  for (const auto& q : kQuantities) {
    Verdict v{q.name, q.unit, std::nullopt, std::nullopt, Verdict::Result::no_limit, std::nullopt};
    const std::optional<double> u = u_of(t, q);
    if (const auto& value = t.*(q.value)) v.value = std::abs(*value) * q.scale;
    if (u) v.u = *u * q.scale;
    if (const auto& lim = limits.*(q.limit)) v.limit = *lim * q.scale;
    // Judged in the stored unit, as circana analyze judges: a value + U exactly at the limit
    // passes here as there. A check that cannot be made does not pass.
    v.result = judge(t.*(q.value), u, limits.*(q.limit));
    out.push_back(v);
  }
  return out;
}

const char* decision_words(Verdict::Result r) noexcept {
  switch (r) {
    case Verdict::Result::pass:
      return "pass";
    case Verdict::Result::fail:
      return "fail";
    case Verdict::Result::not_decided:
      return "not decided: within the uncertainty";
    case Verdict::Result::not_measured:
      return "not measured";
    case Verdict::Result::no_limit:
      break;
  }
  return "no limit";
}

std::vector<std::string> breaches(const TestRecord& t, const Limits& limits) {
  std::vector<std::string> out;
  for (const Verdict& v : verdicts(t, limits)) {
    const std::string q = v.quantity;
    auto num = [](double x) { return std::isfinite(x) ? fmt::format("{:.1f}", x) : "n/a"; };
    if (v.result == Verdict::Result::not_measured) {
      out.push_back(
          fmt::format("{} not measured{}", q,
                      q == "backlash" || q == "squareness" ? " (no diagnosis stored)" : ""));
    } else if (v.result == Verdict::Result::fail && v.u && std::isfinite(*v.value)) {
      out.push_back(
          fmt::format("{} {} - U {} > {:.1f} {}", q, num(*v.value), num(*v.u), *v.limit, v.unit));
    } else if (v.result == Verdict::Result::fail) {
      out.push_back(fmt::format(
          "{} {} > {:.1f} {}{}", q, num(*v.value), *v.limit, v.unit,
          !v.u && (q == "H" || q == "G" || q == "F") ? " (no U stored: value alone)" : ""));
    } else if (v.result == Verdict::Result::not_decided) {
      out.push_back(fmt::format("{} {} + U {} > {:.1f} {}: not decided, within the uncertainty", q,
                                num(*v.value), num(*v.u), *v.limit, v.unit));
    }
  }
  return out;
}

std::string history_text(const std::string& machine, const std::vector<TestRecord>& tests,
                         const Limits& limits) {
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out, "History of machine {}: {} test(s); H, G, F with U (k = 2)\n", machine,
                 tests.size());
  fmt::format_to(out, "{:<25} {:>6} {:>5} {:>12} {:>12} {:>12} {:>11} {:>11}  {}\n", "tested at",
                 "id", "plane", "H um", "G um", "F um", "backlash um", "square urad",
                 limits.empty() ? "trace" : "check");
  std::vector<std::int64_t> without_u;
  for (const auto& t : tests) {
    std::string last;
    if (limits.empty()) {
      last = t.trace_path;
    } else {
      const auto vs = verdicts(t, limits);
      last = check_word(vs);
      if (judged_without_u(vs)) without_u.push_back(t.id);
      const auto b = breaches(t, limits);
      if (!b.empty()) {
        last += ":";
        for (const auto& x : b) last += " " + x + ";";
        last.pop_back();
      }
    }
    fmt::format_to(out, "{:<25} {:>6} {:>5} {:>12} {:>12} {:>12} {:>11} {:>11}  {}\n", t.tested_at,
                   t.id, t.plane, cell_with_u(t.h_mm, t.u_h_mm), cell_with_u(t.g_mm, t.u_g_mm),
                   cell_with_u(t.f_mm, t.u_f_mm), cell(t.backlash_mm, 1000),
                   cell(t.squareness_urad, 1), last);
  }
  if (limits.empty() || tests.empty()) return s;
  fmt::format_to(out, "Decision rule: {}\n", kDecisionRule);
  if (limits.backlash_mm || limits.squareness_urad || !without_u.empty()) {
    fmt::format_to(out, "Judged on the value alone ({}):", kValueAloneRule);
    if (limits.backlash_mm || limits.squareness_urad)
      s += " backlash and squareness (the diagnosis states them without U);";
    if (!without_u.empty()) {
      std::vector<std::string> ids;
      for (const auto id : without_u) ids.push_back(std::to_string(id));
      fmt::format_to(out, " H, G, F of test(s) {} (stored without U);", join(ids, ", "));
    }
    s.back() = '\n';
  }
  const auto vs = verdicts(tests.back(), limits);
  const std::string word = check_word(vs);
  const auto b = breaches(tests.back(), limits);
  if (b.empty()) {
    fmt::format_to(out, "Latest test ({}): within the limits\n", tests.back().tested_at);
  } else {
    fmt::format_to(out, "Latest test ({}): {}:", tests.back().tested_at,
                   word == "FAIL" ? "OUT OF TOLERANCE" : "NOT DECIDED (within the uncertainty)");
    for (const auto& x : b) fmt::format_to(out, " {};", x);
    s.back() = '\n';
  }
  return s;
}

ojson history_json(const std::string& machine, const std::vector<TestRecord>& tests,
                   const Limits& limits) {
  auto opt = [](const std::optional<double>& v) { return v ? ojson(*v) : ojson(nullptr); };
  ojson j;
  j["schema"] = "circtest.history/1";
  j["units"] = "mm";
  j["machine"] = machine;
  ojson lim = ojson::object();
  for (const auto& q : kQuantities) {
    if (limits.*(q.limit)) lim[q.name] = *(limits.*(q.limit));
  }
  j["limits"] = lim;
  if (!limits.empty()) j["decision_rule"] = kDecisionRule;
  ojson arr = ojson::array();
  for (const auto& t : tests) {
    ojson measures = ojson::array();
    for (const auto& m : t.measures) {
      measures.push_back({{"kind", m.kind},
                          {"label", m.label},
                          {"direction", m.direction},
                          {"feed_mm_per_min", opt(m.feed_mm_per_min)},
                          {"value", m.value_mm},
                          {"U", opt(m.u_mm)}});
    }
    ojson test = {{"id", t.id},
                  {"tested_at", t.tested_at},
                  {"stored_at", t.stored_at},
                  {"plane", t.plane},
                  {"channels", t.channels},
                  {"trace_path", t.trace_path},
                  {"trace_sha256", t.trace_sha256.empty() ? ojson(nullptr) : ojson(t.trace_sha256)},
                  {"H", opt(t.h_mm)},
                  {"G", opt(t.g_mm)},
                  {"F", opt(t.f_mm)},
                  {"U_H", opt(t.u_h_mm)},
                  {"U_G", opt(t.u_g_mm)},
                  {"U_F", opt(t.u_f_mm)},
                  {"backlash", opt(t.backlash_mm)},
                  {"squareness_urad", opt(t.squareness_urad)},
                  {"measures", measures},
                  {"conditions", parse_ordered_json_text(json_text(t.conditions), t.trace_path)}};
    if (!limits.empty()) {
      // Each limit's verdict, in the limits' units (mm; squareness urad).
      ojson items = ojson::array();
      for (const auto& q : kQuantities) {
        if (!(limits.*(q.limit))) continue;
        const std::optional<double> u = u_of(t, q);
        const auto& value = t.*(q.value);
        items.push_back({{"quantity", q.name},
                         {"value", value ? ojson(std::abs(*value)) : ojson(nullptr)},
                         {"U", opt(u)},
                         {"limit", *(limits.*(q.limit))},
                         {"decision", decision_words(judge(value, u, limits.*(q.limit)))},
                         {"rule", u ? kDecisionRule : kValueAloneRule}});
      }
      test["verdicts"] = items;
      test["check"] = check_word(verdicts(t, limits));
      test["breaches"] = breaches(t, limits);
    }
    arr.push_back(std::move(test));
  }
  j["tests"] = arr;
  if (!limits.empty() && !tests.empty()) j["pass"] = breaches(tests.back(), limits).empty();
  return j;
}

std::string history_svg(const std::string& machine, const std::vector<TestRecord>& tests,
                        const Limits& limits, int width_px) {
  const double w = width_px, panel_h = 120, top = 40, left = 70, right = 20, gap = 30;
  const double n_panels = static_cast<double>(std::size(kQuantities));
  const double height = top + n_panels * (panel_h + gap) + 20;
  // x: time when every date parses, else the order of the tests.
  std::vector<double> xs;
  bool by_time = true;
  for (const auto& t : tests) {
    const auto e = epoch_s(t.tested_at);
    if (!e) by_time = false;
    xs.push_back(e.value_or(0));
  }
  if (!by_time) {
    for (std::size_t i = 0; i < xs.size(); ++i) xs[i] = static_cast<double>(i);
  }
  double x0 = xs.empty() ? 0 : *std::min_element(xs.begin(), xs.end());
  double x1 = xs.empty() ? 1 : *std::max_element(xs.begin(), xs.end());
  if (x1 <= x0) x1 = x0 + 1;
  auto px = [&](double x) { return left + (x - x0) / (x1 - x0) * (w - left - right); };

  std::string s;
  auto out = std::back_inserter(s);
  s += svg_open(w, height, 11, true);
  fmt::format_to(
      out,
      "<text x=\"10\" y=\"20\" font-size=\"14\" font-weight=\"bold\">Trend of machine "
      "{}: {} test(s){}</text>\n",
      xml_escape(machine), tests.size(),
      tests.empty() ? ""
                    : xml_escape(", " + tests.front().tested_at + " to " + tests.back().tested_at));
  double y0 = top;
  for (const auto& q : kQuantities) {
    const auto& lim = limits.*(q.limit);
    double vmax = lim ? *lim * q.scale : 0.0;
    for (const auto& t : tests) {
      const auto& v = t.*(q.value);
      const double u = u_of(t, q).value_or(0.0);
      if (v && std::isfinite((std::abs(*v) + u) * q.scale))
        vmax = std::max(vmax, (std::abs(*v) + u) * q.scale);
    }
    if (!(vmax > 0)) vmax = 1;
    vmax *= 1.15;
    auto py = [&](double v) { return y0 + panel_h - v / vmax * panel_h; };
    fmt::format_to(out,
                   "<g class=\"panel\" data-quantity=\"{0}\">\n<rect x=\"{1}\" y=\"{2}\" "
                   "width=\"{3}\" height=\"{4}\" fill=\"none\" stroke=\"#999\"/>\n"
                   "<text x=\"{1}\" y=\"{5}\" font-weight=\"bold\">{0} ({6})</text>\n"
                   "<text x=\"{7}\" y=\"{8}\" text-anchor=\"end\">{9:.1f}</text>\n"
                   "<text x=\"{7}\" y=\"{10}\" text-anchor=\"end\">0</text>\n",
                   q.name, left, y0, w - left - right, panel_h, y0 - 4, q.unit, left - 4, y0 + 10,
                   vmax, y0 + panel_h);
    if (lim) {
      fmt::format_to(out,
                     "<line class=\"limit\" x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" "
                     "y2=\"{:.1f}\" stroke=\"#c0392b\" stroke-dasharray=\"6,3\"/>\n"
                     "<text x=\"{:.1f}\" y=\"{:.1f}\" fill=\"#c0392b\" text-anchor=\"end\">limit "
                     "{:.1f}</text>\n",
                     left, py(*lim * q.scale), w - right, py(*lim * q.scale), w - right - 2,
                     py(*lim * q.scale) - 3, *lim * q.scale);
    }
    std::string pts;
    for (std::size_t i = 0; i < tests.size(); ++i) {
      const auto& v = tests[i].*(q.value);
      if (!v || !std::isfinite(*v * q.scale)) continue;
      const double vx = px(xs[i]), vy = py(std::abs(*v) * q.scale);
      svg_add_point(pts, vx, vy);
      const std::optional<double> u = u_of(tests[i], q);
      const Verdict::Result result = judge(v, u, lim);
      if (u && std::isfinite(*u * q.scale)) {
        // U (k = 2) as a bar from value - U to value + U.
        fmt::format_to(out,
                       "<line class=\"u-bar\" x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" "
                       "y2=\"{2:.1f}\" stroke=\"#1f5fbf\" stroke-width=\"1\"/>\n",
                       vx, py(std::max(0.0, std::abs(*v) - *u) * q.scale),
                       py((std::abs(*v) + *u) * q.scale));
      }
      fmt::format_to(out,
                     "<circle class=\"point\" cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3\" fill=\"{}\">"
                     "<title>{} {}: {:.2f} {}{}{}</title></circle>\n",
                     vx, vy,
                     result == Verdict::Result::fail          ? "#c0392b"
                     : result == Verdict::Result::not_decided ? "#d68910"
                                                              : "#1f5fbf",
                     xml_escape(tests[i].tested_at), q.name, std::abs(*v) * q.scale, q.unit,
                     u     ? fmt::format(", U = {:.2f} {}", *u * q.scale, q.unit)
                     : q.u ? std::string(", U not known (stored without it)")
                           : std::string(),
                     lim ? std::string(": ") + decision_words(result) : std::string());
    }
    if (!pts.empty()) {
      fmt::format_to(out,
                     "<polyline points=\"{}\" fill=\"none\" stroke=\"#1f5fbf\" "
                     "stroke-width=\"1.2\"/>\n",
                     pts);
    } else {
      fmt::format_to(out, "<text x=\"{:.1f}\" y=\"{:.1f}\" fill=\"#777\">not measured</text>\n",
                     left + 10, y0 + panel_h / 2);
    }
    s += "</g>\n";
    y0 += panel_h + gap;
  }
  return s + "</svg>\n";
}

}  // namespace circtest::history
