#include "circtest/analysis/report.hpp"

#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/trace_keys.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iterator>
#include <set>

namespace circtest {

namespace {

using json = nlohmann::ordered_json;

// Micrometres for the text report: the unit people read circular-test results in.
std::string signed_um(double mm) {
  return fmt::format("{:+.1f} um", mm * 1000.0);
}
std::string um_abs(double mm) {
  return fmt::format("{:.1f} um", mm * 1000.0);
}

}  // namespace

std::string channels_text(const Evaluation& ev) {
  std::string s = fmt::format("{}, {}", ev.channel_a, ev.channel_b);
  std::string described;
  for (const std::string* name : {&ev.channel_a, &ev.channel_b}) {
    if (const std::string* d = ev.conditions.find(meta_key::channel_prefix + *name)) {
      described += fmt::format("{}{}: {}", described.empty() ? "" : "; ", *name, *d);
    }
  }
  if (!described.empty()) s += " (" + described + ")";
  return s;
}

std::string feed_text(const std::optional<double>& feed_mm_per_min) {
  return feed_mm_per_min ? fmt::format("{:.0f} mm/min", *feed_mm_per_min) : std::string("feed ?");
}

std::vector<ReportSection> header_sections(const Evaluation& ev) {
  std::vector<ReportSection> sections;
  constexpr const char* kNone = "not recorded";
  auto meta = [&ev](const char* key) -> std::string {
    const std::string* v = ev.conditions.find(key);
    return v && !v->empty() ? *v : std::string(kNone);
  };
  auto line = [&sections](std::string title, std::string value) {
    sections.back().items.push_back({std::move(title), std::move(value)});
  };
  // Clause 6: every item is listed, "not recorded" when neither the trace nor an option
  // gave it, so a missing condition is visible instead of silently absent.
  sections.push_back({"Test (clause 6)", {}});
  {
    std::string date = meta(meta_key::date);
    if (date == kNone) date = meta(meta_key::start_time);
    line("Date", date);
  }
  line("Machine", meta(meta_key::machine));
  line("Machine serial", meta(meta_key::machine_serial));
  line("Location", meta(meta_key::location));
  line("Operator", meta(meta_key::operator_name));
  line("Instrument", meta(meta_key::instrument));
  line("Channels evaluated", channels_text(ev));
  line("Notes", meta(meta_key::notes));
  sections.push_back({"Conditions (clause 4.4)", {}});
  if (ev.nominal_radius_mm) {
    line("Diameter",
         fmt::format("{:.4f} mm (radius {:.4f} mm, from {})", 2 * *ev.nominal_radius_mm,
                     *ev.nominal_radius_mm, value_source_name(ev.nominal_radius_source)));
  } else {
    line("Diameter", kNone);
  }
  {
    std::string feed = meta(meta_key::feeds_mm_per_min);
    if (feed == kNone) feed = meta(meta_key::feed_mm_per_min);
    line("Programmed feed (mm/min)", feed);
  }
  {
    std::string dirs;
    for (const auto& r : ev.runs) {
      dirs += fmt::format("{}{} ({}, {})", dirs.empty() ? "" : ", ",
                          direction_name(r.run.direction), r.label, feed_text(r.feed_mm_per_min));
    }
    line("Runs (direction, feed)", dirs.empty() ? std::string(kNone) : dirs);
  }
  {
    const PlaneAxes axes = plane_axes(ev.plane);
    line("Axes", fmt::format("{}, {} (plane {})", static_cast<char>(std::toupper(axes.first)),
                             static_cast<char>(std::toupper(axes.second)), plane_name(ev.plane)));
  }
  line("Circle centre (mm)", meta(meta_key::centre_mm));
  if (ev.centre) {
    line("Nominal centre", fmt::format("{:.4f}, {:.4f} mm (from {})", ev.centre->a_mm,
                                       ev.centre->b_mm, value_source_name(ev.centre_source)));
  }
  line("Tool-side offset (mm)", meta("offset_tool_mm"));
  line("Workpiece-side offset (mm)", meta("offset_workpiece_mm"));
  auto temp = [](const std::optional<double>& t) {
    return t ? fmt::format("{:.2f} deg C", *t) : std::string(kNone);
  };
  line("Machine temperature", temp(ev.temperatures.machine_C));
  line("Instrument temperature", temp(ev.temperatures.instrument_C));
  line("Air temperature", meta(meta_key::temperature_air_C) == kNone
                              ? std::string(kNone)
                              : meta(meta_key::temperature_air_C) + " deg C");
  if (ev.temperatures.available()) {
    line("F at 20 deg C", fmt::format("corrected, radius factor {:.8f}", ev.temperature_factor));
  } else {
    line("F at 20 deg C", "not corrected (no temperatures recorded; taken as 20 deg C)");
  }
  line("Compensations in use", meta(meta_key::compensation));
  line("Axes not under test", meta(meta_key::other_axes));
  {
    std::string capture = fmt::format("{} runs by {} segmentation, no smoothing", ev.runs.size(),
                                      segmentation_method_name(ev.segmentation));
    if (const std::string* p = ev.conditions.find(meta_key::sample_period_s)) {
      capture += ", sample period " + *p + " s";
    }
    if (const std::string* l = ev.conditions.find(meta_key::lost_samples)) {
      capture += ", lost samples " + *l;
    }
    line("Data capture", capture);
  }
  // Conditions the trace carries that have no line above: shown as they are.
  static const std::set<std::string, std::less<>> kShown = {meta_key::date,
                                                            meta_key::start_time,
                                                            meta_key::machine,
                                                            meta_key::machine_serial,
                                                            meta_key::location,
                                                            meta_key::operator_name,
                                                            meta_key::instrument,
                                                            meta_key::notes,
                                                            meta_key::feeds_mm_per_min,
                                                            meta_key::feed_mm_per_min,
                                                            meta_key::centre_mm,
                                                            "offset_tool_mm",
                                                            "offset_workpiece_mm",
                                                            meta_key::temperature_machine_C,
                                                            meta_key::temperature_instrument_C,
                                                            meta_key::temperature_air_C,
                                                            meta_key::compensation,
                                                            meta_key::other_axes,
                                                            meta_key::sample_period_s,
                                                            meta_key::lost_samples,
                                                            meta_key::plane,
                                                            meta_key::radius_mm,
                                                            meta_key::diameter_mm,
                                                            meta_key::channels};
  for (const std::size_t i : ev.conditions.distinct()) {
    const auto& [key, value] = ev.conditions.entries()[i];
    if (kShown.count(key) || key.rfind(meta_key::channel_prefix, 0) == 0) continue;
    sections.back().items.push_back({key, value, true});
  }
  return sections;
}

std::string uncertainty_text(const UncertaintyBudget& b) {
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out,
                 "\nUncertainty budget (ISO/TR 230-9, GUM; instrument profile {}: {})\n"
                 "   {:<38} {:>9} {:<12} {:<18} {:>5} {:>5} {:>5}\n",
                 instrument_profile_name(b.profile), b.profile_note, "contribution", "value um",
                 "distribution", "source", "c_G", "c_H", "c_F");
  for (const auto& c : b.contributions) {
    fmt::format_to(out, "   {:<38} {:>9.3f} {:<12} {:<18} {:>5.3g} {:>5.3g} {:>5.3g}\n", c.name,
                   c.value_mm * 1000.0, distribution_name(c.distribution), c.source, c.c_g, c.c_h,
                   c.c_f);
  }
  fmt::format_to(out,
                 "   u = root sum of squares of c x (value, or value/sqrt(3) for a rectangular "
                 "half-width); U = k u + c x each bias, k = {:g}\n   U(G) = {}, U(H) = {}, U(F) = "
                 "{}\n",
                 b.k, um_abs(b.u_g_mm), um_abs(b.u_h_mm), um_abs(b.u_f_mm));
  for (const auto& c : b.contributions) fmt::format_to(out, "   {}: {}\n", c.name, c.note);
  return s;
}

std::string limits_text(const std::vector<LimitDecision>& decisions) {
  std::string s = fmt::format("\nAgainst the limits ({})\n", kDecisionRule);
  auto out = std::back_inserter(s);
  for (const auto& d : decisions) {
    if (!d.value_mm) {
      fmt::format_to(out, "   {}: not measured, limit {}: does not pass\n", d.quantity,
                     um_abs(d.limit_mm));
      continue;
    }
    fmt::format_to(out, "   {} = {}, U = {} (k = 2), limit {}: {}\n", d.quantity,
                   um_abs(*d.value_mm), um_abs(d.u_mm), um_abs(d.limit_mm),
                   decision_words(*d.decision));
  }
  return s;
}

nlohmann::ordered_json limits_json(const std::vector<LimitDecision>& decisions) {
  json items = json::array();
  for (const auto& d : decisions) {
    items.push_back({{"quantity", d.quantity},
                     {"value", json_number_or_null(d.value_mm)},
                     {"U", d.u_mm},
                     {"limit", d.limit_mm},
                     {"decision", d.decision ? json(std::string(decision_words(*d.decision)))
                                             : json("not measured")}});
  }
  return {{"rule", kDecisionRule}, {"items", items}, {"pass", all_pass(decisions)}};
}

bool add_limit_verdicts(const Evaluation& ev, const ResultLimits& limits, std::string* text,
                        nlohmann::ordered_json* doc) {
  const auto decisions = decide_limits(ev, uncertainty_budget(ev, ev.uncertainty_options), limits);
  if (text) *text += limits_text(decisions);
  if (doc && doc->is_object()) (*doc)["verdicts"] = limits_json(decisions);
  return all_pass(decisions);
}

std::string text_report(const Evaluation& ev) {
  std::string s;
  auto out = std::back_inserter(s);
  const UncertaintyBudget budget = uncertainty_budget(ev, ev.uncertainty_options);
  const std::string u_g = fmt::format(", U = {} (k = 2)", um_abs(budget.u_g_mm));
  const std::string u_f = fmt::format("  U = {} (k = 2)", um_abs(budget.u_f_mm));
  fmt::format_to(out, "ISO 230-4 / JIS B 6194 circular test: {}\n", ev.source);
  for (const ReportSection& section : header_sections(ev)) {
    s += section.title + "\n";
    for (const ReportItem& item : section.items) {
      fmt::format_to(out, "  {:<28}{}\n", item.title + ":", item.value);
    }
  }
  s += "\n";
  for (const auto& h : ev.hysteresis) {
    // A feed sweep has one H per feed: each line names its runs' feeds.
    const auto& ccw = ev.runs[h.run_ccw];
    const auto& cw = ev.runs[h.run_cw];
    const std::string feeds =
        ccw.feed_mm_per_min && cw.feed_mm_per_min &&
                std::abs(*ccw.feed_mm_per_min - *cw.feed_mm_per_min) <
                    0.05 * std::max(*ccw.feed_mm_per_min, *cw.feed_mm_per_min)
            ? feed_text(ccw.feed_mm_per_min)
            : feed_text(ccw.feed_mm_per_min) + " / " + feed_text(cw.feed_mm_per_min);
    fmt::format_to(out,
                   "a) Circular hysteresis H_{} = {}  at {}  (largest at {:.1f} deg, runs {}/{}), "
                   "U = {} (k = 2)\n",
                   ccw.label, um_abs(h.h_mm), feeds, h.at_angle_deg, h.run_ccw + 1, h.run_cw + 1,
                   um_abs(budget.u_h_mm));
  }
  if (ev.hysteresis.empty()) s += "a) Circular hysteresis H: not available\n";
  fmt::format_to(out, "b) Circular deviation G ({})\n", g_method_name(ev.g_method));
  for (std::size_t i = 0; i < ev.runs.size(); ++i) {
    const auto& r = ev.runs[i];
    fmt::format_to(out, "   run {} {:>3} {:>12} G_{} = {}{}   (other method: {})\n", i + 1,
                   direction_name(r.run.direction), feed_text(r.feed_mm_per_min), r.label,
                   um_abs(r.g_mm(ev.g_method)), u_g,
                   um_abs(r.g_mm(ev.g_method == GMethod::min_zone ? GMethod::least_squares
                                                                  : GMethod::min_zone)));
  }
  s += "c) Radial deviation F (centre: lsc = least-squares centre, nominal = set-up centre)\n";
  for (std::size_t i = 0; i < ev.runs.size(); ++i) {
    const auto& r = ev.runs[i];
    if (r.f_max_mm) {
      fmt::format_to(out, "   run {} {:>3} {:>12} F_{},max = {}  F_{},min = {}{}  (centre: {})\n",
                     i + 1, direction_name(r.run.direction), feed_text(r.feed_mm_per_min), r.label,
                     signed_um(*r.f_max_mm), r.label, signed_um(*r.f_min_mm), u_f,
                     f_centre_method_name(r.f_centre_method));
    } else {
      fmt::format_to(out, "   run {} {:>3} F: not available\n", i + 1,
                     direction_name(r.run.direction));
    }
  }
  s += "\nData capture (clause 4.4 g)\n";
  for (std::size_t i = 0; i < ev.runs.size(); ++i) {
    const auto& r = ev.runs[i];
    fmt::format_to(out,
                   "   run {} {:>3}: segment {}, lines {}-{}, {} samples, arc {:.2f} deg from "
                   "{:.2f} deg, LSC centre {:.4f}, {:.4f} mm, radius {:.4f} mm",
                   i + 1, direction_name(r.run.direction), r.run.segment_id, r.first_line,
                   r.last_line, r.run.size(), r.run.sweep_deg, r.run.start_deg, r.lsc.centre_a_mm,
                   r.lsc.centre_b_mm, r.lsc.radius_mm);
    if (r.feed_mm_per_min) fmt::format_to(out, ", feed {:.0f} mm/min", *r.feed_mm_per_min);
    s += ", no smoothing\n";
  }
  s += uncertainty_text(budget);
  for (const auto& n : ev.notes) fmt::format_to(out, "Note: {}\n", n);
  return s;
}

FitReport fit_all(const std::string& source, std::span<const double> a, std::span<const double> b) {
  FitReport r;
  r.source = source;
  r.points = a.size();
  r.lsc = fit_lsc(a, b);
  r.mzc = fit_mzc(a, b);
  r.mcc = fit_mcc(a, b);
  // An arc of 180 deg or less encloses no inscribed circle; the other fits still stand.
  MicFit mic = fit_mic(a, b);
  r.mic = std::move(mic.mic);
  r.mic_note = std::move(mic.why_none);
  return r;
}

json to_json(const FitReport& r) {
  auto circle = [](const ContactCircle& c) {
    return json{{"centre", {c.circle.centre_a_mm, c.circle.centre_b_mm}},
                {"radius", c.circle.radius_mm},
                {"contacts", c.contacts}};
  };
  json j;
  j["units"] = "mm";
  j["source"] = r.source;
  j["points"] = r.points;
  j["lsc"] = {{"centre", {r.lsc.centre_a_mm, r.lsc.centre_b_mm}}, {"radius", r.lsc.radius_mm}};
  j["mzc"] = {{"centre", {r.mzc.centre_a_mm, r.mzc.centre_b_mm}},
              {"radius", r.mzc.mean_radius_mm()},
              {"inner_radius", r.mzc.inner_radius_mm},
              {"outer_radius", r.mzc.outer_radius_mm},
              {"zone_width", r.mzc.zone_width_mm},
              {"certified", r.mzc.certified},
              {"outer_contacts", r.mzc.outer_contacts},
              {"inner_contacts", r.mzc.inner_contacts}};
  j["mcc"] = circle(r.mcc);
  j["mic"] = r.mic ? circle(*r.mic) : json(nullptr);
  if (!r.mic) j["mic_note"] = r.mic_note;
  return j;
}

std::string text_report(const FitReport& r) {
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out, "Circle fits of {} ({} points), mm\n", r.source, r.points);
  fmt::format_to(out, "LSC  centre {:.9f}, {:.9f}  radius {:.9f}\n", r.lsc.centre_a_mm,
                 r.lsc.centre_b_mm, r.lsc.radius_mm);
  fmt::format_to(out, "MZC  centre {:.9f}, {:.9f}  radius {:.9f}  zone width {:.9f} ({})\n",
                 r.mzc.centre_a_mm, r.mzc.centre_b_mm, r.mzc.mean_radius_mm(), r.mzc.zone_width_mm,
                 r.mzc.certified ? "certified optimal" : "NOT certified");
  fmt::format_to(out, "MCC  centre {:.9f}, {:.9f}  radius {:.9f}\n", r.mcc.circle.centre_a_mm,
                 r.mcc.circle.centre_b_mm, r.mcc.circle.radius_mm);
  if (r.mic) {
    fmt::format_to(out, "MIC  centre {:.9f}, {:.9f}  radius {:.9f}\n", r.mic->circle.centre_a_mm,
                   r.mic->circle.centre_b_mm, r.mic->circle.radius_mm);
  } else {
    fmt::format_to(out, "MIC  none: {}\n", r.mic_note);
  }
  return s;
}

}  // namespace circtest
