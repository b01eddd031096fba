// circana as a user runs it: exit codes, one-line errors naming file and line, nothing on
// stdout on error, and the JSON document.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "circana_cli_fixture.hpp"
#include "circtest/core/strings.hpp"
#include "reference.hpp"
#include "scratch.hpp"

TEST_F(CircanaCli, BadTraces) {
  const std::string empty = write("empty.csv", "");
  expect_error("analyze " + empty, 4,
               empty + ":1: empty file: expected a header row of column names");

  const std::string nox = write("nox.csv", "t,y\n0,1\n");
  expect_error("analyze " + nox, 4,
               nox + ":1: missing column 'x': expected it in the header (found: t,y)");

  const std::string word = write("word.csv", "# plane: XY\nt,x,y\n0,1,2\n0.001,one,2\n");
  expect_error("analyze " + word, 4, word + ":4: column 'x': expected a number, got 'one'");

  const std::string nan = write("nan.csv", "t,x,y\n0,1,2\n0.001,1,NaN\n");
  expect_error("analyze " + nan, 4, nan + ":3: column 'y': expected a finite number, got 'NaN'");

  const std::string inf = write("inf.csv", "t,x,y\n0,inf,2\n");
  expect_error("analyze " + inf, 4, inf + ":2: column 'x': expected a finite number, got 'inf'");

  const std::string back = write("back.csv", "t,x,y\n0,1,2\n0.002,1,2\n0.001,1,2\n");
  expect_error("analyze " + back, 5,
               back +
                   ":4: time goes backwards: t = 0.001 after t = 0.002; expected "
                   "non-decreasing time");

  const std::string few = write("few.csv", "t,x,y\n0,1,2\n0.001,1,2\n");
  expect_error("analyze " + few, 5,
               few + ":3: too few points: 2 rows, expected at least 3 per run");

  const std::string quote = write("quote.csv", "t,x,y\n0,\"1,2\n");
  expect_error("analyze " + quote, 4,
               quote + ":2: field 2: unterminated quoted field: expected a closing '\"'");

  const std::string missing = (dir_ / "missing.csv").string();
  const CommandResult r = run("analyze " + missing);
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "circana: error: " + missing + ": cannot open: No such file or directory\n");
}

TEST_F(CircanaCli, ShortArcIsRefusedWithItsLines) {
  const std::string trace = (dir_ / "arc60.csv").string();
  ASSERT_EQ(simtrace("-o " + trace + " --arc 60"), 0);
  const CommandResult r = run("analyze " + trace);
  EXPECT_EQ(r.exit_code, 5);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find(trace + ":"), std::string::npos) << r.err;
  EXPECT_NE(
      r.err.find("sweeps 60.0 deg: expected an arc of at least 90 deg (ISO 230-4 clause 3.1)"),
      std::string::npos)
      << r.err;
}

TEST_F(CircanaCli, SvgPathThatIsNotARegularFileIsRefusedAndKept) {
  const std::string trace = std::string(CIRCTEST_SOURCE_DIR) + "/examples/sim-d150-f1000.csv";
  const std::string fifo = (dir_ / "plot.svg").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  expect_error("analyze " + trace + " --svg " + fifo, 3,
               fifo + ": is a FIFO, not a regular file; refusing to replace it");
  EXPECT_TRUE(fs::is_fifo(fifo));
  expect_error("analyze " + trace + " --svg /dev/full", 3,
               "/dev/full: is a character device, not a regular file; refusing to replace it");
  EXPECT_TRUE(fs::is_character_file("/dev/full"));
  expect_error("analyze " + trace + " --svg " + dir_.string(), 3,
               dir_.string() + ": is a directory, not a regular file; refusing to replace it");
  fs::create_symlink("/dev/null", dir_ / "null.svg");
  const CommandResult r = run("analyze " + trace + " --svg " + (dir_ / "null.svg").string());
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
}

// Issue 12: a glitched example trace, row by row. `edit` gets the fields of data row `row`.
std::string edited_example(const fs::path& dir, const std::string& name, std::size_t row,
                           const std::function<void(std::vector<std::string>&)>& edit,
                           const std::string& extra_metadata = "") {
  std::ifstream in(std::string(CIRCTEST_SOURCE_DIR) + "/examples/sim-d150-f1000.csv");
  std::ostringstream out;
  out << extra_metadata;
  std::string line;
  std::size_t data = 0;
  bool header = false;
  while (std::getline(in, line)) {
    if (line.starts_with("#") || !header) {
      header = header || !line.starts_with("#");
      const std::string key = line.substr(0, line.find(':') + 1);
      if (line.starts_with("#") && extra_metadata.find(key) != std::string::npos) continue;
      out << line << '\n';
      continue;
    }
    if (++data == row) {
      std::vector<std::string> f;
      std::stringstream ss(line);
      for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
      edit(f);
      line.clear();
      for (std::size_t i = 0; i < f.size(); ++i) line += (i ? "," : "") + f[i];
    }
    out << line << '\n';
  }
  const fs::path p = dir / name;
  std::ofstream(p) << out.str();
  return p.string();
}

// A program run in a work offset: circgen states the centre in it (centre_mm) and, knowing the
// offset's origin, in machine coordinates (centre_machine_mm); the recorded positions are
// LinuxCNC's joint positions, machine coordinates, so the runs are found about the latter.
TEST_F(CircanaCli, ARecordedTraceCirclesTheCentreInMachineCoordinates) {
  const std::string example = std::string(CIRCTEST_SOURCE_DIR) + "/examples/sim-d150-f1000.csv";
  const std::string offset = edited_example(
      dir_, "offset.csv", 0, [](std::vector<std::string>&) {},
      "# centre_mm: 0,0,0\n# centre_machine_mm: 250,250,100\n");
  const auto ja = run_json("analyze " + example + " --json");
  const auto jb = run_json("analyze " + offset + " --json");
  ASSERT_FALSE(ja.is_null() || jb.is_null());
  ASSERT_EQ(jb["runs"].size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_DOUBLE_EQ(jb["runs"][i]["G"].get<double>(), ja["runs"][i]["G"].get<double>());
    EXPECT_DOUBLE_EQ(jb["runs"][i]["F_max"].get<double>(), ja["runs"][i]["F_max"].get<double>());
  }
}

TEST_F(CircanaCli, OneOutlierRowIsADataErrorAtItsLine) {
  // y = 0 in one row of run 1 (columns t,x,y,...) would make G = 150 mm (the MZC zone set
  // by that row): refused naming the row's line (5 metadata lines + header + 3000). (assign,
  // not = "0": GCC 12 warns falsely, -Wrestrict, on the inlined copy of the literal.)
  const std::string t = edited_example(dir_, "outlier.csv", 3000,
                                       [](std::vector<std::string>& f) { f[2].assign(1, '0'); });
  const CommandResult r = run("analyze " + t + " --json");
  EXPECT_EQ(r.exit_code, 5) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err.rfind("circana: error: " + t + ":3006: run 1: an outlier: this sample lies ", 0),
            0u)
      << r.err;
  EXPECT_NE(r.err.find("which would set G (the MZC zone): correct or remove the row\n"),
            std::string::npos)
      << r.err;
}

TEST_F(CircanaCli, TheFuzzersMzcNonConvergenceEndsWithAnAnswer) {
  // fuzz_analyze's finding (kept in its corpus): a mutated simulated trace on which the
  // exchange lost its alternation and circana exited 1 with an internal error.
  const std::string t =
      std::string(CIRCTEST_SOURCE_DIR) + "/tests/fuzz/corpus/fuzz_analyze/mzc-did-not-converge.csv";
  // Its radius no longer matches its metadata (refused since); the warning lets the fit run.
  const CommandResult r = run("analyze " + t + " --json --warn-inconsistent");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("internal"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("did not converge"), std::string::npos) << r.err;
}

TEST_F(CircanaCli, SegmentIdsNoIntegerHoldsAreRefusedAtTheirLine) {
  for (const char* v : {"1e300", "9223372036854775808", "-3e9"}) {
    const std::string t =
        edited_example(dir_, "seg.csv", 3000, [&](std::vector<std::string>& f) { f[8] = v; });
    const CommandResult r = run("analyze " + t);
    EXPECT_EQ(r.exit_code, 5) << v << r.err;
    EXPECT_NE(r.err.find(t + ":3006: segment: expected a run id, a whole number 0..2147483647 "
                             "(0 = idle), got"),
              std::string::npos)
        << r.err;
  }
}

TEST_F(CircanaCli, ImplausibleMetadataIsAParseErrorAtItsLine) {
  // Values that once gave F = -inf or a usage error without a file: the reader refuses them
  // at their line (exit 4) before anything is evaluated. The metadata line is line 1.
  const auto none = [](std::vector<std::string>&) {};
  for (const std::string meta :
       {"# radius_mm: -75\n", "# radius_mm: 1e308\n", "# temperature_machine_C: 1e308\n",
        "# expansion_instrument_per_K: 1e308\n", "# units: furlong\n"}) {
    // Replaces the example's own line of that key.
    const std::string t = edited_example(dir_, "meta.csv", 0, none, meta);
    const CommandResult r = run("analyze " + t);
    EXPECT_EQ(r.exit_code, 4) << meta << r.out << r.err;
    EXPECT_EQ(r.out, "");
    const std::string key = meta.substr(2, meta.find(':') - 2);
    EXPECT_EQ(r.err.rfind("circana: error: " + t + ":1: metadata '" + key + "': expected ", 0), 0u)
        << r.err;
  }
  const std::string t = edited_example(dir_, "meta.csv", 0, none, "# radius_mm: -75\n");
  expect_error("analyze " + t, 4,
               t + ":1: metadata 'radius_mm': expected a radius in mm above 0 and at most 100000, "
                   "got '-75'");
}

TEST_F(CircanaCli, NonFiniteResultsAreRefusedNotPrinted) {
  // Neither the metadata (above) nor an option can carry such values: refused where given.
  const std::string t = std::string(CIRCTEST_SOURCE_DIR) + "/examples/sim-d150-f1000.csv";
  const CommandResult r = run("analyze " + t + " --radius 1e308");
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find("--radius: expected a radius in mm above 0 and at most 100000, got "
                       "'1e308'"),
            std::string::npos)
      << r.err;
}

TEST_F(CircanaCli, BadOptions) {
  const std::string t = write("t.csv", "t,x,y\n0,1,2\n");
  expect_error("analyze " + t + " --radius abc", 2,
               "--radius: expected a radius in mm above 0 and at most 100000, got 'abc'");
  expect_error("analyze " + t + " --centre 1", 2,
               "--centre: expected 2 comma-separated numbers, got '1'");
  expect_error("analyze " + t + " --plane XZ", 2, "--plane: expected XY, YZ or ZX, got 'XZ'");
  expect_error("analyze", 2, "missing the trace argument: expected a file name");
  expect_error("fit --json", 2, "missing the points argument: expected a file name");
  expect_error("frobnicate", 2,
               "unknown command 'frobnicate': expected analyze, diagnose, report, fit, import, "
               "export-polar, store, history or summary");
}

TEST_F(CircanaCli, JsonDocumentOfASimulatedMachine) {
  const std::string trace = (dir_ / "sq.csv").string();
  ASSERT_EQ(simtrace("-o " + trace + " --squareness 100e-6 --backlash-x 0.02 --period 0.002"), 0);
  const CommandResult r = run("analyze " + trace + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["units"], "mm");
  ASSERT_EQ(j["runs"].size(), 2u);
  EXPECT_EQ(j["runs"][0]["direction"], "CCW");
  EXPECT_EQ(j["runs"][0]["label"], "XY");
  EXPECT_EQ(j["runs"][1]["direction"], "CW");
  EXPECT_EQ(j["runs"][1]["label"], "YX");
  EXPECT_NEAR(j["H"].get<double>(), 0.020, 0.0005);
  for (const auto& run : j["runs"]) {
    for (const char* key : {"G", "G_lsc", "F_max", "F_min", "radius", "points", "arc_deg"}) {
      EXPECT_TRUE(run.contains(key)) << key;
    }
    EXPECT_EQ(run["centre"].size(), 2u);
    EXPECT_NEAR(run["arc_deg"].get<double>(), 360.0, 0.5);
  }
}

// circana diagnose: the JSON contract of docs/diagnosis.md, the text's sign words, --pitch.
TEST_F(CircanaCli, DiagnoseOfASimulatedMachine) {
  const std::string trace = (dir_ / "diag.csv").string();
  ASSERT_EQ(simtrace("-o " + trace +
                     " --d 100 --f 2000 --squareness 100e-6 --backlash-x 0.01 --kv-x 30"
                     " --kv-y 33 --cyclic-y 0.002 --pitch-y 5"),
            0);
  const CommandResult r = run("diagnose " + trace + " --json --pitch Y=5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["schema"], "circtest.diagnosis/1");
  EXPECT_NEAR(j["backlash_mm"]["X"].get<double>(), 0.010, 0.0005);
  EXPECT_NEAR(j["squareness_urad"].get<double>(), 100.0, 5.0);
  EXPECT_NEAR(j["servo_mismatch_ms"].get<double>(), (1.0 / 30 - 1.0 / 33) * 1e3, 0.05);
  EXPECT_NEAR(j["cyclic"]["Y"]["amplitude_mm"].get<double>(), 0.002, 0.0001);
  EXPECT_EQ(j["cyclic"]["Y"]["pitch_source"], "option");
  const CommandResult text = run("diagnose " + trace);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("X lags Y by 3.0"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("X backlash 10.0 um"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("is 90 deg - 100."), std::string::npos) << text.out;
  const CommandResult analyze = run("analyze " + trace);
  EXPECT_NE(analyze.out.find("Diagnosis"), std::string::npos);
  // --svg: the plot with the diagnosis panel, from diagnose and from analyze (also with --json).
  const std::string svg = (dir_ / "diag.svg").string();
  ASSERT_EQ(run("diagnose " + trace + " --json --svg " + svg).exit_code, 0);
  EXPECT_NE(circtest::testing::slurp(svg).find("X backlash 10.0 um"), std::string::npos);
  EXPECT_NE(circtest::testing::slurp(svg).find("class=\"contribution\""), std::string::npos);
  fs::remove(svg);
  ASSERT_EQ(run("analyze " + trace + " --json --svg " + svg).exit_code, 0);
  EXPECT_NE(circtest::testing::slurp(svg).find("servo mismatch: X lags Y by 3.0"),
            std::string::npos);
  expect_error("diagnose " + trace + " --pitch X5", 2,
               "--pitch: expected AXIS=MM items like X=5,Y=5, each pitch from 0.001 to 1000 mm, "
               "got 'X5'");
  expect_error("diagnose " + trace + " --pitch X=-1", 2,
               "--pitch: expected AXIS=MM items like X=5,Y=5, each pitch from 0.001 to 1000 mm, "
               "got 'X=-1'");
}

// An axis that follows its command (no lag: FF1 1, a stepgen) with measurement noise: its lag
// is zero within its standard error, and 1 / lag is no position gain to print.
TEST_F(CircanaCli, ALagWithinItsUncertaintyOfZeroGivesNoPositionGain) {
  const std::string trace = (dir_ / "nolag.csv").string();
  ASSERT_EQ(simtrace("-o " + trace + " --noise 0.0002 --seed 3 --period 0.002"), 0);
  const CommandResult text = run("diagnose " + trace);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  std::istringstream lines(text.out);
  int axes = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.find(" servo lag ") == std::string::npos || line.find("mismatch") != std::string::npos)
      continue;
    ++axes;
    EXPECT_TRUE(line.find("position gain not measurable") != std::string::npos ||
                line.find("position gain not positive") != std::string::npos)
        << line;
  }
  EXPECT_EQ(axes, 2) << text.out;
  EXPECT_NE(text.out.find("position gain not measurable (the lag is within its uncertainty"),
            std::string::npos)
      << text.out;
}

TEST_F(CircanaCli, RadialTraceGivesTheResultsOfItsXyForm) {
  const std::string trace = (dir_ / "bar.csv").string();
  ASSERT_EQ(
      simtrace("-o " + trace + " --squareness 50e-6 --backlash-x 0.01 --radial --bar-length 75"),
      0);
  const auto jx = run_json("analyze " + trace + " --json");
  const auto jb = run_json("analyze " + trace + " --json --radial");
  ASSERT_FALSE(jx.is_null() || jb.is_null());
  EXPECT_NEAR(jb["H"].get<double>(), jx["H"].get<double>(), 1e-4);
  for (std::size_t k = 0; k < 2; ++k) {
    for (const char* key : {"G", "F_max", "F_min"}) {
      EXPECT_NEAR(jb["runs"][k][key].get<double>(), jx["runs"][k][key].get<double>(), 1e-4) << key;
    }
  }
  ASSERT_FALSE(jb["notes"].empty());
  EXPECT_NE(jb["notes"][0].get<std::string>().find("radial trace"), std::string::npos);
  EXPECT_TRUE(jx["notes"].empty() ||
              jx["notes"][0].get<std::string>().find("radial") == std::string::npos);
}

TEST_F(CircanaCli, ImportPolarWritesARadialTrace) {
  std::string text = "Angle (deg), Deviation (um)\n";
  for (int i = 0; i <= 360; ++i) text += std::to_string(i) + "," + (i == 90 ? "4.5" : "0.5") + "\n";
  const std::string in = write("export.txt", text);
  const std::string out = (dir_ / "imported.csv").string();
  const CommandResult r = run("import-polar " + in + " --radius 50 -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("361 rows, 1 run(s)"), std::string::npos) << r.out;
  const CommandResult a = run("analyze " + out + " --json --f-centre nominal --centre 0,0");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  const auto j = nlohmann::json::parse(a.out);
  ASSERT_EQ(j["runs"].size(), 1u);
  EXPECT_NEAR(j["runs"][0]["F_max"].get<double>(), 0.0045, 1e-6);
  EXPECT_NEAR(j["runs"][0]["F_min"].get<double>(), 0.0005, 1e-6);
  expect_error(
      "import-polar " + write("bad.txt", "0 1\n1 one\n") + " --radius 50 -o " + out, 4,
      (dir_ / "bad.txt").string() + ":2: column 'dev_um': expected a number, got 'one' in '1 one'");
  expect_error("import-polar " + in + " --radius -5 -o " + out, 2,
               "--radius: expected a radius in mm above 0 and at most 100000, got '-5'");
}

TEST_F(CircanaCli, FitOfTheCertifiedCaseC09) {
  const std::string c09 = circtest::testing::reference_path("tracim-circle-2d/C09.csv");
  CIRCTEST_SKIP_WITHOUT_REFERENCE(c09);
  const CommandResult r = run("fit " + c09 + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["mzc"]["zone_width"].get<double>(), 0.05, 1e-9);
  EXPECT_NEAR(j["mzc"]["centre"][0].get<double>(), 400.0, 1e-6);
  EXPECT_NEAR(j["mzc"]["centre"][1].get<double>(), 390.0, 1e-6);
  EXPECT_NEAR(j["mzc"]["radius"].get<double>(), 20.0, 1e-6);
}

TEST_F(CircanaCli, FitOfAHalfArcHasNoInscribedCircleButTheOtherFits) {
  std::string text = "x,y\n";
  for (int i = 0; i <= 180; ++i) {
    const double t = i * 3.14159265358979323846 / 180.0;
    text += std::to_string(10.0 + 20.0 * std::cos(t)) + "," +
            std::to_string(-5.0 + 20.0 * std::sin(t)) + "\n";
  }
  const std::string arc = write("arc.csv", text);
  const CommandResult r = run("fit " + arc + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["mic"].is_null());
  EXPECT_NEAR(j["mzc"]["radius"].get<double>(), 20.0, 1e-5);
  EXPECT_NEAR(j["lsc"]["centre"][0].get<double>(), 10.0, 1e-4);
}

// The clause 4.4 / 6 conditions as options: into the report, the JSON and the plot.
TEST_F(CircanaCli, TestConditionsFromTheCommandLine) {
  const std::string trace = (dir_ / "c.csv").string();
  ASSERT_EQ(simtrace("-o " + trace + " --period 0.004"), 0);
  const std::vector<std::string> opts = {
      "--machine",      "VMC 3",   "--serial",   "SN-1",       "--instrument", "grid encoder",
      "--operator",     "A. Sato", "--location", "hall 2",     "--t-machine",  "21",
      "--t-instrument", "20.5",    "--notes",    "after crash"};
  auto with = [&](std::vector<std::string> head, const std::vector<std::string>& tail) {
    head.insert(head.end(), opts.begin(), opts.end());
    head.insert(head.end(), tail.begin(), tail.end());
    return head;
  };
  CommandResult r = run(
      with({"analyze", trace}, {"--columns", "x_cmd,y_cmd", "--svg", (dir_ / "p.svg").string()}));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* line :
       {"  Machine:                    VMC 3\n", "  Machine serial:             SN-1\n",
        "  Instrument:                 grid encoder\n", "  Operator:                   A. Sato\n",
        "  Location:                   hall 2\n", "  Notes:                      after crash\n",
        "  Machine temperature:        21.00 deg C\n",
        "  Instrument temperature:     20.50 deg C\n",
        "  Channels evaluated:         x_cmd, y_cmd\n"}) {
    EXPECT_NE(r.out.find(line), std::string::npos) << line << r.out;
  }
  EXPECT_NE(circtest::testing::slurp(dir_ / "p.svg").find("channels evaluated x_cmd, y_cmd"),
            std::string::npos);
  r = run(with({"analyze", trace}, {"--json"}));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["conditions"]["machine"], "VMC 3");
  EXPECT_EQ(j["conditions"]["machine_serial"], "SN-1");
  EXPECT_EQ(j["conditions"]["temperature_machine_C"], "21");
  EXPECT_EQ(j["temperature"]["machine_C"], 21.0);
  EXPECT_EQ(j["channels"], nlohmann::json::array({"x", "y"}));

  expect_error("analyze " + trace + " --t-machine warm", 2,
               "--t-machine: expected a temperature in deg C from -273.15 to 1000, got 'warm'");
  expect_error({"analyze", trace, "--machine", " "}, 2, "--machine: expected a value, got nothing");
  expect_error("analyze " + trace + " --scale-um-per-div 0", 2,
               "--scale-um-per-div: expected a plot scale in um per division from 0.01 to 10000, "
               "got '0'");
}

TEST_F(CircanaCli, HostileInputs) {
  expect_error("analyze /dev/zero", 3, "/dev/zero: is a character device, not a regular file");
  expect_error("analyze " + dir_.string(), 3,
               dir_.string() + ": is a directory, not a regular file");
  const std::string longline = write("long.csv", "t,x,y\n" + std::string(2 << 20, '1') + "\n");
  expect_error(
      "analyze " + longline, 4,
      longline + ":2: line longer than 1048576 bytes (1 MiB): expected one record per line");
  // An unknown --columns name: the message lists every column of the file, kept or not.
  const std::string t = write("t.csv", "t,x,y,x_cmd,y_cmd,x_fb,y_fb,temp\n0,1,2,1,2,1,2,20\n");
  expect_error("analyze " + t + " --columns x_enc,y_fb", 4,
               t + ":1: missing column 'x_enc': expected it in the header (found: "
                   "t,x,y,x_cmd,y_cmd,x_fb,y_fb,temp)");
}

TEST_F(CircanaCli, TraceWithoutTimeIsEvaluatedWithANote) {
  const std::string full = (dir_ / "full.csv").string(), xy = (dir_ / "xy.csv").string();
  ASSERT_EQ(simtrace("-o " + full + " --backlash-x 0.02 --period 0.002"), 0);
  // The same trace with its first column (t) dropped.
  {
    std::istringstream in(circtest::testing::slurp(full));
    std::string out;
    for (std::string line; std::getline(in, line);) {
      out += (line.starts_with("#") ? line : line.substr(line.find(',') + 1)) + "\n";
    }
    circtest::testing::spit(xy, out);
  }
  ASSERT_EQ(circtest::testing::slurp(xy).find("\nt,"), std::string::npos);
  const CommandResult with_t = run("analyze " + full + " --json");
  const CommandResult without_t = run("analyze " + xy + " --json");
  ASSERT_EQ(without_t.exit_code, 0) << without_t.err;
  const auto a = nlohmann::json::parse(with_t.out), b = nlohmann::json::parse(without_t.out);
  EXPECT_DOUBLE_EQ(a["H"].get<double>(), b["H"].get<double>());
  bool noted = false;
  for (const auto& n : b["notes"]) {
    noted = noted || n.get<std::string>().rfind("no 't' column", 0) == 0;
  }
  EXPECT_TRUE(noted) << b["notes"];
  EXPECT_FALSE(b["runs"][0].contains("feed_mm_per_min") &&
               !b["runs"][0]["feed_mm_per_min"].is_null());
}

TEST_F(CircanaCli, CompareDrawsTheEarlierTestUnderThisOneInOnePlot) {
  const std::string before = (dir_ / "before.csv").string();
  const std::string after = (dir_ / "after.csv").string();
  ASSERT_EQ(simtrace("-o " + before + " --d 150 --f 1000 --backlash-x 0.02"), 0);
  ASSERT_EQ(simtrace("-o " + after + " --d 150 --f 1000 --backlash-x 0.002"), 0);
  const std::string svg = (dir_ / "both.svg").string();
  const CommandResult r = run("analyze " + after + " --svg " + svg + " --compare " + before);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string text = circtest::testing::slurp(svg);
  // Both tests' H in the legend: the earlier one (20 um play) first, this one dashed.
  const auto h_before = text.find("before: H_XY = 20.0 um");
  const auto h_after = text.find("after: H_XY = 2.0 um");
  EXPECT_NE(h_before, std::string::npos) << text.substr(0, 4000);
  EXPECT_NE(h_after, std::string::npos);
  EXPECT_LT(h_before, h_after);
  EXPECT_NE(text.find("after: channels evaluated x, y (dashed)"), std::string::npos);
  expect_error("analyze " + after + " --compare " + before, 2,
               "--compare: draws into the plot, so it needs --svg");
  expect_error("diagnose " + after + " --compare " + before, 2,
               "--compare: only for circana analyze");
}

TEST_F(CircanaCli, StoreRefusesThePlotAndJsonOptionsItWouldIgnore) {
  // Once `store TRACE --svg F` stored and wrote no F, silently. Refused before the history is
  // opened (exit 2): nothing stored, no file written.
  const std::string trace = (dir_ / "store.csv").string();
  ASSERT_EQ(simtrace("-o " + trace + " --d 150 --f 1000"), 0);
  const std::string db = (dir_ / "h.sqlite").string();
  const std::string svg = (dir_ / "store.svg").string();
  const std::string why =
      ": not for circana store (it only stores; analyze --store plots or "
      "prints and stores)";
  expect_error("store " + trace + " --db " + db + " --svg " + svg, 2, "--svg" + why);
  expect_error("store " + trace + " --db " + db + " --scale-um-per-div 5", 2,
               "--scale-um-per-div" + why);
  expect_error("store " + trace + " --db " + db + " --json", 2, "--json" + why);
  EXPECT_FALSE(fs::exists(svg));
  EXPECT_FALSE(fs::exists(db));
}
