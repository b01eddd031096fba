// circana as a user runs it on traces whose inputs disagree: the input checks' refusals with
// their exact messages and exit codes, an inch trace, each command's --help, summary.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "circana_cli_fixture.hpp"
#include "circtest/core/strings.hpp"
#include "scratch.hpp"

namespace {

// A simulated trace's text (circtest-simtrace, an ideal machine: every sample on the circle).
struct TextTrace {
  std::vector<std::string> lines;  // without line ends
  std::size_t header = 0;          // index of the header line
  int marker = -1;                 // column indices
  int segment = -1;
  std::vector<std::string> fields(std::size_t i) const {
    std::vector<std::string> f;
    std::stringstream ss(lines[i]);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    return f;
  }
  void set_field(std::size_t i, int column, const std::string& value) {
    auto f = fields(i);
    f[static_cast<std::size_t>(column)] = value;
    lines[i] = circtest::join(f, ",");
  }
  // First and last line index of each stretch of marker = 1.
  std::vector<std::pair<std::size_t, std::size_t>> marked() const {
    std::vector<std::pair<std::size_t, std::size_t>> out;
    bool open = false;
    for (std::size_t i = header + 1; i < lines.size(); ++i) {
      const bool on = fields(i)[static_cast<std::size_t>(marker)] == "1";
      if (on && !open) out.emplace_back(i, i);
      if (on) out.back().second = i;
      open = on;
    }
    return out;
  }
  std::string save(const fs::path& p) const {
    std::ofstream out(p);
    for (const auto& l : lines) out << l << '\n';
    return p.string();
  }
};

TextTrace load_text(const std::string& path) {
  TextTrace t;
  std::ifstream in(path);
  for (std::string l; std::getline(in, l);) t.lines.push_back(l);
  while (t.lines[t.header].starts_with("#")) ++t.header;
  const auto names = t.fields(t.header);
  for (std::size_t c = 0; c < names.size(); ++c) {
    if (names[c] == "marker") t.marker = static_cast<int>(c);
    if (names[c] == "segment") t.segment = static_cast<int>(c);
  }
  return t;
}

}  // namespace

TEST_F(CircanaCli, NominalRadiusFarFromTheMeasuredOneIsRefused) {
  const std::string trace = (dir_ / "d150.csv").string();
  ASSERT_EQ(simtrace("-o " + trace), 0);
  const auto runs = load_text(trace).marked();
  ASSERT_EQ(runs.size(), 2u);
  const std::string l1 = std::to_string(runs[0].first + 1), l2 = std::to_string(runs[0].second + 1);
  // The issue's case: --radius 50 on a 75 mm circle once gave F = +25 mm with exit 0.
  expect_error("analyze " + trace + " --radius 50", 5,
               trace + ":" + l1 + ": run 1 (lines " + l1 + "-" + l2 +
                   "): its least-squares radius 75.0000 mm differs from the nominal radius "
                   "50.0000 mm (option) by +25.0000 mm, more than the tolerance 0.5000 mm "
                   "(--radius-tolerance): F would measure that difference (--warn-inconsistent "
                   "to evaluate anyway)");
  const CommandResult warned = run("analyze " + trace + " --radius 50 --warn-inconsistent");
  EXPECT_EQ(warned.exit_code, 0) << warned.err;
  EXPECT_NE(warned.out.find("warning: run 1 (lines " + l1 + "-" + l2 + "): its least-squares"),
            std::string::npos)
      << warned.out;
  EXPECT_EQ(run("analyze " + trace + " --radius 50 --radius-tolerance 26").exit_code, 0);
  EXPECT_EQ(run("analyze " + trace + " --radius 74.5").exit_code, 0);  // within 1 %
  expect_error("analyze " + trace + " --radius-tolerance -1", 2,
               "--radius-tolerance: expected a radius tolerance in mm above 0 and at most 1000, "
               "got '-1'");
}

TEST_F(CircanaCli, ARunCutOffBeforeItsArcIsRefused) {
  const std::string full = (dir_ / "full.csv").string();
  ASSERT_EQ(simtrace("-o " + full), 0);
  TextTrace t = load_text(full);
  t.lines.insert(t.lines.begin(), "# arc_deg: 360");
  ++t.header;
  const auto runs = t.marked();
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(run("analyze " + t.save(dir_ / "whole.csv")).exit_code, 0);
  // The recording stops half-way through run 2.
  const std::size_t last = (runs[1].first + runs[1].second) / 2;
  t.lines.resize(last + 1);
  // Its sweep, from the samples themselves (centre 0,0 of the simulator).
  double sweep = 0.0;
  for (std::size_t i = runs[1].first + 1; i <= last; ++i) {
    const auto p = t.fields(i - 1), q = t.fields(i);
    const double a0 = std::atan2(std::stod(p[2]), std::stod(p[1]));
    const double a1 = std::atan2(std::stod(q[2]), std::stod(q[1]));
    sweep += std::remainder(a1 - a0, 2 * M_PI);
  }
  sweep = std::abs(sweep) * 180 / M_PI;
  EXPECT_NEAR(sweep, 180.0, 1.0);
  const std::string cut = t.save(dir_ / "cut.csv");
  const std::string l1 = std::to_string(runs[1].first + 1), l2 = std::to_string(last + 1);
  expect_error("analyze " + cut, 5,
               cut + ":" + l1 + ": run 2 (lines " + l1 + "-" + l2 + ") sweeps " +
                   fmt::format("{:.1f}", sweep) +
                   " deg of the 360.0 deg the program ran (arc_deg, line 1): the run is cut off "
                   "(--warn-inconsistent to evaluate anyway)");
  const CommandResult warned = run("analyze " + cut + " --warn-inconsistent");
  EXPECT_EQ(warned.exit_code, 0) << warned.err;
  EXPECT_NE(warned.out.find("warning: run 2 (lines " + l1 + "-" + l2 + ") sweeps"),
            std::string::npos);
}

TEST_F(CircanaCli, APlaneWithoutMotionIsRefusedNamingTheRanges) {
  const std::string trace = (dir_ / "xy.csv").string();
  ASSERT_EQ(simtrace("-o " + trace), 0);
  const auto runs = load_text(trace).marked();
  const std::string l1 = std::to_string(runs.front().first + 1);
  const std::string l2 = std::to_string(runs.back().second + 1);
  // The issue's case: once "sweeps 0.0 deg".
  expect_error("analyze " + trace + " --plane ZX", 5,
               trace + ": plane ZX: z moves 0.000 mm and x 150.000 mm over lines " + l1 + "-" + l2 +
                   ": no circle in that plane (position ranges: x 150.000 mm, y 150.000 mm, z "
                   "0.000 mm); give the plane of the test with --plane");
}

TEST_F(CircanaCli, OneMarkedSpanHoldingBothDirectionsIsSplitAtTheReversal) {
  const std::string trace = (dir_ / "two.csv").string();
  ASSERT_EQ(simtrace("-o " + trace), 0);
  TextTrace t = load_text(trace);
  const auto runs = t.marked();
  ASSERT_EQ(runs.size(), 2u);
  const CommandResult separate = run("analyze " + trace + " --json");
  ASSERT_EQ(separate.exit_code, 0) << separate.err;
  // No marker gap and one segment id from the CCW run's start to the CW run's end.
  for (std::size_t i = runs[0].first; i <= runs[1].second; ++i) {
    t.set_field(i, t.marker, "1");
    t.set_field(i, t.segment, "1");
  }
  const std::string merged = t.save(dir_ / "merged.csv");
  const CommandResult r = run("analyze " + merged + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["runs"].size(), 2u);
  EXPECT_EQ(j["runs"][0]["direction"], "CCW");
  EXPECT_EQ(j["runs"][1]["direction"], "CW");
  // Split at the turn, inside the stretch that was unmarked between the two runs.
  const auto split = j["runs"][0]["lines"][1].get<std::size_t>();
  EXPECT_GE(split, runs[0].second + 1);
  EXPECT_LT(split, runs[1].first + 1);
  const std::string note = "marked span lines " + std::to_string(runs[0].first + 1) + "-" +
                           std::to_string(runs[1].second + 1) +
                           " holds both directions: split where the rotation reverses (at line " +
                           std::to_string(split) + ") into 2 runs: CCW ";
  bool found = false;
  for (const auto& n : j["notes"]) found = found || n.get<std::string>().starts_with(note);
  EXPECT_TRUE(found) << r.out;
  // H of the split runs is the H of the separately marked ones (an ideal machine: 0).
  EXPECT_NEAR(j["H"].get<double>(), nlohmann::json::parse(separate.out)["H"].get<double>(), 1e-6);
}

TEST_F(CircanaCli, InchTracesAreResolvedFromTheirCircle) {
  const std::string mm = (dir_ / "mm.csv").string();
  ASSERT_EQ(simtrace("-o " + mm + " --backlash-x 0.01"), 0);
  TextTrace t = load_text(mm);
  t.lines.insert(t.lines.begin(), "# units: inch");
  ++t.header;
  // An inch program on a metric machine: positions in mm, evaluated as they are.
  const std::string program_inch = t.save(dir_ / "program-inch.csv");
  // An inch machine: every position column in inch.
  for (std::size_t i = t.header + 1; i < t.lines.size(); ++i) {
    auto f = t.fields(i);
    for (std::size_t c = 1; c <= 6; ++c) f[c] = fmt::format("{:.9f}", std::stod(f[c]) / 25.4);
    t.lines[i] = circtest::join(f, ",");
  }
  const std::string machine_inch = t.save(dir_ / "machine-inch.csv");
  const CommandResult a = run("analyze " + mm + " --json");
  const CommandResult b = run("analyze " + program_inch + " --json");
  const CommandResult c = run("analyze " + machine_inch + " --json");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const auto ja = nlohmann::json::parse(a.out), jb = nlohmann::json::parse(b.out),
             jc = nlohmann::json::parse(c.out);
  EXPECT_NEAR(ja["H"].get<double>(), 0.01, 0.001);  // the injected backlash
  EXPECT_EQ(jb["H"], ja["H"]);
  EXPECT_NEAR(jc["H"].get<double>(), ja["H"].get<double>(), 1e-6);  // 25.4 x what it was
  EXPECT_NEAR(jc["runs"][0]["F_max"].get<double>(), ja["runs"][0]["F_max"].get<double>(), 1e-6);
  EXPECT_NE(jc.dump().find("converted to mm (x 25.4)"), std::string::npos);
  EXPECT_NE(jb.dump().find("the positions are in mm"), std::string::npos);
  // Without a nominal radius nothing tells the two apart: refused, the option decides.
  TextTrace bare = load_text(machine_inch);
  std::erase_if(bare.lines, [](const std::string& l) {
    return l.starts_with("# radius_mm") || l.starts_with("# diameter_mm");
  });
  const std::string no_radius = bare.save(dir_ / "no-radius.csv");
  expect_error("analyze " + no_radius, 5,
               no_radius +
                   ":1: metadata 'units: inch': the program ran in inch, but the positions may be "
                   "in inch or in mm (LinuxCNC logs the machine's units) and there is no "
                   "radius_mm to tell which: give --units inch or --units mm");
  const CommandResult forced = run("analyze " + no_radius + " --units inch --json");
  ASSERT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_NEAR(nlohmann::json::parse(forced.out)["H"].get<double>(), ja["H"].get<double>(), 1e-6);
  expect_error("analyze " + mm + " --units feet", 2, "--units: expected mm or inch, got 'feet'");
}

// `circana COMMAND --help` lists that command's usage and only the options it accepts: an
// option it lists is one it takes (never refused afterwards), and no other command's usage.
TEST_F(CircanaCli, EachCommandsHelpListsOnlyWhatItAccepts) {
  const std::vector<std::string> commands = {"analyze", "diagnose", "report",
                                             "fit",     "import",   "export-polar",
                                             "store",   "history",  "summary"};
  for (const std::string& command : commands) {
    const CommandResult r = run({command, "--help"});
    ASSERT_EQ(r.exit_code, 0) << command;
    EXPECT_NE(r.out.find("usage: circana " + command), std::string::npos) << r.out;
    const std::string usage = r.out.substr(0, r.out.find("(man circana"));
    for (const std::string& other : commands) {
      if (other == command) continue;
      EXPECT_EQ(usage.find("circana " + other + " "), std::string::npos)
          << command << " --help shows " << other << "'s usage:\n"
          << r.out;
    }
  }
  // The options these commands refuse are not offered.
  for (const auto& [command, refused] :
       std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"store", {"--svg", "--json", "--scale-um-per-div", "--compare"}},
           {"export-polar", {"--svg", "--json", "--scale-um-per-div", "--compare"}},
           {"diagnose", {"--compare"}},
           {"report", {"--json", "--svg"}}}) {
    const CommandResult r = run({command, "--help"});
    const std::string options = r.out.substr(r.out.find("(man circana"));
    for (const std::string& o : refused) {
      EXPECT_EQ(options.find(o + " "), std::string::npos) << command << " lists " << o << "\n"
                                                          << options;
    }
  }
  // The top-level help still shows every command.
  const CommandResult all = run(std::vector<std::string>{"--help"});
  for (const std::string& command : commands)
    EXPECT_NE(all.out.find("circana " + command), std::string::npos) << command;
}

// circana summary: the runs' figures side by side from their documents, as the demo prints
// them: the injected backlash, and H as analyze reports it.
TEST_F(CircanaCli, SummaryReadsTheRunsDocuments) {
  const std::string trace = (dir_ / "b.csv").string();
  ASSERT_EQ(simtrace("-o " + trace + " --backlash-x 0.008"), 0);
  const CommandResult analyzed = run({"analyze", trace, "--json"});
  const CommandResult diagnosed = run({"diagnose", trace, "--json"});
  ASSERT_EQ(analyzed.exit_code, 0);
  ASSERT_EQ(diagnosed.exit_code, 0);
  const std::string result = write("b.json", analyzed.out);
  const std::string diagnosis = write("b-diagnosis.json", diagnosed.out);
  const std::string out = (dir_ / "summary.json").string();
  const CommandResult r =
      run({"summary", "--name", "before", "--result", result, "--diagnosis", diagnosis, "--name",
           "again", "--result", result, "--diagnosis", diagnosis, "--json", out});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("backlash X (um)"), std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(circtest::testing::slurp(out));
  EXPECT_EQ(j["runs"], nlohmann::json({"before", "again"}));
  const auto row = [&j](const std::string& label) {
    for (const auto& row : j["rows"]) {
      if (row["label"] == label) return row["values"];
    }
    return nlohmann::json();
  };
  EXPECT_NEAR(row("backlash X")[0].get<double>(), 8.0, 0.1);
  EXPECT_EQ(row("H")[0].get<double>(),
            nlohmann::json::parse(analyzed.out)["H"].get<double>() * 1e3);
  EXPECT_EQ(row("H")[1], row("H")[0]);
  // Each H and G with its U (k = 2), as analyze states it.
  const auto doc = nlohmann::json::parse(analyzed.out);
  EXPECT_NEAR(row("U of H (k = 2)")[0].get<double>(), doc["U_H"].get<double>() * 1e3, 1e-9);
  EXPECT_NEAR(row("U of G (k = 2)")[1].get<double>(), doc["runs"][0]["U_G"].get<double>() * 1e3,
              1e-9);
  EXPECT_NE(r.out.find("U of G (k = 2) (um)"), std::string::npos) << r.out;
  EXPECT_EQ(run({"summary", "--name", "x", "--result", result}).exit_code, 2);
}
