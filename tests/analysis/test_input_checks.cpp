// The input-consistency checks (analysis/input_checks) on traces from the test simulator,
// whose circle, plane and runs are known: each check must pass the good trace and refuse
// (or note) the one made inconsistent in a way seen on real traces.
#include "circtest/analysis/input_checks.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/segmentation.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace_keys.hpp"
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

// A trace in inch is checked at the same physical sizes as the same trace in mm: resolve_units
// converts it first, so every bound (in mm) sees mm. Each class below builds a known trace in
// mm, its copy in inch (every length column / 25.4 under `units: inch`, as LinuxCNC logs an
// inch machine), and checks that both are accepted with equal results, or both refused, on
// each side of the bound; the inch refusal says its sizes in inch and mm. A bound applied to
// the inch values unconverted would accept 25.4 x too much (or refuse 25.4 x too little).
namespace {

// A 2 mm radius circle: small enough that the fixed floors of the bounds (0.05 mm) decide.
Trace small_circle() {
  sim::MachineModel m;
  m.noise_mm = 0.0002;
  sim::CircleProgram p;
  p.radius_mm = 2.0;
  p.feed_mm_per_min = 300.0;
  return sim::simulate(m, p);
}

Trace in_inch(const Trace& mm) {
  Trace t = mm;
  t.metadata.set("units", "inch");
  for (std::size_t c = 0; c < t.columns.size(); ++c) {
    if (t.columns[c] == "t" || column_name::is_integer(t.columns[c])) continue;
    for (double& v : t.values[c]) v /= 25.4;
  }
  return t;
}

struct Outcome {
  std::optional<Evaluation> evaluation;
  std::string refusal;
};

// As circana evaluates a trace: its units resolved, then the evaluation.
Outcome evaluated(Trace t, EvaluationOptions options = {}) {
  try {
    (void)resolve_units(t, options.plane, options.nominal_radius_mm, options.input_checks);
    return {evaluate(t, options), ""};
  } catch (const Error& e) {
    return {std::nullopt, e.what()};
  }
}

// The mm trace and its inch copy both refused, the inch refusal containing `inch_words`.
void expect_both_refused(const Trace& mm, const std::string& words, const std::string& inch_words,
                         const EvaluationOptions& options = {}) {
  const Outcome a = evaluated(mm, options);
  const Outcome b = evaluated(in_inch(mm), options);
  EXPECT_FALSE(a.evaluation.has_value());
  EXPECT_FALSE(b.evaluation.has_value());
  EXPECT_NE(a.refusal.find(words), std::string::npos) << a.refusal;
  EXPECT_NE(b.refusal.find(words), std::string::npos) << b.refusal;
  EXPECT_NE(b.refusal.find(inch_words), std::string::npos) << b.refusal;
  EXPECT_EQ(a.refusal.find(" in ("), std::string::npos) << a.refusal;
}

// Both accepted, with the results of the inch copy those of the mm trace.
void expect_both_equal(const Trace& mm) {
  const Outcome a = evaluated(mm);
  const Outcome b = evaluated(in_inch(mm));
  ASSERT_TRUE(a.evaluation.has_value()) << a.refusal;
  ASSERT_TRUE(b.evaluation.has_value()) << b.refusal;
  ASSERT_EQ(a.evaluation->runs.size(), b.evaluation->runs.size());
  for (std::size_t k = 0; k < a.evaluation->runs.size(); ++k) {
    const RunResult& ra = a.evaluation->runs[k];
    const RunResult& rb = b.evaluation->runs[k];
    EXPECT_NEAR(rb.lsc.radius_mm, ra.lsc.radius_mm, 1e-9);
    EXPECT_NEAR(rb.g_mzc_mm, ra.g_mzc_mm, 1e-9);
    EXPECT_NEAR(rb.f_max_mm.value(), ra.f_max_mm.value(), 1e-9);
    EXPECT_NEAR(rb.f_min_mm.value(), ra.f_min_mm.value(), 1e-9);
    ASSERT_EQ(ra.feed_mm_per_min.has_value(), rb.feed_mm_per_min.has_value());
    if (ra.feed_mm_per_min) {
      EXPECT_NEAR(*rb.feed_mm_per_min, *ra.feed_mm_per_min, 1e-6);
    }
  }
  ASSERT_EQ(a.evaluation->hysteresis.size(), 1u);
  EXPECT_NEAR(b.evaluation->hysteresis[0].h_mm, a.evaluation->hysteresis[0].h_mm, 1e-9);
}

// The rows of the first marked run.
std::pair<std::size_t, std::size_t> first_run(const Trace& t) {
  const Segmentation s = segments(t);
  return {s.runs.front().begin, s.runs.front().end};
}

}  // namespace

TEST(InchBounds, ResultsAreTheMmOnes) {
  const Trace mm = small_circle();
  expect_both_equal(mm);
  // The simulator's feed: 300 mm/min measured from the time column in both.
  EXPECT_NEAR(evaluated(in_inch(mm)).evaluation->runs[0].feed_mm_per_min.value(), 300.0, 1.0);
}

TEST(InchBounds, OffPlaneMotionAtTheSameSize) {
  // z rises steadily over the first run; z may move max(0.05 mm, 10 % of the 4 mm the plane's
  // columns move) = 0.4 mm: 0.5 mm is refused, 0.3 mm accepted (0.3 mm = 0.0118 in, which a
  // 0.05 bound taken on the inch values would also accept, and 0.5 mm = 0.0197 in too).
  const auto ramp = [](double mm_total) {
    Trace t = small_circle();
    const auto [begin, end] = first_run(t);
    for (std::size_t i = begin; i < end; ++i) {
      column(t, "z")[i] +=
          mm_total * static_cast<double>(i - begin) / static_cast<double>(end - 1 - begin);
    }
    return t;
  };
  expect_both_refused(ramp(0.5), "the run is not in the plane XY (z may move at most",
                      "z moves 0.01968 in (0.500 mm) while x moves 0.157");
  expect_both_refused(ramp(0.5), "", "z may move at most 0.0157");
  expect_both_equal(ramp(0.3));
}

TEST(InchBounds, NominalRadiusAgreementAtTheSameSize) {
  // The default tolerance at 2 mm: its 0.05 mm floor. radius_mm is in mm in both traces.
  const auto nominal = [](const char* radius_mm) {
    Trace t = small_circle();
    t.metadata.set("radius_mm", radius_mm);
    return t;
  };
  expect_both_refused(nominal("2.06"), "differs from the nominal radius",
                      "nominal radius 0.081102 in (2.0600 mm) (metadata) by -0.00236");
  expect_both_refused(nominal("2.06"), "", "more than the tolerance 0.001969 in (0.0500 mm)");
  expect_both_equal(nominal("2.04"));
  // --radius-tolerance is in mm for either trace.
  EvaluationOptions wide;
  wide.input_checks.radius_tolerance_mm = 0.07;
  const Outcome a = evaluated(nominal("2.06"), wide);
  const Outcome b = evaluated(in_inch(nominal("2.06")), wide);
  EXPECT_TRUE(a.evaluation.has_value()) << a.refusal;
  EXPECT_TRUE(b.evaluation.has_value()) << b.refusal;
}

TEST(InchBounds, OutliersAtTheSameSize) {
  // One row of the first run pushed out radially: 0.06 mm is beyond the 0.05 mm floor.
  const auto pushed = [](double mm) {
    Trace t = small_circle();
    const auto [begin, end] = first_run(t);
    const std::size_t row = (begin + end) / 2;
    const double x = column(t, "x")[row], y = column(t, "y")[row];
    const double r = std::hypot(x, y);
    column(t, "x")[row] = x * (r + mm) / r;
    column(t, "y")[row] = y * (r + mm) / r;
    return t;
  };
  expect_both_refused(pushed(0.06), "an outlier", "(beyond 0.001969 in (0.0500 mm))");
  const Outcome a = evaluated(pushed(0.04));
  const Outcome b = evaluated(in_inch(pushed(0.04)));
  ASSERT_TRUE(a.evaluation.has_value()) << a.refusal;
  ASSERT_TRUE(b.evaluation.has_value()) << b.refusal;
  EXPECT_NEAR(b.evaluation->runs[0].g_mzc_mm, a.evaluation->runs[0].g_mzc_mm, 1e-9);
  EXPECT_GT(a.evaluation->runs[0].g_mzc_mm, 0.035);  // the row sets G
}

TEST(InchBounds, PlaneWithoutMotionNamedInInchAndMm) {
  EvaluationOptions zx;
  zx.plane = Plane::ZX;
  Trace mm = small_circle();
  mm.metadata.set("plane", "ZX");
  // resolve_units reads the plane's columns (z does not move): the option decides the unit.
  zx.input_checks.position_units = PositionUnits::inch;
  const Outcome b = evaluated(in_inch(mm), zx);
  ASSERT_FALSE(b.evaluation.has_value());
  EXPECT_NE(b.refusal.find("plane ZX: z moves 0.00005 in (0.001 mm) and x 0.15751 in (4.001 mm)"),
            std::string::npos)
      << b.refusal;
}

TEST(InchBounds, FeedBoundAtTheSameSize) {
  // The time column compressed so that the runs run at 2e6 mm/min, beyond the 1e6 bound; at
  // 5e5 within it. No sample_period_s: the time check would refuse the compression first.
  const auto fast = [](double factor) {
    Trace t = small_circle();
    t.metadata = {};
    t.metadata.set("radius_mm", "2");
    t.metadata.set("plane", "XY");
    for (double& v : column(t, "t")) v /= factor;
    return t;
  };
  const Outcome a = evaluated(fast(2000.0 / 0.3));
  const Outcome b = evaluated(in_inch(fast(2000.0 / 0.3)));
  ASSERT_TRUE(a.evaluation.has_value()) << a.refusal;
  ASSERT_TRUE(b.evaluation.has_value()) << b.refusal;
  EXPECT_FALSE(a.evaluation->runs[0].feed_mm_per_min.has_value());
  EXPECT_FALSE(b.evaluation->runs[0].feed_mm_per_min.has_value());
  const auto has = [](const Evaluation& e, const std::string& words) {
    return std::any_of(e.notes.begin(), e.notes.end(),
                       [&](const std::string& n) { return n.find(words) != std::string::npos; });
  };
  EXPECT_TRUE(has(*a.evaluation, "mm/min (t from")) << a.evaluation->notes.front();
  EXPECT_TRUE(has(*b.evaluation, "in/min (20000")) << b.evaluation->notes.front();
  EXPECT_TRUE(has(*b.evaluation, "above any machine's 39370.079 in/min (1000000 mm/min)"));
  expect_both_equal(fast(500.0 / 0.3));
  EXPECT_NEAR(evaluated(in_inch(fast(500.0 / 0.3))).evaluation->runs[0].feed_mm_per_min.value(),
              5e5, 2e3);
}

TEST(InchBounds, AnInchProgramsFeedWordsAreInchPerMinute) {
  // circgen's segments give each run's F word in the program's units: F11.811 in an inch
  // program is the 300 mm/min of F300 in a mm one.
  Trace mm = small_circle();
  mm.metadata.set("segments", "1:CCW:F300:XY,2:CW:F300:XY");
  Trace inch = in_inch(mm);
  inch.metadata.set("segments", "1:CCW:F11.811:XY,2:CW:F11.811:XY");
  const Segmentation s = segments(mm);
  const auto fa = announced_run_feeds(mm, s.runs);
  const auto fb = announced_run_feeds(inch, s.runs);
  ASSERT_EQ(fa.size(), 2u);
  ASSERT_EQ(fb.size(), 2u);
  EXPECT_DOUBLE_EQ(fa[0].value(), 300.0);
  EXPECT_NEAR(fb[0].value(), 300.0, 0.001);
  EXPECT_NEAR(fb[1].value(), 300.0, 0.001);
}

TEST(InchBounds, WithoutATimeColumnTheLagOfAnInchTraceIsTheMmOne) {
  // Without a time column the runs' feeds come from the program's F words: the servo lag in
  // ms (lag in mm over the feed) of the inch copy is the mm trace's, not 25.4 x it.
  sim::MachineModel m;
  m.x.kv_per_s = 40.0;
  m.y.kv_per_s = 30.0;
  m.noise_mm = 0.0002;
  sim::CircleProgram p;
  p.feed_mm_per_min = 3000.0;
  Trace mm = sim::simulate(m, p);
  const std::size_t t = mm.column_index("t").value();
  mm.columns.erase(mm.columns.begin() + static_cast<std::ptrdiff_t>(t));
  mm.values.erase(mm.values.begin() + static_cast<std::ptrdiff_t>(t));
  mm.metadata = {};
  mm.metadata.set("radius_mm", "75");
  mm.metadata.set("segments", "1:CCW:F3000:XY,2:CW:F3000:XY");
  Trace inch = in_inch(mm);
  inch.metadata.set("segments", "1:CCW:F118.11:XY,2:CW:F118.11:XY");  // 3000 mm/min in in/min
  ASSERT_TRUE(resolve_units(inch, Plane::XY, std::nullopt, {}).has_value());
  const Diagnosis a = diagnose(mm);
  const Diagnosis b = diagnose(inch);
  ASSERT_EQ(b.feeds_mm_per_min.size(), 1u);
  EXPECT_NEAR(b.feeds_mm_per_min[0], 3000.0, 0.01);
  ASSERT_TRUE(a.servo_mismatch_ms.value.has_value());
  ASSERT_TRUE(b.servo_mismatch_ms.value.has_value());
  // The simulated mismatch: 1/40 - 1/30 s.
  EXPECT_NEAR(*a.servo_mismatch_ms.value, 1e3 / 40.0 - 1e3 / 30.0, 1.0);
  EXPECT_NEAR(*b.servo_mismatch_ms.value, *a.servo_mismatch_ms.value, 0.01);
}
