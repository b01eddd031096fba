// The session's acceptance limits (`circtest run --limits`, the syntax of circana report's
// --limits) and the verdict of a test against them, by the same rule and the same code as the
// hand-over report and circana history decide it (circtest::history::verdicts).
#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/history/history.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace fs = std::filesystem;

namespace {

std::optional<double> number(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return std::nullopt;
  return j[key].get<double>();
}

void keep_max(std::optional<double>& slot, double v) {
  slot = std::max(slot.value_or(v), v);
}

// The trend's numbers of a test as the history keeps them: the largest H and G, the largest
// |F_max|, |F_min|, each with its U; backlash (largest of the axes) and squareness from the
// diagnosis.
history::TestRecord test_record(const std::string& results_text,
                                const std::string& diagnosis_text) {
  history::TestRecord r;
  const auto j = nlohmann::json::parse(results_text);
  r.h_mm = number(j, "H");
  r.u_h_mm = number(j, "U_H");
  for (const auto& run : j.value("runs", nlohmann::json::array())) {
    if (const auto g = number(run, "G")) {
      if (!r.g_mm || *g > *r.g_mm) r.u_g_mm = number(run, "U_G");
      keep_max(r.g_mm, *g);
    }
    for (const char* key : {"F_max", "F_min"}) {
      const auto f = number(run, key);
      if (!f) continue;
      if (!r.f_mm || std::abs(*f) > *r.f_mm) r.u_f_mm = number(run, "U_F");
      keep_max(r.f_mm, std::abs(*f));
    }
  }
  if (!diagnosis_text.empty()) {
    const auto d = nlohmann::json::parse(diagnosis_text);
    if (d.contains("backlash_mm") && d["backlash_mm"].is_object()) {
      for (const auto& [axis, b] : d["backlash_mm"].items()) {
        if (b.is_number()) keep_max(r.backlash_mm, std::abs(b.get<double>()));
      }
    }
    r.squareness_urad = number(d, "squareness_urad");
  }
  return r;
}

std::string item_words(const history::Verdict& v) {
  using R = history::Verdict::Result;
  const std::string q = v.quantity;
  if (v.result == R::not_measured || !v.value) return q + " not measured";
  const std::string value = fmt::format("{} {:.1f}", q, *v.value);
  const std::string limit = fmt::format("{:.1f} {}", *v.limit, v.unit);
  switch (v.result) {
    case R::pass:
      return v.u ? fmt::format("{} + U {:.1f} <= {}", value, *v.u, limit)
                 : fmt::format("{} <= {} (no U)", value, limit);
    case R::fail:
      return v.u ? fmt::format("{} - U {:.1f} > {}", value, *v.u, limit)
                 : fmt::format("{} > {} (no U)", value, limit);
    default:
      return fmt::format("{} + U {:.1f} > {}: within the uncertainty", value, v.u.value_or(0),
                         limit);
  }
}

}  // namespace

void check_limits(const std::string& text) {
  (void)history::parse_limits(text, "--limits");
}

std::string session_limits(const std::string& dir, const std::string& given) {
  const fs::path file = fs::path(dir) / kLimitsFile;
  if (!given.empty()) {
    write_file_atomic(file.string(), given + "\n");
    return given;
  }
  if (!fs::exists(file)) return {};
  std::string text = read_file(file.string());
  text.erase(std::remove(text.begin(), text.end(), '\n'), text.end());
  // Written by the session: a file edited since is held to the same syntax.
  (void)history::parse_limits(text, file.string());
  return text;
}

SessionVerdict session_verdict(const std::string& results_text, const std::string& diagnosis_text,
                               const std::string& limits_text) {
  using W = SessionVerdict::Word;
  if (limits_text.empty()) {
    return {W::none, "no acceptance limits set (circtest run --limits H=MM,G=MM,F=MM): no verdict"};
  }
  const history::Limits limits = history::parse_limits(limits_text, "--limits");
  using R = history::Verdict::Result;
  std::vector<std::string> items;
  bool fail = false, pass = true;
  for (const history::Verdict& v :
       history::verdicts(test_record(results_text, diagnosis_text), limits)) {
    if (v.result == R::no_limit) continue;
    items.push_back(item_words(v));
    // As the report's banner: a limit that cannot be checked fails.
    fail = fail || v.result == R::fail || v.result == R::not_measured;
    pass = pass && v.result == R::pass;
  }
  const W word = pass ? W::within : fail ? W::out_of_tolerance : W::not_decided;
  const char* words = word == W::within             ? "within the limits"
                      : word == W::out_of_tolerance ? "OUT OF TOLERANCE"
                                                    : "NOT DECIDED";
  std::string line =
      fmt::format("verdict against {} (ISO 14253-1, U k = 2): {}: ", limits_text, words);
  for (std::size_t i = 0; i < items.size(); ++i) line += (i ? "; " : "") + items[i];
  return {word, line};
}

std::string verdict_line(const std::string& results_text, const std::string& diagnosis_text,
                         const std::string& limits_text) {
  return session_verdict(results_text, diagnosis_text, limits_text).line;
}

int verify_exit_code(SessionVerdict::Word word) {
  using W = SessionVerdict::Word;
  return word == W::none || word == W::within ? 0 : static_cast<int>(ExitCode::tolerance);
}

}  // namespace circtest::session
