// circana import and export-polar on the real executables: a logged trace exported and
// imported again evaluates the same and carries what circcomp apply needs; the export formats
// of other instruments (angle and deviation per direction, time-stamped X/Y). Bad exports:
// tests/hostile/test_hostile_import.cpp.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "circtest/core/sha256.hpp"
#include "circtest/core/strings.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;
using circtest::testing::CommandResult;
using circtest::testing::run_command;
using circtest::testing::ScratchDir;
using circtest::testing::slurp;

namespace {

class Import : public ::testing::Test {
 protected:
  CommandResult circana(std::vector<std::string> args) {
    args.insert(args.begin(), CIRCANA_PATH);
    return run_command(args);
  }
  nlohmann::json analyze(const std::string& trace) {
    const CommandResult r = circana({"analyze", trace, "--json"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(r.out);
  }
  std::string simtrace(const std::string& name, std::vector<std::string> args) {
    const std::string path = dir_.file(name);
    args.insert(args.begin(), {SIMTRACE_PATH, "-o", path});
    EXPECT_EQ(run_command(args).exit_code, 0);
    return path;
  }
  // A copy of configs/sim-mill in the scratch folder: its INI.
  std::string sim_mill_ini() {
    const fs::path cfg = dir_.dir() / "cfg";
    fs::create_directories(cfg);
    for (const auto& e :
         fs::directory_iterator(fs::path(CIRCTEST_SOURCE_DIR) / "configs/sim-mill")) {
      fs::copy(e.path(), cfg / e.path().filename());
    }
    return (cfg / "sim-mill.ini").string();
  }
  ScratchDir dir_{"circtest-import"};
};

// The evaluation's H of each pair and G of each run, in mm.
std::vector<double> h_and_g(const nlohmann::json& j) {
  std::vector<double> out;
  for (const auto& p : j["pairs"]) out.push_back(p["H"].get<double>());
  for (const auto& r : j["runs"]) out.push_back(r["G"].get<double>());
  return out;
}

}  // namespace

TEST_F(Import, ALoggedTraceExportedAndImportedEvaluatesTheSameAndApplyNeedsNoForce) {
  const std::string ini = sim_mill_ini();
  const std::string logged =
      simtrace("run.csv", {"--backlash-x", "0.008", "--squareness", "40e-6", "--f", "1500"});

  const std::string polar = dir_.file("polar.txt");
  CommandResult r = circana({"export-polar", logged, "-o", polar, "--operator", "A. Smith"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string imported = dir_.file("imported.csv");
  r = circana({"import", polar, "-o", imported, "--ini", ini, "--date", "2026-11-20T10:00Z",
               "--instrument", "QC20-W ballbar"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("2 run(s)"), std::string::npos) << r.out;

  // H and G the same within 0.1 um.
  const auto before = h_and_g(analyze(logged));
  const nlohmann::json j = analyze(imported);
  const auto after = h_and_g(j);
  ASSERT_EQ(before.size(), 3u);
  ASSERT_EQ(after.size(), before.size());
  for (std::size_t i = 0; i < before.size(); ++i) EXPECT_NEAR(after[i], before[i], 1e-4) << i;
  EXPECT_NEAR(before[0], 0.008, 1e-3);  // the backlash shows as H: the test sees something

  // The test's metadata survives: plane, radius, feed, date, operator, instrument, INI.
  const std::string text = slurp(imported);
  for (const std::string& line : std::vector<std::string>{
           "# plane: XY", "# radius_mm: 75", "# feed_mm_per_min: 1500",
           "# start_time: 2026-11-20T10:00:00Z", "# operator: A. Smith",
           "# instrument: QC20-W ballbar", "# ini_sha256: " + circtest::sha256_hex(slurp(ini))}) {
    EXPECT_NE(text.find(line + "\n"), std::string::npos) << line << "\n" << text.substr(0, 800);
  }
  EXPECT_EQ(j["runs"][0]["direction"], "CCW");
  EXPECT_EQ(j["runs"][1]["direction"], "CW");

  // diagnose, then circcomp apply takes it without --force; without --ini it does not.
#ifndef CIRCCOMP_PATH
  GTEST_SKIP() << "circcomp is not built (CIRCTEST_BUILD_COMPENSATION off)";
#else
  const std::vector<std::string> env = {"CIRCTEST_KINS_MODULE=" + dir_.write("kins.so", ""),
                                        "CIRCTEST_FRIC_MODULE=" + dir_.write("fric.so", "")};
  const std::string unproven = dir_.file("unproven.csv");
  ASSERT_EQ(circana({"import", polar, "-o", unproven}).exit_code, 0);
  for (const auto& [trace, code] : {std::pair{unproven, 10}, std::pair{imported, 0}}) {
    r = circana({"diagnose", trace, "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::string diagnosis = dir_.write("diagnosis.json", r.out);
    const CommandResult apply = run_command({CIRCCOMP_PATH, "apply", "--ini", ini, diagnosis}, env);
    EXPECT_EQ(apply.exit_code, code) << trace << "\n" << apply.err << apply.out;
    if (code != 0) {
      EXPECT_NE(apply.err.find("has no ini_sha256"), std::string::npos) << apply.err;
    }
  }
  EXPECT_NE(slurp(ini).find("BACKLASH"), std::string::npos);
#endif
}

TEST_F(Import, AnExportWithADeviationColumnPerDirection) {
  // One angle column, the CCW and CW deviations beside it: a 6 um step between the
  // directions is H.
  std::string text = "Angle (\xC2\xB0);CCW deviation (\xC2\xB5m);CW deviation (\xC2\xB5m)\r\n";
  for (int i = 0; i < 360; ++i) {
    text +=
        std::to_string(i) + ";" + (i < 180 ? "3" : "-3") + ";" + (i < 180 ? "-3" : "3") + "\r\n";
  }
  const std::string in = dir_.write("twodir.csv", text);
  const std::string out = dir_.file("twodir-trace.csv");
  const CommandResult r = circana({"import", in, "-o", out, "--radius", "100", "--feed", "800"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = analyze(out);
  ASSERT_EQ(j["runs"].size(), 2u);
  EXPECT_EQ(j["runs"][0]["direction"], "CCW");
  EXPECT_EQ(j["runs"][1]["direction"], "CW");
  EXPECT_NEAR(j["H"].get<double>(), 0.006, 1e-4);
  EXPECT_NE(slurp(out).find("# feed_mm_per_min: 800\n"), std::string::npos);
  EXPECT_NE(slurp(out).find("# directions: CCW,CW\n"), std::string::npos);
}

TEST_F(Import, OneRunNamedByDirection) {
  std::string text;
  for (int i = 0; i <= 360; i += 2) text += std::to_string(i) + " 0.5\n";
  const std::string in = dir_.write("one.txt", text);
  for (const std::string direction : {"cw", "ccw"}) {
    const std::string out = dir_.file("one-" + direction + ".csv");
    const CommandResult r =
        circana({"import", in, "-o", out, "--radius", "50", "--direction", direction});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json j = analyze(out);
    ASSERT_EQ(j["runs"].size(), 1u);
    EXPECT_EQ(j["runs"][0]["direction"], direction == "cw" ? "CW" : "CCW");
    EXPECT_NE(slurp(out).find(direction == "cw" ? "# directions: CW\n" : "# directions: CCW\n"),
              std::string::npos);
  }
}

TEST_F(Import, TimeStampedPositionsInTheUnitsTheColumnsName) {
  // A grid encoder's export: time in ms, positions in um, no title; plane YZ.
  std::string text;
  const double r_um = 50'000.0;
  for (int i = 0; i <= 2000; ++i) {
    const double a = 2 * std::numbers::pi * i / 2000.0;
    const double wobble = 2.0 * std::cos(2 * a);  // 4 um of G
    text += fmt::format("{} {:.4f} {:.4f}\n", i * 2, (r_um + wobble) * std::cos(a),
                        (r_um + wobble) * std::sin(a));
  }
  const std::string in = dir_.write("grid.txt", text);
  const std::string out = dir_.file("grid-trace.csv");
  CommandResult r = circana({"import", in, "-o", out, "--plane", "YZ", "--columns",
                             "t_ms,y_um,z_um", "--radius", "50", "--instrument", "KGM 282"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string trace = slurp(out);
  EXPECT_NE(trace.find("\nt,y,z\n"), std::string::npos) << trace.substr(0, 400);
  EXPECT_NE(trace.find("# instrument: KGM 282\n"), std::string::npos);
  const nlohmann::json j = analyze(out);
  ASSERT_EQ(j["runs"].size(), 1u);
  EXPECT_NEAR(j["runs"][0]["G"].get<double>(), 0.004, 2e-4);
  // 2000 samples 2 ms apart over one turn of radius 50 mm: 2 pi 50 mm in 4 s.
  EXPECT_NEAR(j["runs"][0]["feed_mm_per_min"].get<double>(), 2 * std::numbers::pi * 50 / 4 * 60,
              50.0);
}

TEST_F(Import, TitlesNameTheColumnsAndTheirUnits) {
  // A grid encoder's CSV whose title says it all: ms and um become s and mm.
  std::string text = "Sample;Time [ms];X position [\xC2\xB5m];Y position [\xC2\xB5m]\n";
  for (int i = 0; i <= 400; ++i) {
    const double a = 2 * std::numbers::pi * i / 400.0;
    text += fmt::format("{};{};{:.3f};{:.3f}\n", i, i * 10, 50'000.0 * std::cos(a),
                        50'000.0 * std::sin(a));
  }
  // "Sample" says nothing about its unit: refused until --columns names it (skip).
  const std::string in = dir_.write("titled.csv", text);
  const std::string out = dir_.file("titled-trace.csv");
  CommandResult r = circana({"import", in, "-o", out});
  EXPECT_EQ(r.exit_code, 4) << r.err;
  EXPECT_NE(r.err.find("cannot tell what 'Sample' holds"), std::string::npos) << r.err;
  r = circana({"import", in, "-o", out, "--columns", "skip,t_ms,x_um,y_um"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Without the sample column the title alone is enough.
  std::string titled = "Time [ms];X position [\xC2\xB5m];Y position [\xC2\xB5m]\n";
  for (std::size_t p = text.find('\n') + 1; p < text.size();) {
    const std::size_t end = text.find('\n', p);
    titled += text.substr(text.find(';', p) + 1, end - text.find(';', p));
    p = end + 1;
  }
  const std::string out2 = dir_.file("titled-trace2.csv");
  r = circana({"import", dir_.write("titled2.csv", titled), "-o", out2});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string trace = slurp(out2);
  EXPECT_NE(trace.find("\nt,x,y\n0.000000,50.000000,0.000000\n0.010000,"), std::string::npos)
      << trace.substr(0, 400);
  EXPECT_EQ(slurp(out).substr(slurp(out).find("\nt,x,y\n")), trace.substr(trace.find("\nt,x,y\n")));
}

namespace {

// The text without its lines that start with PREFIX.
std::string without_lines(const std::string& text, const std::string& prefix) {
  std::string out;
  for (std::size_t p = 0; p < text.size();) {
    std::size_t end = text.find('\n', p);
    end = end == std::string::npos ? text.size() : end + 1;
    if (text.compare(p, prefix.size(), prefix) != 0) out += text.substr(p, end - p);
    p = end;
  }
  return out;
}

bool lists(const nlohmann::json& j, const std::string& term) {
  for (const auto& t : j["unseparable"]) {
    if (t == term) return true;
  }
  return false;
}

}  // namespace

// A ball bar's polar export of a trace with X backlash 8 um and unequal position loops,
// its feed line removed: the backlash is the injected one (or not reported and listed as
// unseparable), never the servo ellipse taken for play; the import's synthesised commanded
// columns give no lag; circcomp plans no backlash from an unseparable term.
TEST_F(Import, AnExportWithoutItsFeedGivesTheInjectedBacklashOrNone) {
  const std::string logged =
      simtrace("run.csv", {"--backlash-x", "0.008", "--kv-x", "30", "--kv-y", "40", "--f", "1500"});
  const std::string polar = dir_.file("polar.txt");
  ASSERT_EQ(circana({"export-polar", logged, "-o", polar}).exit_code, 0);
  const std::string bare = dir_.write("bare.txt", without_lines(slurp(polar), "# feed_mm_per_min"));
  const std::string imported = dir_.file("imported.csv");
  CommandResult r = circana({"import", bare, "-o", imported});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = circana({"diagnose", imported, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["feeds_mm_per_min"].empty());
  const nlohmann::json& x = j["backlash_mm"]["X"];
  if (x.is_null()) {
    EXPECT_TRUE(lists(j, "backlash_mm.X")) << j.dump(1);
  } else {
    EXPECT_NEAR(x.get<double>(), 0.008, 0.0004) << j.dump(1);  // 5 % of the truth
  }
  const nlohmann::json& y = j["backlash_mm"]["Y"];
  if (!y.is_null()) EXPECT_NEAR(y.get<double>(), 0.0, 0.0004) << j.dump(1);
  // The synthesised x_cmd, y_cmd only give each reading's angle: no lag from them.
  for (const char* axis : {"X", "Y"}) {
    EXPECT_NE(j["axis_lag_source"][axis], "instrument") << j.dump(1);
  }
  EXPECT_TRUE(j["lag_ms"].is_null()) << j.dump(1);
}

// A two-feed export that states its feeds: each run diagnosed at its own feed.
TEST_F(Import, AnExportOfTwoFeedsUsesTheFeedsItStates) {
  const std::string logged =
      simtrace("set.csv", {"--set", "XY", "--feeds", "500,1500", "--backlash-x", "0.008", "--kv-x",
                           "30", "--kv-y", "40"});
  const std::string polar = dir_.file("polar2.txt");
  CommandResult r = circana({"export-polar", logged, "-o", polar});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(slurp(polar).find("# feeds_mm_per_min: 500,1500\n"), std::string::npos);
  const std::string imported = dir_.file("imported2.csv");
  r = circana({"import", polar, "-o", imported});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = circana({"diagnose", imported, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["feeds_mm_per_min"], nlohmann::json({500.0, 1500.0})) << j.dump(1);
  ASSERT_FALSE(j["backlash_mm"]["X"].is_null()) << j.dump(1);
  EXPECT_NEAR(j["backlash_mm"]["X"].get<double>(), 0.008, 0.0004);
  // The ellipse grows with the feed: its lag mismatch is 1/30 - 1/40 s.
  ASSERT_FALSE(j["servo_mismatch_ms"].is_null()) << j.dump(1);
  EXPECT_NEAR(j["servo_mismatch_ms"].get<double>(), (1.0 / 30 - 1.0 / 40) * 1e3, 0.3);
}

#ifdef CIRCCOMP_PATH
// circcomp gives an unseparable term no correction, whatever number stands beside it.
TEST_F(Import, CirccompPlansNothingForAnUnseparableTerm) {
  const std::string ini = sim_mill_ini();
  const std::string logged = simtrace("run.csv", {"--backlash-x", "0.008", "--f", "1500"});
  CommandResult r = circana({"diagnose", logged, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_FALSE(j["backlash_mm"]["X"].is_null());
  const std::vector<std::string> env = {"CIRCTEST_KINS_MODULE=" + dir_.write("kins.so", ""),
                                        "CIRCTEST_FRIC_MODULE=" + dir_.write("fric.so", "")};
  const auto plan = [&](const nlohmann::json& doc) {
    const std::string path = dir_.write("diagnosis.json", doc.dump());
    return run_command({CIRCCOMP_PATH, "plan", "--ini", ini, "--force", path}, env);
  };
  r = plan(j);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("BACKLASH"), std::string::npos) << r.out;  // the control: it would
  j["unseparable"] = {"backlash_mm.X"};
  r = plan(j);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.find("BACKLASH"), std::string::npos) << r.out;
  EXPECT_NE((r.out + r.err).find("X backlash: not in the diagnosis"), std::string::npos)
      << r.out << r.err;
}
#endif

// Titles in British and American usage alike: anticlockwise and counterclockwise, metre and
// meter, singular and plural units; a centre's (center's) coordinate is no position.
TEST_F(Import, TitlesInBritishAndAmericanUsage) {
  const auto polar = [](const std::string& title) {
    std::string text = title + "\n";
    for (int i = 0; i < 360; ++i) {
      text += fmt::format("{};{};{}\n", i, i < 180 ? 3 : -3, i < 180 ? -3 : 3);
    }
    return text;
  };
  for (const std::string title :
       {"Angle (degrees);Anticlockwise deviation (micrometres);Clockwise deviation (micrometres)",
        "Angle (degree);Counterclockwise deviation (micrometers);Clockwise deviation "
        "(micrometers)",
        "Angle [deg];Anti-clockwise [microns];Clockwise [microns]",
        "Angle (deg);Counter-clockwise (micrometer);Clockwise (micrometre)"}) {
    const std::string in = dir_.write("titled.csv", polar(title));
    const std::string out = dir_.file("titled-trace.csv");
    const CommandResult r = circana({"import", in, "-o", out, "--radius", "100"});
    ASSERT_EQ(r.exit_code, 0) << title << "\n" << r.err;
    const nlohmann::json j = analyze(out);
    ASSERT_EQ(j["runs"].size(), 2u) << title;
    EXPECT_EQ(j["runs"][0]["direction"], "CCW") << title;
    EXPECT_NEAR(j["H"].get<double>(), 0.006, 1e-4) << title;
  }
  // Millimetres and millimeters, milliseconds: the same trace.
  for (const std::string title : {"Time (milliseconds);X (millimetres);Y (millimetres)",
                                  "Time (millisecond);X (millimeters);Y (millimeters)"}) {
    std::string text = title + "\n";
    for (int i = 0; i <= 400; ++i) {
      const double a = 2 * std::numbers::pi * i / 400.0;
      text += fmt::format("{};{:.6f};{:.6f}\n", i * 10, 50.0 * std::cos(a), 50.0 * std::sin(a));
    }
    const std::string out = dir_.file("xy-trace.csv");
    const CommandResult r = circana({"import", dir_.write("xy.csv", text), "-o", out});
    ASSERT_EQ(r.exit_code, 0) << title << "\n" << r.err;
    EXPECT_NE(slurp(out).find("\nt,x,y\n0.000000,50.000000,0.000000\n0.010000,"), std::string::npos)
        << title;
  }
  // A centre's coordinate in either spelling is not taken for the axis's position.
  for (const std::string title :
       {"Time (ms);Centre X (mm);X (mm);Y (mm)", "Time (ms);Center X (mm);X (mm);Y (mm)"}) {
    const std::string in = dir_.write("c.csv", title + "\n0;0;50;0\n10;0;0;50\n20;0;-50;0\n");
    const CommandResult r = circana({"import", in, "-o", dir_.file("c-trace.csv")});
    EXPECT_EQ(r.exit_code, 4) << title;
    EXPECT_NE(r.err.find("cannot tell what 'Cent"), std::string::npos) << r.err;
  }
}
