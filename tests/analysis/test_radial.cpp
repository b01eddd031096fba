// Radial (ball bar) traces: a bar's length from the test simulator's machine errors must
// give the H, G and F of the x/y form of the same run; a polar export must survive the
// import into the trace format.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/instrument_export.hpp"
#include "circtest/analysis/radial.hpp"
#include "circtest/core/error.hpp"
#include "machine_sim.hpp"

using namespace circtest;
using sim::CircleProgram;
using sim::MachineModel;

namespace {

constexpr double kTolMm = 1e-4;  // 0.1 um

MachineModel machine_with_errors() {
  MachineModel m;
  m.x.kv_per_s = m.y.kv_per_s = m.z.kv_per_s = 1000.0;
  m.x.backlash_mm = 0.008;
  m.y.backlash_mm = 0.004;
  m.x.scale = 15e-6;
  m.z.scale = -10e-6;
  m.squareness_rad = 20e-6;
  return m;
}

// The x/y form evaluated on the plane's own columns, the radial form on the bar alone.
void expect_same_results(const Trace& trace) {
  const Evaluation xy = evaluate(trace, {});
  const RadialPositions radial = radial_positions(trace, {});
  EvaluationOptions o;
  o.column_a = radial.column_a;
  o.column_b = radial.column_b;
  const Evaluation bar = evaluate(radial.trace, o);
  ASSERT_EQ(xy.runs.size(), 2u);
  ASSERT_EQ(bar.runs.size(), 2u);
  ASSERT_EQ(xy.hysteresis.size(), 1u);
  ASSERT_EQ(bar.hysteresis.size(), 1u);
  // The injected errors are large enough for the comparison to mean something.
  EXPECT_GT(xy.runs[0].g_mzc_mm, 0.003);
  EXPECT_GT(xy.hysteresis[0].h_mm, 0.003);
  for (std::size_t k = 0; k < 2; ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(bar.runs[k].run.direction, xy.runs[k].run.direction);
    EXPECT_NEAR(bar.runs[k].g_mzc_mm, xy.runs[k].g_mzc_mm, kTolMm);
    EXPECT_NEAR(bar.runs[k].g_lsc_mm, xy.runs[k].g_lsc_mm, kTolMm);
    ASSERT_TRUE(bar.runs[k].f_max_mm && xy.runs[k].f_max_mm);
    EXPECT_NEAR(*bar.runs[k].f_max_mm, *xy.runs[k].f_max_mm, kTolMm);
    EXPECT_NEAR(*bar.runs[k].f_min_mm, *xy.runs[k].f_min_mm, kTolMm);
  }
  EXPECT_NEAR(bar.hysteresis[0].h_mm, xy.hysteresis[0].h_mm, kTolMm);
  std::cout << "G " << xy.runs[0].g_mzc_mm * 1e3 << " / " << bar.runs[0].g_mzc_mm * 1e3 << " um, H "
            << xy.hysteresis[0].h_mm * 1e3 << " / " << bar.hysteresis[0].h_mm * 1e3 << " um, F_max "
            << *xy.runs[0].f_max_mm * 1e3 << " / " << *bar.runs[0].f_max_mm * 1e3
            << " um (x/y / radial)\n";
}

}  // namespace

TEST(Radial, BarLengthGivesTheHGFOfTheXyFormXY) {
  CircleProgram p;
  p.radial = true;
  expect_same_results(sim::simulate(machine_with_errors(), p));
}

TEST(Radial, BarLengthChangeWithBarLengthMetadataZX) {
  CircleProgram p;
  p.plane = Plane::ZX;
  p.radius_mm = 100.0;
  p.centre_mm[0] = 20.0, p.centre_mm[1] = -5.0, p.centre_mm[2] = -150.0;
  p.radial = true;
  p.bar_length_mm = 100.0;
  const Trace trace = sim::simulate(machine_with_errors(), p);
  ASSERT_NE(trace.metadata.find("bar_length_mm"), nullptr);
  EXPECT_LT(std::abs((*trace.column("r"))[5000]), 0.05);  // a change, not a length
  expect_same_results(trace);
}

TEST(Radial, TraceWithoutPositionColumnsIsRadial) {
  CircleProgram p;
  p.radial = true;
  Trace trace = sim::simulate(machine_with_errors(), p);
  EXPECT_FALSE(is_radial_trace(trace, Plane::XY));
  for (const char* drop : {"x", "y", "z"}) {
    const std::size_t i = trace.column_index(drop).value();
    trace.columns.erase(trace.columns.begin() + static_cast<std::ptrdiff_t>(i));
    trace.values.erase(trace.values.begin() + static_cast<std::ptrdiff_t>(i));
  }
  EXPECT_TRUE(is_radial_trace(trace, Plane::XY));
  EXPECT_TRUE(is_radial_trace(trace, Plane::ZX));
  const RadialPositions radial = radial_positions(trace, {});
  EXPECT_EQ(radial.column_a, "x_r");
  EXPECT_EQ(radial.centre_source, ValueSource::metadata);
  EXPECT_NE(radial.note.find("radial deviations only"), std::string::npos);
}

TEST(Radial, CentreFromTheCommandedArcsWithoutMetadata) {
  CircleProgram p;
  p.radial = true;
  p.centre_mm[0] = 12.5, p.centre_mm[1] = -40.0;
  Trace trace = sim::simulate({}, p);
  TraceMetadata kept;
  for (const auto& [k, v] : trace.metadata.entries())
    if (k != "centre_mm") kept.set(k, v);
  trace.metadata = kept;
  const RadialPositions radial = radial_positions(trace, {});
  EXPECT_EQ(radial.centre_source, ValueSource::commanded);
  EXPECT_NEAR(radial.centre_a_mm, 12.5, 1e-9);
  EXPECT_NEAR(radial.centre_b_mm, -40.0, 1e-9);
}

TEST(Radial, LengthChangeWithoutBarLengthIsRefused) {
  CircleProgram p;
  p.radial = true;
  p.bar_length_mm = 75.0;
  Trace trace = sim::simulate({}, p);
  TraceMetadata kept;
  for (const auto& [k, v] : trace.metadata.entries())
    if (k != "bar_length_mm") kept.set(k, v);
  trace.metadata = kept;
  try {
    radial_positions(trace, {});
    FAIL() << "a length change read as a length";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("bar_length_mm"), std::string::npos) << e.what();
  }
}

TEST(Radial, MissingCommandedColumnsAreAParseError) {
  Trace trace;
  trace.source = "bar.csv";
  trace.columns = {"t", "r"};
  trace.values = {{0.0}, {75.0}};
  trace.line_of_row = {2};
  EXPECT_THROW(radial_positions(trace, {}), ParseError);
}

namespace {

struct PolarPoint {
  double angle_deg;
  double deviation_um;
};

// Deviations of a known shape: two lobes, an offset and a step, CCW 0..360 then CW back.
std::vector<PolarPoint> polar_points() {
  std::vector<PolarPoint> pts;
  for (int i = 0; i <= 720; ++i) {
    const double a = i * 0.5;
    pts.push_back({a, 3.0 * std::sin(2 * a * std::numbers::pi / 180) + 1.25});
  }
  for (int i = 720; i >= 0; --i) {
    const double a = i * 0.5;
    pts.push_back({a, 2.5 * std::cos(2 * a * std::numbers::pi / 180) - 0.75 + (a > 180 ? 2 : 0)});
  }
  return pts;
}

Trace import_polar(const std::string& text, double radius_mm, Plane plane = Plane::XY) {
  ExportImportOptions o;
  o.radius_mm = radius_mm;
  o.plane = plane;
  return import_export_text(text, "e.txt", o);
}

}  // namespace

TEST(PolarImport, RoundTripsThroughTheTraceFormat) {
  const auto pts = polar_points();
  std::ostringstream text;
  text << "# exported by some ballbar software\nAngle[deg]\tDeviation[um]\n";
  text.precision(12);
  for (const auto& p : pts) text << p.angle_deg << '\t' << p.deviation_um << '\n';
  const Trace imported = import_polar(text.str(), 150.0, Plane::YZ);
  ASSERT_EQ(imported.rows(), pts.size());
  EXPECT_EQ(imported.line_of_row.front(), 3u);

  const std::string path =
      (std::filesystem::temp_directory_path() / "circtest-polar-roundtrip.csv").string();
  write_trace(path, imported);
  const Trace back = read_trace(path);
  std::filesystem::remove(path);
  const RadialPositions radial = radial_positions(back, {});
  const auto& a = *radial.trace.column(radial.column_a);
  const auto& b = *radial.trace.column(radial.column_b);
  const auto& segment = *back.column("segment");
  ASSERT_EQ(back.rows(), pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    double angle = std::atan2(b[i], a[i]) * 180.0 / std::numbers::pi;
    if (angle < -1e-9) angle += 360.0;
    if (pts[i].angle_deg == 360.0 && angle < 1.0) angle += 360.0;
    EXPECT_NEAR(angle, pts[i].angle_deg, 1e-6) << i;
    EXPECT_NEAR((std::hypot(a[i], b[i]) - 150.0) * 1e3, pts[i].deviation_um, 1.5e-3) << i;
    EXPECT_EQ(segment[i], i <= 720 ? 1.0 : 2.0) << i;
  }

  // F about the nominal centre is the extreme deviation of each run, by construction.
  EvaluationOptions o;
  o.column_a = radial.column_a;
  o.column_b = radial.column_b;
  o.f_centre = FCentre::nominal;
  const Evaluation ev = evaluate(radial.trace, o);
  ASSERT_EQ(ev.runs.size(), 2u);
  EXPECT_EQ(ev.runs[0].run.direction, Direction::CCW);
  EXPECT_EQ(ev.runs[1].run.direction, Direction::CW);
  EXPECT_NEAR(*ev.runs[0].f_max_mm * 1e3, 4.25, 2e-3);
  EXPECT_NEAR(*ev.runs[0].f_min_mm * 1e3, -1.75, 2e-3);
  EXPECT_NEAR(*ev.runs[1].f_max_mm * 1e3, 3.75, 2e-3);
  EXPECT_NEAR(*ev.runs[1].f_min_mm * 1e3, -3.25, 2e-3);
}

TEST(PolarImport, BadLinesNameFileAndLine) {
  try {
    import_polar("0 1\n1 2\n2 x\n", 50.0);
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("e.txt:3"), std::string::npos) << e.what();
  }
  try {
    import_polar("0 1 2\n", 50.0);
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("e.txt:1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(import_polar("angle_deg dev_um\n0 1\n", 50.0), ParseError);  // too few points
  EXPECT_EQ(import_polar("0;1\r\n1,2\r\n\n; note\n2\t3\r\n", 50.0).rows(), 3u);
}
