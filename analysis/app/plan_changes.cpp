// What circcomp changed between the tests, for the report's page 1: the plans of every apply
// round (circcomp plan --json, circtest.plan/1) netted to one line per item.
#include "circtest/circana/plan_changes.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <regex>

#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"

namespace circtest {

namespace {

// An optional text of a change: a string, or null / absent.
std::optional<std::string> optional_text(const JsonReader<nlohmann::json>& rd,
                                         const nlohmann::json& c, const char* key,
                                         const std::string& at) {
  if (!c.contains(key) || c[key].is_null()) return std::nullopt;
  return rd.text(c, key, at);
}

// The "A → B" pairs of a change's words, in order, with where each B stands.
struct Arrow {
  std::string from, to;
  std::size_t to_pos = 0;
};
std::vector<Arrow> arrows(const std::string& words) {
  static const std::regex arrow(R"((\S+) → (\S+))");
  std::vector<Arrow> out;
  for (std::sregex_iterator it(words.begin(), words.end(), arrow), end; it != end; ++it) {
    out.push_back({(*it)[1], (*it)[2], static_cast<std::size_t>(it->position(2))});
  }
  return out;
}

// The net words of an item changed in several rounds: the first round's words with each
// "→ B" taken from the last round ("X backlash 0 → 10.2 µm" and "X backlash 10.2 → 10.5 µm"
// give "X backlash 0 → 10.5 µm"); the last round's words when the two differ in form. Empty
// when every net "A → B" has A = B: the rounds undid each other.
std::string net_words(const std::string& first, const std::string& last) {
  const auto a = arrows(first), b = arrows(last);
  if (a.size() != b.size()) return last;
  std::string out = first;
  bool changed = a.empty();
  for (std::size_t i = a.size(); i-- > 0;) {
    out.replace(a[i].to_pos, a[i].to.size(), b[i].to);
    changed |= a[i].from != b[i].to;
  }
  return changed ? out : std::string();
}

// "rising over 12 ms", "rising over 10 → 12 ms"; empty when not set after.
std::string timing(const char* what, const PlanChange* c) {
  if (!c || !c->after) return {};
  if (c->before && *c->before != *c->after)
    return fmt::format("{} over {} → {} ms", what, *c->before, *c->after);
  return fmt::format("{} over {} ms", what, *c->after);
}

// One line for an axis' friction compensator ([FRICTION_<axis>] AMPLITUDE, DECAY_MS, RISE_MS;
// its bounds AMPLITUDE_MAX and SPIKE_MM are circcomp's bookkeeping): the pulse's height and
// timing, as they were and are.
std::string friction_words(char axis, const std::map<std::string, const PlanChange*>& keys) {
  auto key = [&keys](const char* k) {
    const auto it = keys.find(k);
    return it == keys.end() ? nullptr : it->second;
  };
  const PlanChange* amplitude = key("AMPLITUDE");
  if (amplitude && !amplitude->after) return fmt::format("{} friction compensation removed", axis);
  std::vector<std::string> parts;
  if (amplitude) {
    parts.push_back(amplitude->before ? fmt::format("pulse height {} → {} (machine units)",
                                                    *amplitude->before, *amplitude->after)
                                      : fmt::format("pulse height {} (machine units) at each "
                                                    "reversal",
                                                    *amplitude->after));
  }
  for (const auto& t : {timing("rising", key("RISE_MS")), timing("decaying", key("DECAY_MS"))}) {
    if (!t.empty()) parts.push_back(t);
  }
  if (parts.empty()) return {};  // only circcomp's bounds changed
  const bool added = amplitude && !amplitude->before;
  std::string words = fmt::format("{} friction compensation{}: ", axis, added ? " added" : "");
  for (std::size_t i = 0; i < parts.size(); ++i) words += (i ? ", " : "") + parts[i];
  return words;
}

}  // namespace

void read_plan_changes(const std::string& path, std::vector<PlanChange>& changes,
                       std::vector<std::string>& advice) {
  // The schema circcomp writes (compensation/plan_json.hpp); circana reads it as data only.
  constexpr const char* kPlanSchema = "circtest.plan/1";
  const nlohmann::json j = read_json_file(path);
  const JsonReader<nlohmann::json> rd(path, "plan JSON", 1e12);
  if (!j.is_object() || !j.contains("schema") || !j["schema"].is_string() ||
      j["schema"].get<std::string>() != kPlanSchema) {
    throw ParseError(path, 0,
                     fmt::format("expected a {} document (circcomp plan --json)", kPlanSchema));
  }
  const auto& items = rd.array(j, "changes", "");
  for (std::size_t i = 0; i < items.size(); ++i) {
    const nlohmann::json& c = items[i];
    const std::string at = fmt::format("changes[{}]", i);
    PlanChange change;
    change.words = rd.text(c, "words", at);
    // A setting written without effect (0 where there was none) is no news to the customer.
    if (c.contains("effective") && !rd.boolean(c, "effective", at)) continue;
    change.wiring = c.contains("kind") && rd.text(c, "kind", at) == "wiring";
    change.file = optional_text(rd, c, "file", at).value_or("");
    change.section = optional_text(rd, c, "section", at).value_or("");
    change.key = optional_text(rd, c, "key", at).value_or("");
    change.before = optional_text(rd, c, "before", at);
    change.after = optional_text(rd, c, "after", at);
    if (c.contains("hal_line")) change.key += fmt::format(":{}", rd.count(c, "hal_line", at));
    // A HAL file added or removed, a file written: the same item only when said the same.
    const bool named =
        !change.section.empty() || !change.key.empty() || (!change.file.empty() && !change.wiring);
    change.item =
        named ? change.file + "|" + change.section + "|" + change.key : "words|" + change.words;
    // The same item in an earlier round: one net change, from its first before to this after.
    const auto same = std::find_if(changes.begin(), changes.end(), [&change](const PlanChange& p) {
      return p.item == change.item;
    });
    if (same == changes.end()) {
      change.first_words = change.words;
      changes.push_back(std::move(change));
    } else {
      same->after = change.after;
      same->words = change.words;
    }
  }
  advice.clear();
  if (j.contains("advice")) {
    const auto& a = rd.array(j, "advice", "");
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (!a[i].is_string()) rd.fail(fmt::format("advice[{}]", i), "a string");
      advice.push_back(a[i].get<std::string>());
    }
  }
}

NetChanges net_changes(const std::vector<PlanChange>& changes) {
  NetChanges out;
  std::map<char, std::map<std::string, const PlanChange*>> friction;
  std::vector<char> friction_order;
  static const std::regex friction_section(R"(FRICTION_([A-Z]))");
  for (const PlanChange& c : changes) {
    std::smatch m;
    if (std::regex_match(c.section, m, friction_section)) {
      const char axis = m[1].str()[0];
      if (!friction.count(axis)) friction_order.push_back(axis);
      friction[axis][c.key] = &c;
      continue;
    }
    const bool ini_key = !c.section.empty() && !c.key.empty();
    if (ini_key && c.before == c.after) continue;  // the rounds undid each other
    const std::string words = net_words(c.first_words, c.words);
    if (words.empty()) continue;
    (c.wiring ? out.wiring : out.settings).push_back(words);
  }
  for (const char axis : friction_order) {
    const std::string words = friction_words(axis, friction[axis]);
    if (!words.empty()) out.settings.push_back(words);
  }
  return out;
}

}  // namespace circtest
