// The expanded uncertainty U (k = 2) of H, G and F in the history: stored as analyze states
// it, decided by ISO 14253-1 as analyze decides, an older database migrated and read as
// without U. SQLite and PostgreSQL alike (history_fixture.hpp).
#include "history_fixture.hpp"

using namespace circtest_history_test;

// U (k = 2) of H, G and F is stored with each test and equals what circana analyze --json
// states for the same trace (an independent path: the trace evaluated again); history --limits
// decides by ISO 14253-1 as analyze --limits does, also exactly at the boundaries.
TEST_P(History, LimitsFollowIso14253WithTheStoredUAsAnalyzeDoes) {
  sim::MachineModel m;
  m.x.backlash_mm = 0.006;
  sim::CircleProgram p;
  p.period_s = 0.004;
  Trace t = sim::simulate(m, p);
  t.metadata.set("machine", "VMC-3");
  t.metadata.set("date", "2026-05-01");
  const fs::path trace = dir_ / "u.csv";
  write_trace(trace.string(), t);
  Result r = run(circana("store " + trace.string()), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  r = run(std::string(CIRCANA_PATH) + " analyze " + trace.string() + " --json", dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto a = nlohmann::json::parse(r.out);
  const double h = a["pairs"][0]["H"].get<double>(), u_h = a["U_H"].get<double>();
  const double u_g = a["runs"][0]["U_G"].get<double>(), u_f = a["runs"][0]["U_F"].get<double>();
  ASSERT_GT(u_h, 0.0);

  // The stored numbers are the evaluation's doubles; the JSON holds them to 15 digits.
  const auto tests = open_store(url_)->tests("VMC-3", "");
  ASSERT_EQ(tests.size(), 1u);
  ASSERT_TRUE(tests[0].h_mm && tests[0].u_h_mm && tests[0].u_g_mm && tests[0].u_f_mm);
  auto near = [](double stored, double analyzed) { return std::abs(stored - analyzed) <= 1e-14; };
  EXPECT_TRUE(near(*tests[0].h_mm, h)) << *tests[0].h_mm << " " << h;
  EXPECT_TRUE(near(*tests[0].u_h_mm, u_h)) << *tests[0].u_h_mm << " " << u_h;
  EXPECT_TRUE(near(*tests[0].u_g_mm, u_g)) << *tests[0].u_g_mm << " " << u_g;
  EXPECT_TRUE(near(*tests[0].u_f_mm, u_f)) << *tests[0].u_f_mm << " " << u_f;
  for (const Measure& x : tests[0].measures) {
    ASSERT_TRUE(x.u_mm) << x.kind;
    EXPECT_EQ(*x.u_mm, x.kind == "H"   ? *tests[0].u_h_mm
                       : x.kind == "G" ? *tests[0].u_g_mm
                                       : *tests[0].u_f_mm)
        << x.kind;
  }
  r = run(circana("history --machine VMC-3 --json"), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(near(j["tests"][0]["U_H"].get<double>(), u_h));
  EXPECT_TRUE(near(j["tests"][0]["U_G"].get<double>(), u_g));
  EXPECT_TRUE(near(j["tests"][0]["U_F"].get<double>(), u_f));
  EXPECT_TRUE(near(j["tests"][0]["measures"][0]["U"].get<double>(), u_h));
  r = run(circana("history --machine VMC-3"), dir_);
  EXPECT_NE(r.out.find(fmt::format("{:.1f} +-{:.1f}", h * 1000, u_h * 1000)), std::string::npos)
      << r.out;

  // The limit around value + U and value - U, 1e-9 mm off (two evaluations of one trace may
  // differ in the last bits of a double, the vectorised sums): pass above value + U, not
  // decided between, fail below value - U; analyze --limits on the trace decides the same.
  // The exact boundaries: HistoryLimits.TheBoundariesAreDecidedAsTheAnalysisDecidesThem.
  const double hs = *tests[0].h_mm, us = *tests[0].u_h_mm, e = 1e-9;
  const std::vector<std::pair<double, std::string>> cases = {
      {hs + us + e, "pass"},
      {hs + us - e, "not decided: within the uncertainty"},
      {hs, "not decided: within the uncertainty"},
      {hs - us + e, "not decided: within the uncertainty"},
      {hs - us - e, "fail"}};
  for (const auto& [limit, expected] : cases) {
    const std::string l = fmt::format("H={:.17g}", limit);
    r = run(circana("history --machine VMC-3 --json --limits " + l), dir_);
    EXPECT_EQ(r.code, expected == "pass" ? 0 : 9) << l << r.err;
    const auto hj = nlohmann::json::parse(r.out);
    EXPECT_EQ(hj["decision_rule"], history::kDecisionRule);
    const auto& v = hj["tests"][0]["verdicts"][0];
    EXPECT_EQ(v["quantity"], "H");
    EXPECT_EQ(v["decision"], expected) << l;
    EXPECT_EQ(v["rule"], history::kDecisionRule);
    EXPECT_TRUE(near(v["U"].get<double>(), u_h));
    EXPECT_EQ(hj["pass"], expected == "pass") << l;
    r = run(std::string(CIRCANA_PATH) + " analyze " + trace.string() + " --json --limits " + l,
            dir_);
    EXPECT_EQ(r.code, expected == "pass" ? 0 : 9) << l << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["verdicts"]["items"][0]["decision"], expected) << l;
  }
  r = run(circana(fmt::format("history --machine VMC-3 --limits H={:.17g}", h)), dir_);
  EXPECT_NE(r.out.find("Latest test (2026-05-01): NOT DECIDED (within the uncertainty): H "),
            std::string::npos)
      << r.out;
}

// A database of schema version 1 (before U was kept) is migrated on open and stays readable:
// its tests say they have no U, and --limits judges them on the value alone, saying so.
TEST_P(History, AnOldDatabaseIsMigratedAndItsTestsSayTheyHaveNoU) {
  const std::vector<std::string> v1 = {
      "CREATE TABLE circtest_schema (version INTEGER NOT NULL)",
      "INSERT INTO circtest_schema VALUES (1)",
      fmt::format(
          "CREATE TABLE tests (id {}, machine TEXT NOT NULL, tested_at TEXT NOT NULL, "
          "stored_at TEXT NOT NULL, plane TEXT NOT NULL, channels TEXT NOT NULL, trace_path TEXT "
          "NOT NULL, trace_sha256 TEXT, h_mm DOUBLE PRECISION, g_mm DOUBLE PRECISION, f_mm "
          "DOUBLE PRECISION, backlash_mm DOUBLE PRECISION, squareness_urad DOUBLE PRECISION, "
          "conditions TEXT NOT NULL, result TEXT NOT NULL, diagnosis TEXT)",
          GetParam() == Backend::sqlite ? "INTEGER PRIMARY KEY AUTOINCREMENT"
                                        : "BIGSERIAL PRIMARY KEY"),
      "CREATE TABLE measures (test_id BIGINT NOT NULL REFERENCES tests (id) ON DELETE CASCADE, "
      "seq INTEGER NOT NULL, kind TEXT NOT NULL, label TEXT NOT NULL, direction TEXT NOT NULL, "
      "feed_mm_per_min DOUBLE PRECISION, value_mm DOUBLE PRECISION NOT NULL, PRIMARY KEY "
      "(test_id, seq))",
      "INSERT INTO tests (machine, tested_at, stored_at, plane, channels, trace_path, h_mm, "
      "g_mm, f_mm, conditions, result) VALUES ('VMC-3', '2025-01-05', '2025-01-05', 'XY', "
      "'x,y', 'old.csv', 0.012, 0.018, 0.009, '{}', '{}')",
      "INSERT INTO measures VALUES (1, 0, 'H', 'XY', 'CCW/CW', 1000, 0.012)"};
  for (const std::string& sql : v1) {
    const std::string cmd = GetParam() == Backend::sqlite
                                ? "sqlite3 '" + url_ + "' \"" + sql + "\""
                                : "psql -q '" + url_ + "' -c \"" + sql + "\"";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << sql;
  }
  EXPECT_EQ(open_store(url_)->schema_version(), latest_schema_version());
  // A new test beside the old one has its U.
  const fs::path json = dir_ / "new.json";
  { std::ofstream(json) << simulated_result(0.006, "2026-05-01", dir_).dump(); }
  Result r = run(circana("store " + json.string()), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto tests = open_store(url_)->tests("VMC-3", "");
  ASSERT_EQ(tests.size(), 2u);
  EXPECT_DOUBLE_EQ(tests[0].h_mm.value_or(0), 0.012);
  EXPECT_FALSE(tests[0].u_h_mm || tests[0].u_g_mm || tests[0].u_f_mm);
  ASSERT_EQ(tests[0].measures.size(), 1u);
  EXPECT_FALSE(tests[0].measures[0].u_mm);
  EXPECT_TRUE(tests[1].u_h_mm && tests[1].u_g_mm && tests[1].u_f_mm);

  r = run(circana("history --machine VMC-3 --json --limits H=0.013,G=0.020"), dir_);
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["tests"][0]["U_H"].is_null());
  EXPECT_TRUE(j["tests"][0]["measures"][0]["U"].is_null());
  // 12.0 um against 13.0 um: passes on the value alone (with a U of 1 um or more it would not
  // be decided), and the verdict says which rule it used.
  const auto& old = j["tests"][0]["verdicts"][0];
  EXPECT_EQ(old["decision"], "pass");
  EXPECT_EQ(old["rule"], kValueAloneRule);
  EXPECT_EQ(j["tests"][1]["verdicts"][0]["rule"], history::kDecisionRule);
  r = run(circana("history --machine VMC-3 --limits H=0.013,G=0.020"), dir_);
  EXPECT_NE(r.out.find("12.0 (no U)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(fmt::format("Judged on the value alone ({}): H, G, F of test(s) {} "
                                   "(stored without U)",
                                   kValueAloneRule, tests[0].id)),
            std::string::npos)
      << r.out;
  // A limit the old test breaches is named as judged on the value alone.
  r = run(circana("history --machine VMC-3 --limits H=0.011"), dir_);
  EXPECT_NE(r.out.find("FAIL: H 12.0 > 11.0 um (no U stored: value alone)"), std::string::npos)
      << r.out;
  // The trend says of the old test's H that its U is not known, not nothing.
  r = run(circana("history --machine VMC-3 --svg " + (dir_ / "trend.svg").string()), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string svg = slurp(dir_ / "trend.svg");
  EXPECT_NE(svg.find("H: 12.00 um, U not known (stored without it)"), std::string::npos) << svg;
}

// Exactly at the boundaries (binary-exact numbers, so value + U and value - U are exact):
// history's verdict of a stored test is circtest::decide of the analysis, which analyze
// --limits applies: value + U at the limit passes, value - U at the limit is not decided.
TEST_P(History, TheBoundariesAreDecidedAsTheAnalysisDecidesThem) {
  TestRecord r;
  r.machine = "VMC-3";
  r.tested_at = "2026-05-01";
  r.plane = "XY";
  r.channels = "x,y";
  r.trace_path = "exact.csv";
  r.result = nlohmann::json::object();
  r.h_mm = 0.015625;       // 2^-6
  r.u_h_mm = 0.001953125;  // 2^-9
  r.measures.push_back({"H", "XY", "CCW/CW", 1000.0, *r.h_mm, *r.u_h_mm});
  open_store(url_)->add(r);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"0.017578125", "pass"},                                 // value + U
      {"0.017578124", "not decided: within the uncertainty"},  // just below value + U
      {"0.013671875", "not decided: within the uncertainty"},  // value - U
      {"0.013671874", "fail"}};                                // just below value - U
  for (const auto& [limit, expected] : cases) {
    const Result res = run(circana("history --machine VMC-3 --json --limits H=" + limit), dir_);
    EXPECT_EQ(res.code, expected == "pass" ? 0 : 9) << limit << res.err;
    EXPECT_EQ(nlohmann::json::parse(res.out)["tests"][0]["verdicts"][0]["decision"], expected)
        << limit;
    EXPECT_EQ(decision_words(decide(*r.h_mm, *r.u_h_mm, std::stod(limit))), expected) << limit;
  }
}

// The history's rule is the analysis' rule, word for word.
TEST(HistoryLimits, TheDecisionRuleIsTheAnalysisRule) {
  EXPECT_STREQ(history::kDecisionRule, circtest::kDecisionRule);
}
