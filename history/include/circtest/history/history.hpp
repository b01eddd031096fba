#pragma once
// The history of every machine's circular tests: one schema, kept in an embedded SQLite file
// (default) or on a shop-wide PostgreSQL server, created and migrated on first use.
//
// This part stores records and keeps the result documents (circtest.evaluation/1,
// circtest.diagnosis/1) as they were; it does not read them. The analysis makes the record
// from its own types (circtest/analysis/history_record.hpp: a stored document goes through
// evaluation_from_json first), so a document's keys are read in one place.
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace circtest::history {

// One number of a test: H of a pair, G / F_max / F_min of a run.
struct Measure {
  std::string kind;       // "H", "G", "F_max", "F_min"
  std::string label;      // clause 3.7 label, e.g. "XY"
  std::string direction;  // "CCW", "CW"
  std::optional<double> feed_mm_per_min;
  double value_mm = 0.0;
  // Its expanded uncertainty U (k = 2); empty for a test stored before U was kept.
  std::optional<double> u_mm;
};

struct TestRecord {
  std::int64_t id = 0;       // set by the store
  std::string machine;       // the history is kept per machine
  std::string tested_at;     // ISO 8601, UTC when known (the trace's start_time or date);
                             // empty: the store takes the time of storing
  std::string stored_at;     // ISO 8601 UTC, set by the store
  std::string plane;         // "XY", ...
  std::string channels;      // "x,y"
  std::string trace_path;    // as given
  std::string trace_sha256;  // empty when the trace file was not at hand
  nlohmann::json conditions = nlohmann::json::object();
  std::vector<Measure> measures;
  // The trend's numbers: the largest H and G of the test, and from the diagnosis (when one
  // was stored) the largest backlash of the plane's axes and the squareness.
  std::optional<double> h_mm;
  std::optional<double> g_mm;
  std::optional<double> f_mm;  // the largest |F_max|, |F_min|
  // The expanded uncertainties (k = 2) of H, G and F: one budget per trace
  // (circtest/analysis/uncertainty.hpp). Empty for a test stored before U was kept.
  std::optional<double> u_h_mm, u_g_mm, u_f_mm;
  std::optional<double> backlash_mm;
  std::optional<double> squareness_urad;
  nlohmann::json result;               // the evaluation document as stored
  nlohmann::json diagnosis = nullptr;  // the diagnosis document, or null
};

// Calls VISIT(value, name) for each number of TEST, named as a message about it names it
// ("H", "G of run XY CW", "feed of run XY CW"): the one list the checks before storing use.
template <typename Visit>
void for_each_number(const TestRecord& test, Visit&& visit) {
  visit(test.h_mm, std::string("H"));
  visit(test.g_mm, std::string("G"));
  visit(test.f_mm, std::string("F"));
  visit(test.u_h_mm, std::string("U of H"));
  visit(test.u_g_mm, std::string("U of G"));
  visit(test.u_f_mm, std::string("U of F"));
  visit(test.backlash_mm, std::string("backlash"));
  visit(test.squareness_urad, std::string("squareness_urad"));
  for (const Measure& m : test.measures) {
    const std::string run = " of run " + m.label + " " + m.direction;
    visit(std::optional<double>(m.value_mm), m.kind + run);
    visit(m.feed_mm_per_min, "feed" + run);
    visit(m.u_mm, "U of " + m.kind + run);
  }
}

// The storage interface. Every call throws DatabaseError (exit code 11) with the database
// named when the database cannot be used.
class Store {
 public:
  virtual ~Store() = default;
  // Stores one test in one transaction: all of it or, on any failure, nothing.
  virtual std::int64_t add(const TestRecord& record) = 0;
  // The tests of a machine at or after `since` (ISO 8601 prefix; empty: all), oldest first,
  // with their measures.
  virtual std::vector<TestRecord> tests(const std::string& machine, const std::string& since) = 0;
  virtual std::vector<std::string> machines() = 0;
  virtual int schema_version() = 0;
  virtual const std::string& name() const = 0;  // for messages (no password)
};

// The newest schema this build knows; older databases are migrated on open, newer ones
// refused.
int latest_schema_version() noexcept;

// Opens (creating and migrating when needed) the history at `url`: empty for the default
// SQLite file, "postgresql://..." / "postgres://..." for a server (a libpq URI), else
// "sqlite:PATH" or a file path. `setting` is how the front end names the database setting in
// its messages (circana: "--db"); the library names no command-line option itself.
inline constexpr std::string_view kDatabaseSetting = "history database";  // the library's word
std::unique_ptr<Store> open_store(const std::string& url,
                                  std::string_view setting = kDatabaseSetting);

// $XDG_DATA_HOME/circtest/history.sqlite ($HOME/.local/share when XDG_DATA_HOME is unset).
std::string default_database_path(std::string_view setting = kDatabaseSetting);

// Limits of the trend: H, G, F, backlash (mm) and squareness (urad).
struct Limits {
  std::optional<double> h_mm, g_mm, f_mm, backlash_mm, squareness_urad;
  bool empty() const { return !h_mm && !g_mm && !f_mm && !backlash_mm && !squareness_urad; }
};
// "H=0.015,G=0.020" (mm; squareness in urad). Throws UsageError naming `setting` (circana:
// "--limits").
Limits parse_limits(const std::string& text, std::string_view setting = "limits");
// The decision rule of ISO 14253-1, as `circana analyze --limits` applies it: the same words
// as circtest::kDecisionRule of the analysis (a test holds them equal).
inline constexpr const char* kDecisionRule =
    "ISO 14253-1: pass when value + U <= limit, fail when value - U > limit, otherwise not "
    "decided (U expanded, k = 2)";
// How a quantity without U is judged: the value alone against the limit (a test stored before
// U was kept; backlash and squareness, which the diagnosis states without U).
inline constexpr const char* kValueAloneRule =
    "without U: pass when value <= limit, fail otherwise (the value alone)";

// The quantities of a test that do not pass their limit, e.g. {"H 21.0 - U 1.4 > 15.0 um"},
// {"G 19.6 + U 1.5 > 20.0 um: not decided, within the uncertainty"}.
std::vector<std::string> breaches(const TestRecord& test, const Limits& limits);

// One quantity of a test against its limit: H, G, F, backlash (values and limit in um) and
// squareness (urad). With U (H, G, F of a test stored with it) the rule of kDecisionRule;
// without, the value alone (kValueAloneRule). A quantity with a limit that was not measured
// does not pass.
struct Verdict {
  enum class Result { pass, fail, not_decided, no_limit, not_measured };
  const char* quantity;         // as in the limits: "H", "G", "F", "backlash", "squareness"
  const char* unit;             // "um" or "urad" (ASCII; a front end writes its own symbol)
  std::optional<double> value;  // |value| in the unit, when measured
  std::optional<double> limit;  // in the unit, when set
  Result result = Result::no_limit;
  std::optional<double> u;  // U (k = 2) in the unit; empty: judged on the value alone
};
// "pass", "fail", "not decided: within the uncertainty", "not measured", "no limit".
const char* decision_words(Verdict::Result result) noexcept;
// Every quantity of the test, in the order above.
std::vector<Verdict> verdicts(const TestRecord& test, const Limits& limits);

// Outputs of `circana history`: a text table, a circtest.history/1 document, an SVG trend.
std::string history_text(const std::string& machine, const std::vector<TestRecord>& tests,
                         const Limits& limits);
nlohmann::ordered_json history_json(const std::string& machine,
                                    const std::vector<TestRecord>& tests, const Limits& limits);
std::string history_svg(const std::string& machine, const std::vector<TestRecord>& tests,
                        const Limits& limits, int width_px = 720);

}  // namespace circtest::history
