#include "circtest/circana/history_record.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "circtest/analysis/result_checks.hpp"
#include "circtest/analysis/result_json.hpp"
#include "circtest/analysis/uncertainty.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/core/utc_time.hpp"

namespace circtest {

namespace {
nlohmann::json plain(const nlohmann::ordered_json& j, const std::string& source) {
  return parse_json_text(json_text(j), source);
}
void keep_max(std::optional<double>& slot, double v) {
  slot = std::max(slot.value_or(v), v);
}

// The test's time: start_time (the recorder's), else date (the program's), canonical UTC;
// "" when the trace has neither.
std::string tested_at(const TraceMetadata& conditions, const std::string& source) {
  for (const char* key : {meta_key::start_time, meta_key::date}) {
    const std::string* text = conditions.find(key);
    if (!text) continue;
    if (auto canonical = canonical_utc_iso8601(*text)) return *canonical;
    throw DataError(source, conditions.line_of(key),
                    fmt::format("'{}': expected an ISO 8601 date YYYY-MM-DD or date-time "
                                "YYYY-MM-DDTHH:MM:SSZ (a real one), got '{}': the test is not "
                                "stored under a date that is none",
                                key, utf8_replacing_invalid(*text)));
  }
  return {};
}

// Every number the history keeps, finite and of a size a circular test can have, or a
// DataError naming it: "inf" never reaches the trend.
void require_usable_numbers(const history::TestRecord& r, const std::string& source) {
  history::for_each_number(r, [&source](const std::optional<double>& v, const std::string& what) {
    if (v && !(std::abs(*v) <= kMaxReportedMagnitude)) {
      throw DataError(source, 0,
                      fmt::format("{} = {:g} is not a usable number (finite, at most {:g} in "
                                  "size): not stored",
                                  what, *v, kMaxReportedMagnitude));
    }
  });
}
}  // namespace

void add_measures(const Evaluation& ev, history::TestRecord& r) {
  // One budget for every run of the trace, as circana analyze states it.
  const UncertaintyBudget budget = uncertainty_budget(ev, ev.uncertainty_options);
  for (const auto& h : ev.hysteresis) {
    const RunResult& ccw = ev.runs[h.run_ccw];
    r.measures.push_back({"H", ccw.label, "CCW/CW", ccw.feed_mm_per_min, h.h_mm, budget.u_h_mm});
    keep_max(r.h_mm, h.h_mm);
    r.u_h_mm = budget.u_h_mm;
  }
  for (const auto& run : ev.runs) {
    const std::string dir(direction_name(run.run.direction));
    const double g = run.g_mm(ev.g_method);
    r.measures.push_back({"G", run.label, dir, run.feed_mm_per_min, g, budget.u_g_mm});
    keep_max(r.g_mm, g);
    r.u_g_mm = budget.u_g_mm;
    for (const auto& [kind, f] : {std::pair{"F_max", run.f_max_mm}, {"F_min", run.f_min_mm}}) {
      if (!f) continue;
      r.measures.push_back({kind, run.label, dir, run.feed_mm_per_min, *f, budget.u_f_mm});
      keep_max(r.f_mm, std::abs(*f));
      r.u_f_mm = budget.u_f_mm;
    }
  }
}

history::TestRecord history_record(const Evaluation& ev, const Diagnosis* diagnosis,
                                   const std::string& machine, RemedyWords words,
                                   const std::string& source) {
  const std::string& file = source.empty() ? ev.source : source;
  history::TestRecord r;
  auto condition = [&ev](const char* key) {
    const std::string* v = ev.conditions.find(key);
    return v ? *v : std::string();
  };
  r.machine = machine.empty() ? condition(meta_key::machine) : machine;
  if (r.machine.empty()) {
    throw Error(ExitCode::data,
                fmt::format("no machine name: give {} or record it in the trace (# machine: NAME)",
                            words(Remedy::give_machine)));
  }
  r.tested_at = tested_at(ev.conditions, file);
  r.plane = std::string(plane_name(ev.plane));
  r.channels = ev.channel_a + "," + ev.channel_b;
  r.trace_path = utf8_replacing_invalid(ev.source);
  r.result = plain(to_json(ev), file);
  r.conditions = r.result.value("conditions", nlohmann::json::object());
  r.conditions[meta_key::machine] = r.machine;
  r.result["conditions"] = r.conditions;
  add_measures(ev, r);
  if (diagnosis) {
    r.diagnosis = plain(to_json(*diagnosis), file);
    for (const Estimate& b : diagnosis->backlash_mm) {
      if (b.value) keep_max(r.backlash_mm, std::abs(*b.value));
    }
    r.squareness_urad = diagnosis->squareness_urad.value;
  }
  require_usable_numbers(r, file);
  return r;
}

ResultLimits result_limits(const std::string& text) {
  const history::Limits l = history::parse_limits(text, "--limits");
  if (l.backlash_mm || l.squareness_urad) {
    throw UsageError(
        "--limits of circana analyze: H, G and F only (backlash and squareness: "
        "circana report or history)");
  }
  return ResultLimits{l.h_mm, l.g_mm, l.f_mm};
}

}  // namespace circtest
