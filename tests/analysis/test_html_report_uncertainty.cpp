// circana report's verdicts by ISO 14253-1 with U (k = 2), and page 1's net changes over the
// apply rounds, checked in real headless Chromium (the fixture: html_report_fixture.hpp).
#include "html_report_fixture.hpp"

using namespace circtest_html_report_test;

// Verdicts by ISO 14253-1 against analyze --json of the same trace: a limit just above
// value + U passes, just below it is not decided, just below value - U fails (1e-9 mm off:
// two evaluations of a trace may differ in a double's last bits; the exact boundaries are
// tested on the history's verdicts, which the report uses: history_test_history). Any fail
// makes the report FAIL; a not decided without a fail makes it OPEN, never PASS.
TEST_F(HtmlReport, VerdictsFollowIso14253WithU) {
  const std::string xy = simtrace("xy.csv", "--backlash-x 0.020 --seed 7");
  CommandResult r = circana({"analyze", xy, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const double h = j["pairs"][0]["H"].get<double>(), u_h = j["U_H"].get<double>();
  double g = 0, f = 0;
  for (const auto& run : j["runs"]) {
    g = std::max(g, run["G"].get<double>());
    f = std::max({f, std::abs(run["F_max"].get<double>()), std::abs(run["F_min"].get<double>())});
  }
  const double u_g = j["runs"][0]["U_G"].get<double>(), u_f = j["runs"][0]["U_F"].get<double>();
  ASSERT_GT(f - u_f, 0.001) << "F must stand clear of its U for a failing limit";
  const double e = 1e-9;
  char limits[200];
  std::snprintf(limits, sizeof limits, "H=%.12g,G=%.12g,F=%.12g", h + u_h + e, g + u_g - e,
                f - u_f - e);
  const std::string html = (dir_ / "report.html").string();
  r = circana({"report", xy, "-o", html, "--limits", limits});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::string d = open(html).dom;
  auto result = [&d](const std::string& q) {
    const auto p = d.find("data-plane=\"XY\" data-quantity=\"" + q + "\"");
    if (p == std::string::npos) return std::string("no line");
    const std::string line = d.substr(p, d.find("</tr>", p) - p);
    const auto c = line.find("<td class=\"result ");
    return c == std::string::npos ? line : line.substr(c);
  };
  EXPECT_EQ(result("H"), "<td class=\"result PASS\">PASS</td>");
  EXPECT_EQ(result("G"), "<td class=\"result OPEN\">not decided: within the uncertainty</td>");
  EXPECT_EQ(result("F"), "<td class=\"result FAIL\">FAIL</td>");
  EXPECT_NE(d.find("data-verdict=\"FAIL\""), std::string::npos);
  // analyze --limits on the trace decides each the same.
  r = circana({"analyze", xy, "--json", "--limits", limits});
  EXPECT_EQ(r.exit_code, 9);
  const auto items = nlohmann::json::parse(r.out)["verdicts"]["items"];
  ASSERT_EQ(items.size(), 3u);
  EXPECT_EQ(items[0]["decision"], "pass");
  EXPECT_EQ(items[1]["decision"], "not decided: within the uncertainty");
  EXPECT_EQ(items[2]["decision"], "fail");

  // Without the failing F: open, not pass.
  std::snprintf(limits, sizeof limits, "H=%.12g,G=%.12g", h + u_h + e, g + u_g - e);
  r = circana({"report", xy, "-o", html, "--limits", limits});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  d = open(html).dom;
  EXPECT_NE(d.find("data-verdict=\"OPEN\">Verdict: not decided: within the uncertainty"),
            std::string::npos);
  // G just above value + U: every limit passes.
  std::snprintf(limits, sizeof limits, "H=%.12g,G=%.12g", h + u_h + e, g + u_g + e);
  r = circana({"report", xy, "-o", html, "--limits", limits});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  d = open(html).dom;
  EXPECT_NE(d.find("data-verdict=\"PASS\""), std::string::npos);
  EXPECT_EQ(d.find("--limits"), std::string::npos) << "a command-line option in the report";
}

// Two apply rounds' plans (circcomp plan --json, as plan_json writes them) give one net line
// per item on page 1: the backlash from its value before the first round to its value after
// the last, the compensation table once with its final values, the friction compensator as
// its pulse height and timing (not its five INI keys), a gain the second round undid not at
// all, the wiring once.
TEST_F(HtmlReport, ChangedBetweenTheTestsIsOneNetLinePerItem) {
  const std::string before = simtrace("before.csv", "--backlash-x 0.008 --seed 4");
  const std::string after = simtrace("after.csv", "--backlash-x 0.002 --seed 5");
  auto key = [](const char* section, const char* k, const char* b, const char* a,
                const std::string& words, const char* kind = "setting") {
    return nlohmann::json{{"file", "/m/mill.ini"},
                          {"section", section},
                          {"key", k},
                          {"before", b ? nlohmann::json(b) : nlohmann::json(nullptr)},
                          {"after", a ? nlohmann::json(a) : nlohmann::json(nullptr)},
                          {"words", words},
                          {"kind", kind},
                          {"effective", true}};
  };
  auto table = [](const std::string& words) {
    return nlohmann::json{{"file", "/m/xcomp.txt"}, {"section", nullptr}, {"key", nullptr},
                          {"before", nullptr},      {"after", nullptr},   {"words", words},
                          {"kind", "setting"},      {"effective", true}};
  };
  const nlohmann::json round1 = {
      {"schema", "circtest.plan/1"},
      {"changes",
       {key("JOINT_0", "BACKLASH", nullptr, "0.0102", "X backlash 0 → 10.2 µm"),
        key("JOINT_0", "FF1", "0", "1.0", "FF1 X 0 → 1.0"),
        table("X compensation table xcomp.txt created: backlash 0 → 10.2 µm, scale correction "
              "0 → 35.0 ppm"),
        key("FRICTION_X", "AMPLITUDE", nullptr, "0.003", "[FRICTION_X] AMPLITUDE (none) → 0.003"),
        key("FRICTION_X", "AMPLITUDE_MAX", nullptr, "0.006",
            "[FRICTION_X] AMPLITUDE_MAX (none) → 0.006"),
        key("FRICTION_X", "DECAY_MS", nullptr, "25", "[FRICTION_X] DECAY_MS (none) → 25"),
        key("FRICTION_X", "RISE_MS", nullptr, "12", "[FRICTION_X] RISE_MS (none) → 12"),
        key("FRICTION_X", "SPIKE_MM", nullptr, "0.003", "[FRICTION_X] SPIKE_MM (none) → 0.003"),
        key("HAL", "HALFILE", nullptr, "circtest-fric.hal", "HAL file circtest-fric.hal added",
            "wiring")}},
      {"advice", {"first advice"}}};
  const nlohmann::json round2 = {
      {"schema", "circtest.plan/1"},
      {"changes",
       {key("JOINT_0", "BACKLASH", "0.0102", "0.0105", "X backlash 10.2 → 10.5 µm"),
        key("JOINT_0", "FF1", "1.0", "0", "FF1 X 1.0 → 0"),
        table("X compensation table xcomp.txt changed: backlash 10.2 → 10.5 µm, scale correction "
              "35.0 → 36.1 ppm"),
        key("FRICTION_X", "AMPLITUDE", "0.003", "0.0035", "[FRICTION_X] AMPLITUDE 0.003 → 0.0035"),
        key("FRICTION_X", "DECAY_MS", "25", "30", "[FRICTION_X] DECAY_MS 25 → 30")}},
      {"advice", {"servo mismatch: X lags Y by 1.08 ms"}}};
  const std::string p1 = (dir_ / "plan1.json").string(), p2 = (dir_ / "plan2.json").string();
  circtest::testing::spit(p1, round1.dump());
  circtest::testing::spit(p2, round2.dump());
  const std::string html = (dir_ / "report.html").string();
  const CommandResult r =
      circana({"report", after, before, "-o", html, "--changes", p1, "--changes", p2});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string d = open(html).dom;
  const auto p = d.find("<ul class=\"changes\">");
  ASSERT_NE(p, std::string::npos);
  const std::string list = d.substr(p, d.find("</ul>", p) - p);
  std::vector<std::string> lines;
  for (auto q = list.find("<li>"); q != std::string::npos; q = list.find("<li>", q + 1)) {
    lines.push_back(list.substr(q + 4, list.find("</li>", q) - q - 4));
  }
  EXPECT_EQ(lines, (std::vector<std::string>{
                       "X backlash 0 → 10.5 µm",
                       "X compensation table xcomp.txt created: backlash 0 → 10.5 µm, scale "
                       "correction 0 → 36.1 ppm",
                       "X friction compensation added: pulse height 0.0035 (machine units) at "
                       "each reversal, rising over 12 ms, decaying over 30 ms"}));
  EXPECT_EQ(count(d, "circtest-fric.hal added"), 1u);
  EXPECT_EQ(d.find("AMPLITUDE"), std::string::npos) << "an INI key on the customer's page";
  EXPECT_NE(d.find("servo mismatch: X lags Y by 1.08 ms"), std::string::npos);
  EXPECT_EQ(d.find("first advice"), std::string::npos) << "the last plan's advice only";
}

// A before/after report: page 1 gives the before test's H, G and F their U (k = 2) beside
// them, as analyze --json states it for the before trace; the plane page names both tests'
// U; the plot's legend carries each H, G and F with its U.
TEST_F(HtmlReport, BeforeFiguresCarryTheirU) {
  const std::string before = simtrace("before.csv", "--backlash-x 0.020 --seed 4");
  const std::string after = simtrace("after.csv", "--backlash-x 0.002 --seed 5");
  CommandResult r = circana({"analyze", before, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const std::string html = (dir_ / "report.html").string();
  r = circana({"report", after, before, "-o", html});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string d = open(html).dom;
  auto line = [&d](const std::string& q) {
    const auto p = d.find("data-plane=\"XY\" data-quantity=\"" + q + "\"");
    if (p == std::string::npos) return std::string("no line");
    return d.substr(p, d.find("</tr>", p) - p);
  };
  for (const auto& [q, u] : {std::pair{"H", j["U_H"].get<double>()},
                             {"G", j["runs"][0]["U_G"].get<double>()},
                             {"F", j["runs"][0]["U_F"].get<double>()}}) {
    const std::string l = line(q);
    const auto cell = l.find("<td class=\"num u before\">");
    ASSERT_NE(cell, std::string::npos) << q << ": " << l;
    const auto mm = l.find("data-mm=\"", cell);
    ASSERT_LT(mm, l.find("</td>", cell)) << q << ": no U beside the before value: " << l;
    EXPECT_NEAR(std::stod(l.substr(mm + 9)), u, 1e-12) << q << ": " << l;
  }
  EXPECT_NE(d.find("of each value of the before test: H"), std::string::npos);
  const auto legend = d.find("before: run 1 CCW");
  ASSERT_NE(legend, std::string::npos);
  char u_g[40];
  std::snprintf(u_g, sizeof u_g, "U = %.1f µm", j["runs"][0]["U_G"].get<double>() * 1000.0);
  const std::string legend_line = d.substr(legend, d.find("</li>", legend) - legend);
  EXPECT_NE(legend_line.find(u_g), std::string::npos) << legend_line;
}
