#include "circtest/analysis/history_record.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "circtest/analysis/result_json.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest {

namespace {
nlohmann::json plain(const nlohmann::ordered_json& j) {
  return nlohmann::json::parse(j.dump());
}
void keep_max(std::optional<double>& slot, double v) {
  slot = std::max(slot.value_or(v), v);
}
}  // namespace

history::TestRecord history_record(const Evaluation& ev, const Diagnosis* diagnosis,
                                   const std::string& machine, RemedyWords words) {
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
  r.tested_at = condition(meta_key::start_time);
  if (r.tested_at.empty()) r.tested_at = condition(meta_key::date);
  r.plane = std::string(plane_name(ev.plane));
  r.channels = ev.channel_a + "," + ev.channel_b;
  r.trace_path = ev.source;
  r.result = plain(to_json(ev));
  r.conditions = r.result.value("conditions", nlohmann::json::object());
  r.conditions[meta_key::machine] = r.machine;
  r.result["conditions"] = r.conditions;
  for (const auto& h : ev.hysteresis) {
    const RunResult& ccw = ev.runs[h.run_ccw];
    r.measures.push_back({"H", ccw.label, "CCW/CW", ccw.feed_mm_per_min, h.h_mm});
    keep_max(r.h_mm, h.h_mm);
  }
  for (const auto& run : ev.runs) {
    const std::string dir(direction_name(run.run.direction));
    const double g = run.g_mm(ev.g_method);
    r.measures.push_back({"G", run.label, dir, run.feed_mm_per_min, g});
    keep_max(r.g_mm, g);
    for (const auto& [kind, f] : {std::pair{"F_max", run.f_max_mm}, {"F_min", run.f_min_mm}}) {
      if (!f) continue;
      r.measures.push_back({kind, run.label, dir, run.feed_mm_per_min, *f});
      keep_max(r.f_mm, std::abs(*f));
    }
  }
  if (diagnosis) {
    r.diagnosis = plain(to_json(*diagnosis));
    for (const Estimate& b : diagnosis->backlash_mm) {
      if (b.value) keep_max(r.backlash_mm, std::abs(*b.value));
    }
    r.squareness_urad = diagnosis->squareness_urad.value;
  }
  return r;
}

}  // namespace circtest
