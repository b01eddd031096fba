// circana report opened in real headless Chromium (label report): the page loads with no
// console message and references nothing outside itself, is not blank, its DOM holds the
// numbers of circana analyze --json and of the simulator's injected errors, no element is
// wider than A4 portrait at 96 dpi, and printing gives the hand-over with the verdict on page
// 1, then exactly one A4 page per plane, then the appendix. Without chromium every test here
// is skipped with a message (ctest shows it as skipped), never passed.
#include "html_report_fixture.hpp"

using namespace circtest_html_report_test;

// The detectors themselves: a page with a script error, an external image and an element
// wider than A4 is caught; the measuring script is gone from the DOM, the page's own kept.
TEST_F(HtmlReport, TheConsoleAndReferenceChecksCatchABadPage) {
  const std::string bad = (dir_ / "bad.html").string();
  circtest::testing::spit(bad,
                          "<!DOCTYPE html><html><body><p>x</p><img "
                          "src=\"http://example.invalid/x.png\"><script>undefinedFn();</script>"
                          "<div style=\"width: 900px\">wide</div></body></html>\n");
  const Opened page = open(bad);
  const std::string& d = page.dom;
  EXPECT_NE(console_messages().find("undefinedFn"), std::string::npos) << console_;
  EXPECT_NE(d.find("src="), std::string::npos);
  EXPECT_EQ(count(d, "<script"), 1u) << d;
  EXPECT_NE(d.find("<script>undefinedFn();</script>"), std::string::npos) << d;
  EXPECT_EQ(d.find("data-widest"), std::string::npos) << d;
  EXPECT_NE(d.find("<body><p>x</p>"), std::string::npos) << d;
  EXPECT_GE(page.widest_px, 900.0) << page.widest;
}

TEST_F(HtmlReport, ThreePlanesPrintOnOneA4PageEachAndTheDomHoldsTheResults) {
  // Injected errors are the truth: X backlash alone makes H of the XY test equal to it.
  const std::string xy = simtrace("xy.csv", "--backlash-x 0.005 --seed 1");
  const std::string yz = simtrace("yz.csv", "--plane YZ --backlash-y 0.003 --seed 2");
  const std::string zx = simtrace("zx.csv", "--plane ZX --backlash-x 0.004 --seed 3");
  const std::string html = (dir_ / "report.html").string();
  CommandResult r = circana({"report", xy, "--trace", yz, "--trace", zx, "-o", html, "--machine",
                             "VMC-3", "--operator", "A. Sato"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("3 plane page(s) (XY, YZ, ZX)"), std::string::npos) << r.out;

  const std::string pdf = (dir_ / "report.pdf").string();
  const std::string shot = (dir_ / "report.png").string();
  const Opened page = open(html, pdf, shot);
  const std::string& d = page.dom;
  EXPECT_EQ(console_messages(), "") << "the page logged to the console";
  // Self-contained: nothing loaded from anywhere (the only URL is the SVG namespace).
  for (const char* ref : {"src=", "href=", "<link", "<script", "@import", "url("}) {
    EXPECT_EQ(d.find(ref), std::string::npos) << ref;
  }
  EXPECT_EQ(count(d, "http"), count(d, "http://www.w3.org/2000/svg"));
  EXPECT_EQ(count(d, "<section class=\"plane\""), 3u);
  // The hand-over: who tested which machine; no limits given, so nothing is judged.
  EXPECT_NE(d.find("A. Sato"), std::string::npos);
  EXPECT_NE(d.find("VMC-3"), std::string::npos);
  EXPECT_NE(d.find("data-verdict=\"NONE\""), std::string::npos);
  EXPECT_EQ(count(d, "class=\"verdict-line\""), 9u);  // H, G, F of each plane
  for (const char* hint : {"--db", "--limits", "--changes", "--machine"}) {
    EXPECT_EQ(d.find(hint), std::string::npos) << "a command-line hint in the report: " << hint;
  }
  EXPECT_EQ(count(d, "<td class=\"result NONE\">no limit set</td>"), 9u);
  // Conditions not recorded: one grey line a plane, never red on every line.
  EXPECT_EQ(count(d, "class=\"grey unrecorded\">Not recorded: "), 3u);
  for (auto p = d.find("<table class=\"conditions\""); p != std::string::npos;
       p = d.find("<table class=\"conditions\"", p + 1)) {
    const std::string table = d.substr(p, d.find("</table>", p) - p);
    EXPECT_EQ(table.find("not recorded"), std::string::npos) << table;
  }
  EXPECT_NE(d.find("Conditions of the test (clause 4.4)"), std::string::npos);

  // Every H, G, F of analyze --json is in the DOM, exactly (data-mm) and as read (um).
  const std::vector<std::pair<std::string, double>> truth = {{xy, 0.005}, {yz, 0.003}, {zx, 0.004}};
  for (const auto& [trace, backlash] : truth) {
    r = circana({"analyze", trace, "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    ASSERT_EQ(j["pairs"].size(), 1u) << trace;
    const double h = j["pairs"][0]["H"].get<double>();
    EXPECT_NEAR(h, backlash, 0.0005) << trace;
    char um[32];
    std::snprintf(um, sizeof um, "%.1f", h * 1000.0);
    EXPECT_NE(d.find("data-mm=\"" + mm(h) + "\">" + um + "</span>"), std::string::npos)
        << trace << " H " << mm(h);
    ASSERT_EQ(j["runs"].size(), 2u);
    for (const auto& run : j["runs"]) {
      for (const char* k : {"G", "F_max", "F_min"}) {
        EXPECT_NE(d.find("data-mm=\"" + mm(run[k].get<double>()) + "\""), std::string::npos)
            << trace << " " << k;
      }
    }
    // U (k = 2) of H, G and F beside each on page 1, as analyze --json states it, and the same
    // in the plane's line of U and in the budget's expanded rows.
    const std::string plane = j["plane"].get<std::string>();
    const std::map<std::string, double> u = {{"H", j["U_H"].get<double>()},
                                             {"G", j["runs"][0]["U_G"].get<double>()},
                                             {"F", j["runs"][0]["U_F"].get<double>()}};
    for (const auto& [q, u_mm] : u) {
      const auto p = d.find("data-plane=\"" + plane + "\" data-quantity=\"" + q + "\"");
      ASSERT_NE(p, std::string::npos) << plane << q;
      const std::string line = d.substr(p, d.find("</tr>", p) - p);
      char cell[160];
      std::snprintf(cell, sizeof cell,
                    "<td class=\"num u\"><span class=\"u\" data-mm=\"%s\">%.1f</span> µm</td>",
                    mm(u_mm).c_str(), u_mm * 1000.0);
      EXPECT_NE(line.find(cell), std::string::npos) << line << "\n" << cell;
      const auto e = d.find("<tr class=\"expanded\" data-quantity=\"" + q + "\"");
      ASSERT_NE(e, std::string::npos) << q;
      EXPECT_NE(d.substr(e, d.find("</tr>", e) - e).find("data-mm=\"" + mm(u_mm) + "\""),
                std::string::npos)
          << plane << " U_" << q << " in the budget";
    }
    const auto up = d.find("<section class=\"plane\" data-plane=\"" + plane + "\"");
    const std::string u_line = d.substr(d.find("<p class=\"uncertainty\">", up));
    EXPECT_NE(u_line.substr(0, u_line.find("</p>")).find("data-mm=\"" + mm(u.at("G")) + "\""),
              std::string::npos)
        << plane;
  }
  // One budget table for the three alike tests, a column of each.
  EXPECT_EQ(count(d, "<table class=\"budget\">"), 1u);
  EXPECT_NE(d.find("<th class=\"num\">XY</th><th class=\"num\">YZ</th><th class=\"num\">ZX</th>"),
            std::string::npos);
  // The diagnosis ran: its ranked contributions are bars.
  r = circana({"diagnose", xy, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto diag = nlohmann::json::parse(r.out);
  ASSERT_FALSE(diag["contributions"].empty());
  EXPECT_NE(d.find("data-mm=\"" + mm(diag["contributions"][0]["G_mm"].get<double>()) + "\""),
            std::string::npos);
  EXPECT_GE(count(d, "class=\"contribution\""), diag["contributions"].size());

  // Summary, one page per plane, appendix.
  EXPECT_EQ(page.pages, 6);
  EXPECT_NE(pdf_page_text(pdf, 1).find("Verdict: no limit set"), std::string::npos);
  EXPECT_NE(pdf_page_text(pdf, 2).find("Plane XY: the measurement"), std::string::npos);
  EXPECT_NE(pdf_page_text(pdf, 3).find("Plane YZ: the measurement"), std::string::npos);
  EXPECT_NE(pdf_page_text(pdf, 4).find("Plane ZX: the measurement"), std::string::npos);
  EXPECT_NE(pdf_page_text(pdf, 5).find("Appendix: the uncertainty of H, G and F"),
            std::string::npos);
  EXPECT_NE(pdf_page_text(pdf, 6).find("Appendix: for the service engineer"), std::string::npos);
  EXPECT_LE(page.widest_px, 794.0) << page.widest;

  // Not blank: the screenshot of the report is far richer than one of an empty page in a
  // window of the same size.
  const std::string empty = (dir_ / "empty.html").string();
  circtest::testing::spit(empty, "<!DOCTYPE html><html><body></body></html>\n");
  ASSERT_EQ(chromium({"--screenshot=" + (dir_ / "empty.png").string(), "--window-size=794,1123",
                      "file://" + empty})
                .exit_code,
            0);
  const auto blank = fs::file_size(dir_ / "empty.png");
  const auto size = fs::file_size(shot);
  EXPECT_GT(size, 10 * blank) << "screenshot " << size << " bytes, empty page " << blank;
}

TEST_F(HtmlReport, BeforeAfterDiagnosisFileAndTrend) {
  const std::string before = simtrace("before.csv", "--backlash-x 0.008 --seed 4");
  const std::string after = simtrace("after.csv", "--backlash-x 0.002 --seed 5");
  // The trend: three tests of this machine in an SQLite history.
  const std::string db = (dir_ / "history.sqlite").string();
  for (const auto& [b, date] : std::vector<std::pair<std::string, std::string>>{
           {"0.006", "2026-01-05"}, {"0.008", "2026-03-02"}}) {
    const std::string t = simtrace("h" + date + ".csv", "--backlash-x " + b);
    const CommandResult s =
        circana({"store", t, "--db", db, "--machine", "VMC-3", "--notes", "dated " + date});
    ASSERT_EQ(s.exit_code, 0) << s.err;
  }
  ASSERT_EQ(circana({"store", after, "--db", db, "--machine", "VMC-3"}).exit_code, 0);
  // A diagnosis from a file: its first contribution marked so that it cannot be recomputed.
  CommandResult r = circana({"diagnose", after, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto diag = nlohmann::json::parse(r.out);
  ASSERT_FALSE(diag["contributions"].empty());
  diag["contributions"][0]["G_mm"] = 0.0123456;
  const std::string diag_path = (dir_ / "diag.json").string();
  circtest::testing::spit(diag_path, diag.dump());

  const std::string html = (dir_ / "report.html").string();
  r = circana({"report", after, before, "-o", html, "--machine", "VMC-3", "--db", db, "--diagnosis",
               diag_path, "--scale-um-per-div", "2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Opened page = open(html, (dir_ / "report.pdf").string());
  const std::string& d = page.dom;
  EXPECT_EQ(console_messages(), "");
  // Before and after: both traces drawn (the before dashed), H of both in the table.
  EXPECT_NE(d.find("<td>" + before + "</td>"), std::string::npos);  // in the appendix
  EXPECT_GE(count(d, "stroke-dasharray=\"5,3\""), 2u);
  EXPECT_NE(d.find("1 division = 2 µm (fixed)"), std::string::npos);
  const auto h_of = [&](const std::string& trace) {
    const CommandResult a = circana({"analyze", trace, "--json"});
    return nlohmann::json::parse(a.out)["pairs"][0]["H"].get<double>();
  };
  const double h_after = h_of(after), h_before = h_of(before);
  EXPECT_NEAR(h_after, 0.002, 0.0005);
  EXPECT_NEAR(h_before, 0.008, 0.0005);
  char cells[160];
  std::snprintf(cells, sizeof cells,
                "<td class=\"num before\">%.1f</td><td class=\"num change\">%+.1f</td>",
                h_before * 1000.0, (h_after - h_before) * 1000.0);
  EXPECT_NE(d.find(cells), std::string::npos) << cells;
  // The diagnosis of the file, not one made here.
  EXPECT_NE(d.find("data-mm=\"0.0123456\""), std::string::npos);
  // The trend: a panel per quantity, the three stored tests as points of H.
  const auto h_panel = d.find("data-quantity=\"H\"");
  ASSERT_NE(h_panel, std::string::npos);
  const std::string panel = d.substr(h_panel, d.find("</g>", h_panel) - h_panel);
  EXPECT_EQ(count(panel, "class=\"point\""), 3u);
  EXPECT_EQ(page.pages, 4);
}

// The hand-over of a before/after visit: the verdict against a limits file, what circcomp
// changed in plain words, the signature block, all on printed page 1; the diagnosis of both
// tests on the plane's page; µm and µrad, never "um"; nothing wider than A4.
TEST_F(HtmlReport, HandOverPageHoldsVerdictChangesAndSignatures) {
  const std::string before = simtrace("before.csv", "--backlash-x 0.008 --seed 4");
  const std::string after = simtrace("after.csv", "--backlash-x 0.002 --seed 5");
  const std::string limits = (dir_ / "shop.limits").string();
  // H passes after (2 um + U 1.4 um), F at 0.1 um is within its U (not decided), G is judged
  // against a wide limit.
  circtest::testing::spit(limits, "# the shop's limits\nH=0.004, G=0.05\n\nF=0.0001  # tight\n");
  const std::string plan = (dir_ / "plan.json").string();
  circtest::testing::spit(plan,
                          R"({"schema": "circtest.plan/1", "changes": [
           {"words": "X backlash 0 → 10.2 µm"},
           {"words": "squareness XY correction 0 → 100.0 µrad"},
           {"words": "FF1 X 0 → 1.0"}],
         "advice": ["servo mismatch: X lags Y by 1.08 ms"]})");
  const std::string html = (dir_ / "report.html").string();
  CommandResult r = circana({"report", after, before, "-o", html, "--machine", "VMC-3",
                             "--limits-file", limits, "--changes", plan, "--tested-by", "A. Sato",
                             "--accepted-by", "B. Kunde", "--instrument", "grid encoder KGM 182"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string pdf = (dir_ / "report.pdf").string();
  const Opened page = open(html, pdf);
  const std::string& d = page.dom;
  EXPECT_EQ(console_messages(), "");

  auto analyzed = [&](const std::string& trace) {
    const CommandResult a =
        circana({"analyze", trace, "--json", "--instrument", "grid encoder KGM 182"});
    EXPECT_EQ(a.exit_code, 0) << a.err;
    return nlohmann::json::parse(a.out);
  };
  const auto ja = analyzed(after), jb = analyzed(before);
  auto row = [&](const std::string& q) {
    const auto p = d.find("data-plane=\"XY\" data-quantity=\"" + q + "\"");
    EXPECT_NE(p, std::string::npos) << q;
    return p == std::string::npos ? std::string() : d.substr(p, d.find("</tr>", p) - p);
  };
  char cells[400];
  const double h_after = ja["pairs"][0]["H"].get<double>() * 1000.0;
  const double h_before = jb["pairs"][0]["H"].get<double>() * 1000.0;
  const double u_h = ja["U_H"].get<double>(), u_h_before = jb["U_H"].get<double>();
  std::snprintf(cells, sizeof cells,
                "<td class=\"num\">%.1f µm</td>"
                "<td class=\"num u before\"><span class=\"u\" data-mm=\"%s\">%.1f</span> µm</td>"
                "<td class=\"num\">%.1f µm</td>"
                "<td class=\"num u\"><span class=\"u\" data-mm=\"%s\">%.1f</span> µm</td>"
                "<td class=\"num\">4.0 µm</td><td class=\"result PASS\">PASS</td>",
                h_before, mm(u_h_before).c_str(), u_h_before * 1000.0, h_after, mm(u_h).c_str(),
                u_h * 1000.0);
  EXPECT_NE(row("H").find(cells), std::string::npos) << row("H") << "\n" << cells;
  ASSERT_LE(h_after + u_h * 1000.0, 4.0) << "the case is no pass by ISO 14253-1";
  const double f_after = ja["runs"][0]["F_max"].get<double>(),
               u_f = ja["runs"][0]["U_F"].get<double>();
  ASSERT_LT(f_after - u_f, 0.0001) << "the case is no undecided F";
  EXPECT_NE(row("F").find("<td class=\"num\">0.1 µm</td><td class=\"result OPEN\">not decided: "
                          "within the uncertainty</td>"),
            std::string::npos)
      << row("F");
  EXPECT_NE(row("G").find("<td class=\"num\">50.0 µm</td><td class=\"result PASS\">PASS</td>"),
            std::string::npos)
      << row("G");
  // Not decided is not shown to conform: the overall verdict is open, the rule stated.
  EXPECT_NE(d.find("data-verdict=\"OPEN\""), std::string::npos);
  EXPECT_NE(d.find("Against the agreed acceptance limits (H 4.0 µm, G 50.0 µm, F 0.1 µm)"),
            std::string::npos);
  EXPECT_NE(d.find("Decision rule (ISO 14253-1): pass when value + U ≤ limit, fail when value − U "
                   "&gt; limit"),
            std::string::npos);
  EXPECT_EQ(d.find("--limits"), std::string::npos) << "a command-line option on a customer's page";
  EXPECT_FALSE(std::regex_search(d, std::regex(R"(\b(um|urad)\b)"))) << "ASCII units left";

  // The diagnosis of both tests, each source with its share of G.
  for (const auto& trace : {before, after}) {
    r = circana({"diagnose", trace, "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto diag = nlohmann::json::parse(r.out);
    ASSERT_FALSE(diag["contributions"].empty()) << trace;
    EXPECT_NE(d.find("data-mm=\"" + mm(diag["contributions"][0]["share_mm"].get<double>()) + "\""),
              std::string::npos)
        << trace;
  }

  EXPECT_EQ(page.pages, 4);
  const std::string page1 = pdf_page_text(pdf, 1);
  for (const char* text : {"Verdict: not decided: within the uncertainty", "U (k = 2)", "VMC-3",
                           "grid encoder KGM 182", "XY", "1000 mm/min", "X backlash 0 → 10.2 µm",
                           "squareness XY correction 0 → 100.0 µrad", "FF1 X 0 → 1.0",
                           "servo mismatch: X lags Y by 1.08 ms", "Tested by", "A. Sato",
                           "Accepted by", "B. Kunde", "Signature", "Date"}) {
    EXPECT_NE(page1.find(text), std::string::npos) << text << "\n" << page1;
  }
  EXPECT_NE(pdf_page_text(pdf, 2).find("Plane XY"), std::string::npos);
  const CommandResult sum = run_command({"/usr/bin/sha256sum", after});
  ASSERT_EQ(sum.exit_code, 0);
  EXPECT_NE(pdf_page_text(pdf, 4).find(sum.out.substr(0, 64)), std::string::npos)
      << "the appendix holds the trace's SHA-256";
  EXPECT_LE(page.widest_px, 794.0) << page.widest;
}

// Any report, above all the one the README's demo writes (out/report.html): named by
// CIRCTEST_REPORT_HTML (absolute path) after the demo ran, checked for what the hand-over
// needs: nothing wider than A4, the verdict on printed page 1, one page per plane, then the
// appendix, µm and µrad written as such. Skipped with a message when the variable is unset.
TEST_F(HtmlReport, AGivenReportFitsA4WithTheVerdictOnPage1) {
  const char* given = std::getenv("CIRCTEST_REPORT_HTML");
  if (!given || !*given) {
    GTEST_SKIP() << "CIRCTEST_REPORT_HTML is not set: no report of a demo run to check";
  }
  const std::string html = fs::absolute(given).string();
  ASSERT_TRUE(fs::is_regular_file(html)) << html;
  const std::string pdf = (dir_ / "given.pdf").string();
  const Opened opened = open(html, pdf);
  const std::string& d = opened.dom;
  EXPECT_EQ(console_messages(), "");
  std::vector<std::string> planes;
  static const std::regex plane(R"re(<section class="plane" data-plane="(XY|YZ|ZX)")re");
  for (std::sregex_iterator it(d.begin(), d.end(), plane), end; it != end; ++it) {
    planes.push_back((*it)[1]);
  }
  ASSERT_FALSE(planes.empty()) << "no plane page: not a circana report";
  // Page 1 the verdict; each plane's page in order, one A4 page each; then the budget
  // appendix and the appendix for the service engineer.
  const int pages = opened.pages;
  EXPECT_EQ(pages, static_cast<int>(planes.size()) + 3);
  EXPECT_NE(pdf_page_text(pdf, 1).find("Verdict: "), std::string::npos);
  int page = 2;
  for (const std::string& p : planes) {
    EXPECT_NE(pdf_page_text(pdf, page).find("Plane " + p + ": "), std::string::npos) << p;
    ++page;
  }
  EXPECT_NE(pdf_page_text(pdf, page).find("Appendix: the uncertainty"), std::string::npos)
      << "page " << page;
  EXPECT_NE(pdf_page_text(pdf, pages).find("Appendix: for the service engineer"),
            std::string::npos);
  EXPECT_FALSE(std::regex_search(d, std::regex(R"(\b(um|urad)\b)"))) << "ASCII units left";
  EXPECT_LE(opened.widest_px, 794.0) << opened.widest;
}

// The fullest plane page a visit makes: before and after with four runs each (two feeds), every
// error source of the demo's machine in both diagnoses, the program's conditions recorded
// (as circgen writes them) and limits: one A4 page, the footer on it, the appendix next.
TEST_F(HtmlReport, AFullPlanePageIsOneA4Page) {
  const std::string errors =
      "--set XY --feeds 500,1000 --d 100 --period 0.001 --cyclic-y 0.002 --pitch-y 5 "
      "--spike-ms-x 15 --spike-ms-y 15 ";
  const std::vector<std::pair<std::string, std::string>> tests{
      {"before.csv", errors + "--backlash-x 0.010 --scale-x 50e-6 --squareness 100e-6 "
                              "--spike-x 0.010 --spike-y 0.009 --kv-x 30 --kv-y 31 --seed 1"},
      {"after.csv", errors + "--backlash-x 0.001 --spike-x 0.004 --spike-y 0.0014 --seed 2"}};
  std::vector<std::string> report{"report"};
  std::vector<std::string> diagnoses;
  for (const auto& [name, args] : tests) {
    const std::string trace = simtrace(name, args);
    std::string recorded;
    for (const char* line :
         {"machine: sim-servo (simulated)", "operator: circtest demo", "temperature_air_C: 20.4",
          "compensation: backlash comp X 0.010, pid FF1 0", "other_axes: Z clamped at 100 mm",
          "arc_deg: 360", "start_deg: 0", "lead_deg: 10", "dwell_s: 0",
          "motion_mode: G64 P0 exact path (G61 during the runs)",
          "feed_override: off during the runs (M50 P0)", "work_offset: G54",
          "tool_length_offset: none (G49)"}) {
      recorded += std::string("# ") + line + "\n";
    }
    circtest::testing::spit(trace, recorded + slurp(trace));
    const CommandResult d = circana({"diagnose", trace, "--json"});
    ASSERT_EQ(d.exit_code, 0) << d.err;
    const std::string json = (dir_ / (name + ".diagnosis.json")).string();
    circtest::testing::spit(json, d.out);
    report.push_back(trace);
    diagnoses.insert(diagnoses.end(), {"--diagnosis", json});
  }
  std::swap(report[1], report[2]);  // after, then before
  const std::string html = (dir_ / "report.html").string();
  report.insert(report.end(), {"-o", html, "--limits", "H=0.012,G=0.020,F=0.015"});
  report.insert(report.end(), diagnoses.begin(), diagnoses.end());
  const CommandResult r = circana(report);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string pdf = (dir_ / "report.pdf").string();
  const Opened page = open(html, pdf);
  ASSERT_GE(count(page.dom, "<tr class=\"contribution\">"), 7u) << "the sources of both tests";
  EXPECT_EQ(page.pages, 4);
  const std::string plane = pdf_page_text(pdf, 2);
  EXPECT_NE(plane.find("Plane XY: the measurement, before and after"), std::string::npos);
  EXPECT_NE(plane.find("Values in µm"), std::string::npos) << "the page's footer on the page";
  EXPECT_NE(pdf_page_text(pdf, 3).find("Appendix: the uncertainty"), std::string::npos);
  // The residual's share is of each test's measured G (the largest least-squares G of analyze
  // --json), shown with that test's U_G (k = 2).
  for (const std::string& trace : {report[1], report[2]}) {
    const CommandResult a = circana({"analyze", trace, "--json"});
    ASSERT_EQ(a.exit_code, 0) << a.err;
    const auto j = nlohmann::json::parse(a.out);
    double g_lsc = 0.0;
    for (const auto& run : j["runs"]) g_lsc = std::max(g_lsc, run["G_lsc"].get<double>());
    char shown[200];
    std::snprintf(shown, sizeof shown,
                  "of the measured G <span data-mm=\"%.12g\">%.1f</span> µm, U = <span "
                  "class=\"u\" data-mm=\"%.12g\">",
                  g_lsc, g_lsc * 1000.0, j["runs"][0]["U_G"].get<double>());
    EXPECT_NE(page.dom.find(shown), std::string::npos) << trace << ": " << shown;
  }
}

// Backlash and squareness limits are judged from the plane's diagnosis, as circana history
// judges them; a diagnosis without the value is not measured, which does not pass.
TEST_F(HtmlReport, BacklashAndSquarenessLimitsAreJudgedFromTheDiagnosis) {
  const std::string xy = simtrace("xy.csv", "--backlash-x 0.005 --seed 6");
  const std::string html = (dir_ / "report.html").string();
  CommandResult r = circana({"report", xy, "-o", html, "--limits", "backlash=0.004,squareness=50"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::string d = open(html).dom;
  r = circana({"diagnose", xy, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto diag = nlohmann::json::parse(r.out);
  const double b_um = diag["backlash_mm"]["X"].get<double>() * 1000.0;
  ASSERT_NEAR(b_um, 5.0, 0.5);
  auto row = [&d](const std::string& q) {
    const auto p = d.find("data-plane=\"XY\" data-quantity=\"" + q + "\"");
    return p == std::string::npos ? std::string() : d.substr(p, d.find("</tr>", p) - p);
  };
  char cells[160];
  std::snprintf(cells, sizeof cells,
                "<td class=\"num\">%.1f µm</td><td class=\"num u\">–</td><td class=\"num\">4.0 "
                "µm</td><td class=\"result FAIL\">FAIL</td>",
                b_um);
  EXPECT_NE(row("backlash").find(cells), std::string::npos) << row("backlash") << "\n" << cells;
  EXPECT_NE(row("squareness").find("<td class=\"num\">50.0 µrad</td><td class=\"result PASS\">"),
            std::string::npos)
      << row("squareness");
  // H, G, F have no limit here: listed, not judged.
  EXPECT_NE(row("H").find("no limit set"), std::string::npos);
  EXPECT_NE(d.find("data-verdict=\"FAIL\""), std::string::npos);
  // Judged without U, and the page says so.
  EXPECT_NE(d.find("Without U (backlash, squareness): the value alone against the limit."),
            std::string::npos);

  // A diagnosis that does not state the squareness: that limit cannot pass.
  diag["squareness_urad"] = nullptr;
  const std::string diag_path = (dir_ / "diag.json").string();
  circtest::testing::spit(diag_path, diag.dump());
  r = circana({"report", xy, "-o", html, "--limits", "squareness=50", "--diagnosis", diag_path});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  d = open(html).dom;
  EXPECT_NE(row("squareness").find("<td class=\"result FAIL\">FAIL (not measured)</td>"),
            std::string::npos)
      << row("squareness");
  EXPECT_EQ(row("backlash"), "") << "no backlash limit, no backlash line";
}

// Bad requests: one clear line, the documented exit code, no file left behind.
TEST_F(HtmlReport, BadRequests) {
  const std::string xy = simtrace("xy.csv", "--backlash-x 0.005");
  const std::string yz = simtrace("yz.csv", "--plane YZ");
  const std::string out = (dir_ / "r.html").string();
  auto expect = [&](const std::vector<std::string>& args, int code, const std::string& message) {
    const CommandResult r = circana(args);
    EXPECT_EQ(r.exit_code, code) << circtest::join(args, " ") << "\n" << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
    EXPECT_EQ(count(r.err, "\n"), 1u) << r.err;
    EXPECT_FALSE(fs::exists(out));
  };
  expect({"report", xy, yz, "-o", out}, 5, "a before trace of plane YZ, but the report's traces");
  expect({"report", xy, "--trace", xy, "-o", out}, 5, "plane XY twice in one report");
  expect({"report", xy}, 2, "output");
  expect({"report", xy, "-o", out, "--json"}, 2, "--json: not for circana report");
  const std::string junk = (dir_ / "junk.json").string();
  circtest::testing::spit(junk, "{\"schema\": \"circtest.evaluation/1\"}");
  expect({"report", xy, "-o", out, "--diagnosis", junk}, 4,
         junk + ": expected a circtest.diagnosis/1 document");
  const std::string newer = (dir_ / "newer.json").string();
  circtest::testing::spit(newer, "{\"schema\": \"circtest.diagnosis/1\", \"version\": \"2.0\"}");
  expect({"report", xy, "-o", out, "--diagnosis", newer}, 4,
         newer + ": \"version\": 2.0 is newer than this circana reads (1.x)");
  // Limits: the history's format, in an option or a file; a bad item names the file's line.
  expect({"report", xy, "-o", out, "--limits", "H=0.01,Q=1"}, 2,
         "--limits: expected NAME=VALUE,... with NAME one of H, G, F");
  const std::string lim = (dir_ / "shop.limits").string();
  circtest::testing::spit(lim, "H=0.01\n# G next\nG=abc\n");
  expect({"report", xy, "-o", out, "--limits-file", lim}, 4, lim + ":3: limit G");
  circtest::testing::spit(lim, "H=0.01\nG=0.02,H=0.02\n");
  expect({"report", xy, "-o", out, "--limits-file", lim}, 4,
         lim + ":2: H is given twice (also on line 1)");
  circtest::testing::spit(lim, "# nothing yet\n\n");
  expect({"report", xy, "-o", out, "--limits-file", lim}, 4, lim + ": no limit in the file");
  expect({"report", xy, "-o", out, "--limits-file", (dir_ / "none.limits").string()}, 3,
         "none.limits");
  // As common editors write it: a byte-order mark, CRLF and a lone CR, blank lines, blanks.
  circtest::testing::spit(lim,
                          "\xEF\xBB\xBFH=0.01 \r\n\r\n  G = 0.02\t\r\nF=0.1\rbacklash=0.004\r\n");
  {
    const CommandResult r = circana({"report", xy, "-o", out, "--limits-file", lim});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::string html = circtest::testing::slurp(out);
    EXPECT_NE(html.find("Against the agreed acceptance limits (H 10.0 µm, G 20.0 µm, F 100.0 µm, "
                        "backlash 4.0 µm)"),
              std::string::npos);
    EXPECT_NE(html.find("acceptance limits: the file " + lim), std::string::npos)
        << "the appendix names where they came from";
    for (const char* q : {"H", "G", "F"}) {
      EXPECT_NE(html.find(std::string("data-quantity=\"") + q + "\""), std::string::npos) << q;
    }
    fs::remove(out);
  }
  expect({"report", xy, "-o", out, "--limits", "H=0.01", "--limits-file", lim}, 2,
         "--limits and --limits-file: give the limits one way");
  // Changes: only a circtest.plan/1 document whose changes have words.
  expect({"report", xy, "-o", out, "--changes", junk}, 4,
         junk + ": expected a circtest.plan/1 document (circcomp plan --json)");
  const std::string plan = (dir_ / "plan.json").string();
  circtest::testing::spit(plan, R"({"schema": "circtest.plan/1", "changes": [{"words": 3}]})");
  expect({"report", xy, "-o", out, "--changes", plan}, 4, "'changes[0].words': expected a string");
  // What names a change (to net it over the rounds) is a string or null.
  circtest::testing::spit(
      plan, R"({"schema": "circtest.plan/1", "changes": [{"words": "a", "before": 3}]})");
  expect({"report", xy, "-o", out, "--changes", plan}, 4, "'changes[0].before': expected a string");
  // A directory in the output's place is never replaced.
  fs::create_directory(dir_ / "dir.html");
  const CommandResult r = circana({"report", xy, "-o", (dir_ / "dir.html").string()});
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_TRUE(fs::is_directory(dir_ / "dir.html"));
}
