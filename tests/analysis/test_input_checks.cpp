// The input-consistency checks (analysis/input_checks) on traces from the test simulator,
// whose circle, plane and runs are known: each check must pass the good trace and refuse
// (or note) the one made inconsistent in a way seen on real traces.
#include "circtest/analysis/input_checks.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/segmentation.hpp"
#include "circtest/core/error.hpp"
#include "expect_error.hpp"
#include "machine_sim.hpp"

using namespace circtest;

namespace {

Trace simulated(Plane plane = Plane::XY) {
  sim::MachineModel m;
  m.x.backlash_mm = 0.005;
  m.noise_mm = 0.0002;
  sim::CircleProgram p;
  p.plane = plane;
  return sim::simulate(m, p);
}

std::vector<double>& column(Trace& t, const char* name) {
  return t.values[t.column_index(name).value()];
}

Segmentation segments(const Trace& t, Plane plane = Plane::XY) {
  return segment_trace(t, plane_columns(t, plane, "", ""), {});
}

std::span<const double> slice(const Trace& t, const char* name, const Run& r) {
  return std::span<const double>(*t.column(name)).subspan(r.begin, r.size());
}

}  // namespace

TEST(Units, InchProgramOnAMetricMachineKeepsItsPositions) {
  Trace t = simulated();
  t.metadata.set("units", "inch");
  const double x0 = column(t, "x")[1000];
  const auto note = resolve_units(t, Plane::XY, std::nullopt, {});
  ASSERT_TRUE(note.has_value());
  EXPECT_NE(note->find("the positions are in mm"), std::string::npos) << *note;
  EXPECT_EQ(column(t, "x")[1000], x0);
}

TEST(Units, PositionsInInchAreConvertedToMm) {
  const Trace mm = simulated();
  Trace t = mm;
  t.metadata.set("units", "inch");
  for (const char* c : {"x", "y", "z", "x_cmd", "y_cmd", "z_cmd"}) {
    for (double& v : column(t, c)) v /= 25.4;
  }
  const auto note = resolve_units(t, Plane::XY, std::nullopt, {});
  ASSERT_TRUE(note.has_value());
  EXPECT_NE(note->find("converted to mm (x 25.4)"), std::string::npos) << *note;
  for (std::size_t i = 0; i < t.rows(); i += 997) {
    EXPECT_NEAR((*t.column("x"))[i], (*mm.column("x"))[i], 1e-12);
    EXPECT_NEAR((*t.column("y_cmd"))[i], (*mm.column("y_cmd"))[i], 1e-12);
    EXPECT_EQ((*t.column("t"))[i], (*mm.column("t"))[i]);              // time untouched
    EXPECT_EQ((*t.column("segment"))[i], (*mm.column("segment"))[i]);  // ids untouched
  }
}

TEST(Units, WithoutANominalRadiusTheOptionDecides) {
  Trace t = simulated();
  t.metadata = {};
  t.metadata.set("units", "inch");
  EXPECT_ERROR(resolve_units(t, Plane::XY, std::nullopt, {}), ExitCode::data,
               "metadata 'units: inch': the program ran in inch, but the positions may be in "
               "inch or in mm");
  InputCheckOptions o;
  o.position_units = PositionUnits::mm;
  EXPECT_TRUE(resolve_units(t, Plane::XY, std::nullopt, o).has_value());
  // A circle that matches neither reading is refused too.
  EXPECT_ERROR(resolve_units(t, Plane::XY, 30.0, {}), ExitCode::data,
               "is within 10 % of neither the nominal radius 30.0000 mm");
}

TEST(PlaneMotion, APlaneWithoutMotionIsRefusedNamingTheRanges) {
  const Trace t = simulated(Plane::XY);
  check_plane_motion(t, Plane::XY, plane_columns(t, Plane::XY, "", ""));  // passes
  EXPECT_ERROR(check_plane_motion(t, Plane::ZX, plane_columns(t, Plane::ZX, "", "")),
               ExitCode::data, "plane ZX: z moves 0.00");
  EXPECT_ERROR(check_plane_motion(t, Plane::YZ, plane_columns(t, Plane::YZ, "", "")),
               ExitCode::data, "plane YZ: y moves 150.0");
}

TEST(NominalRadius, FarFromTheMeasuredCircleIsRefusedOrNoted) {
  const Trace t = simulated();
  const Segmentation s = segments(t);
  const circtest::Run& r = s.runs.front();
  const double fitted = fit_lsc(slice(t, "x", r), slice(t, "y", r)).radius_mm;
  EXPECT_NEAR(fitted, 75.0, 0.01);
  EXPECT_FALSE(check_nominal_radius(t, 1, r, fitted, 75.0, "metadata", {}).has_value());
  // 1 % of 75 mm is the default tolerance.
  EXPECT_FALSE(check_nominal_radius(t, 1, r, fitted, 74.3, "option", {}).has_value());
  EXPECT_ERROR(check_nominal_radius(t, 1, r, fitted, 50.0, "option", {}), ExitCode::data,
               "differs from the nominal radius 50.0000 mm (option) by +25.0");
  InputCheckOptions wide;
  wide.radius_tolerance_mm = 30.0;
  EXPECT_FALSE(check_nominal_radius(t, 1, r, fitted, 50.0, "option", wide).has_value());
  InputCheckOptions warn;
  warn.warn_only = true;
  const auto note = check_nominal_radius(t, 1, r, fitted, 50.0, "option", warn);
  ASSERT_TRUE(note.has_value());
  EXPECT_EQ(note->rfind("warning: run 1 (lines ", 0), 0u) << *note;
}

TEST(RunArc, ARunCutOffIsRefusedOrNoted) {
  Trace t = simulated();
  t.metadata.set("arc_deg", "360");
  const Segmentation whole = segments(t);
  for (std::size_t k = 0; k < whole.runs.size(); ++k) {
    EXPECT_FALSE(check_run_arc(t, k + 1, whole.runs[k], {}).has_value());
  }
  // The recording stops half-way through the second run.
  const circtest::Run& second = whole.runs[1];
  const std::size_t keep = second.begin + second.size() / 2;
  for (auto& c : t.values) c.resize(keep);
  t.line_of_row.resize(keep);
  const Segmentation cut = segments(t);
  ASSERT_EQ(cut.runs.size(), 2u);
  EXPECT_NEAR(cut.runs[1].sweep_deg, 180.0, 1.0);
  EXPECT_ERROR(check_run_arc(t, 2, cut.runs[1], {}), ExitCode::data,
               "of the 360.0 deg the program ran (arc_deg, line ");
  InputCheckOptions warn;
  warn.warn_only = true;
  EXPECT_TRUE(check_run_arc(t, 2, cut.runs[1], warn).has_value());
}

TEST(Outliers, OneRowOffTheCircleIsNamedByItsLine) {
  Trace t = simulated();
  const Segmentation s = segments(t);
  const circtest::Run& r = s.runs.front();
  const Circle c = fit_lsc(slice(t, "x", r), slice(t, "y", r));
  check_outliers(t, 1, r, slice(t, "x", r), slice(t, "y", r), c);  // the clean run passes
  // The case: y = 0 on one row of a D150 run, at 100 deg (x = -13 mm).
  std::size_t row = r.begin;
  while (std::atan2((*t.column("y"))[row], (*t.column("x"))[row]) < 100.0 / 180 * M_PI) ++row;
  column(t, "y")[row] = 0.0;
  const Circle c2 = fit_lsc(slice(t, "x", r), slice(t, "y", r));
  EXPECT_ERROR(check_outliers(t, 1, r, slice(t, "x", r), slice(t, "y", r), c2), ExitCode::data,
               t.source + ":" + std::to_string(t.line_of_row[row]) + ": run 1: an outlier");
}

TEST(Segmentation, OneMarkedSpanHoldingBothDirectionsIsSplitAtTheReversal) {
  Trace t = simulated();
  const Segmentation two = segments(t);
  ASSERT_EQ(two.runs.size(), 2u);
  // One marker span, one segment id, from the first run's start to the second's end: what
  // a program without a marker gap between CCW and CW records.
  auto& marker = column(t, "marker");
  auto& segment = column(t, "segment");
  for (std::size_t i = two.runs[0].begin; i < two.runs[1].end; ++i) {
    marker[i] = 1.0;
    segment[i] = 1.0;
  }
  const Segmentation s = segments(t);
  ASSERT_EQ(s.runs.size(), 2u);
  EXPECT_EQ(s.runs[0].direction, Direction::CCW);
  EXPECT_EQ(s.runs[1].direction, Direction::CW);
  // Each: its 360 deg plus the lead arcs (30 deg each) now inside the span.
  EXPECT_NEAR(s.runs[0].sweep_deg, 390.0, 1.0);
  EXPECT_NEAR(s.runs[1].sweep_deg, 390.0, 1.0);
  // Split at the turn: between the two runs.
  EXPECT_GE(s.runs[0].end, two.runs[0].end);
  EXPECT_LE(s.runs[1].begin, two.runs[1].begin);
  EXPECT_EQ(s.runs[1].begin, s.runs[0].end);
  ASSERT_EQ(s.notes.size(), 1u);
  EXPECT_NE(s.notes[0].find("holds both directions: split where the rotation reverses"),
            std::string::npos)
      << s.notes[0];
  EXPECT_TRUE(two.notes.empty());
}

// Library text names no command-line option: a remedy is named by the words the
// caller gives (circana: its options, tested with the CLI), else by the library's own.
TEST(Remedies, TheLibrarysOwnWordsNameNoOption) {
  const Trace t = simulated();
  const Segmentation s = segments(t);
  const circtest::Run& r = s.runs.front();
  const double fitted = fit_lsc(slice(t, "x", r), slice(t, "y", r)).radius_mm;
  try {
    (void)check_nominal_radius(t, 1, r, fitted, 50.0, "option", {});
    FAIL() << "expected a refusal";
  } catch (const DataError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("mm (the radius tolerance setting): F would"), std::string::npos) << m;
    EXPECT_NE(m.find("(the warn-only setting to evaluate anyway)"), std::string::npos) << m;
    EXPECT_EQ(m.find("--"), std::string::npos) << m;
  }
  Trace inch = simulated();
  inch.metadata = {};
  inch.metadata.set("units", "inch");
  try {
    (void)resolve_units(inch, Plane::XY, std::nullopt, {});
    FAIL() << "expected a refusal";
  } catch (const DataError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(": give the position unit inch or the position unit mm"), std::string::npos)
        << m;
    EXPECT_EQ(m.find("--"), std::string::npos) << m;
  }
}

TEST(Remedies, TheCallersWordsNameTheRemedy) {
  Trace t = simulated();
  InputCheckOptions options;
  options.remedy_words = [](Remedy remedy) -> std::string_view {
    return remedy == Remedy::units_inch ? "<inch>" : remedy == Remedy::units_mm ? "<mm>" : "<?>";
  };
  t.metadata = {};
  t.metadata.set("units", "inch");
  EXPECT_ERROR(resolve_units(t, Plane::XY, std::nullopt, options), ExitCode::data,
               "radius_mm to tell which: give <inch> or <mm>");
  const Trace flat = simulated();
  EXPECT_ERROR(check_plane_motion(flat, Plane::ZX, plane_columns(flat, Plane::ZX, "", ""),
                                  options.remedy_words),
               ExitCode::data, "give the plane of the test with <?>");
}

TEST(Remedies, TheEvaluationsNotesAndRefusalsUseTheLibrarysWords) {
  // No radius, no centre: neither metadata nor commanded columns give them.
  Trace t = simulated();
  t.metadata = {};
  for (const char* name : {"x_cmd", "y_cmd", "z_cmd"}) {
    const auto i = static_cast<std::ptrdiff_t>(t.column_index(name).value());
    t.columns.erase(t.columns.begin() + i);
    t.values.erase(t.values.begin() + i);
  }
  const Evaluation ev = evaluate(t, {});
  bool noted = false;
  for (const std::string& n : ev.notes) {
    EXPECT_EQ(n.find("--"), std::string::npos) << n;
    noted = noted || n == "F not computed: no nominal radius (give the nominal radius setting, a "
                          "radius_mm metadata line, or commanded columns)";
  }
  EXPECT_TRUE(noted);
  EvaluationOptions nominal;
  nominal.f_centre = FCentre::nominal;
  EXPECT_ERROR(evaluate(t, nominal), ExitCode::usage,
               "F about the nominal centre needs the set-up centre: give the set-up centre "
               "setting A,B or a centre_mm metadata line");
}
