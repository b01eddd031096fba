// The ISO 230-4 results of simulated machines against the first-order closed forms of
// the summary (docs/iso230-4-summary.md "Physical relations"): the injected errors are the truth.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace_keys.hpp"
#include "machine_sim.hpp"

using namespace circtest;
using sim::CircleProgram;
using sim::MachineModel;

namespace {

constexpr double kR = 75.0;

Evaluation run(const MachineModel& m, CircleProgram p = {}, EvaluationOptions o = {}) {
  return evaluate(sim::simulate(m, p), o);
}

// Coefficients of r(theta) = c0 + c2 cos 2theta + s2 sin 2theta about a centre, over a run.
struct TwoLobe {
  double c0, c2, s2;
};
TwoLobe two_lobe(const Trace& trace, const RunResult& r, double ca, double cb) {
  const auto& x = *trace.column("x");
  const auto& y = *trace.column("y");
  double s0 = 0, sc = 0, ss = 0;
  const double n = static_cast<double>(r.run.size());
  for (std::size_t i = r.run.begin; i < r.run.end; ++i) {
    const double th = std::atan2(y[i] - cb, x[i] - ca);
    // Less the LSC radius: a run a few samples short of 360 deg would leak the mean into
    // the harmonics.
    const double rad = std::hypot(x[i] - ca, y[i] - cb) - r.lsc.radius_mm;
    s0 += rad;
    sc += rad * std::cos(2 * th);
    ss += rad * std::sin(2 * th);
  }
  return {s0 / n + r.lsc.radius_mm, 2 * sc / n, 2 * ss / n};
}

}  // namespace

TEST(Evaluation, PerfectMachineGivesZeroErrors) {
  const Evaluation ev = run({});
  ASSERT_EQ(ev.runs.size(), 2u);
  EXPECT_EQ(ev.segmentation, SegmentationMethod::marker);
  EXPECT_EQ(ev.runs[0].run.direction, Direction::CCW);
  EXPECT_EQ(ev.runs[0].label, "XY");
  EXPECT_EQ(ev.runs[1].run.direction, Direction::CW);
  EXPECT_EQ(ev.runs[1].label, "YX");
  for (const auto& r : ev.runs) {
    EXPECT_NEAR(r.run.sweep_deg, 360.0, 0.2);
    EXPECT_LT(r.g_mzc_mm, 1e-9);
    EXPECT_NEAR(*r.f_max_mm, 0.0, 1e-9);
    EXPECT_NEAR(*r.f_min_mm, 0.0, 1e-9);
    EXPECT_NEAR(*r.feed_mm_per_min, 1000.0, 5.0);
  }
  ASSERT_EQ(ev.hysteresis.size(), 1u);
  EXPECT_LT(ev.hysteresis[0].h_mm, 1e-9);
  EXPECT_EQ(ev.nominal_radius_source, ValueSource::metadata);
}

TEST(Evaluation, BacklashGivesHEqualToThePlay) {
  MachineModel m;
  m.x.backlash_mm = 0.020;
  const Evaluation ev = run(m);
  ASSERT_EQ(ev.hysteresis.size(), 1u);
  EXPECT_NEAR(ev.hysteresis[0].h_mm, 0.020, 0.01 * 0.020);
  // The step sits at the X reversals, 0 or 180 deg.
  const double at = ev.hysteresis[0].at_angle_deg;
  EXPECT_TRUE(std::min({std::abs(at), std::abs(at - 180.0), std::abs(at - 360.0)}) < 5.0) << at;
}

TEST(Evaluation, SquarenessGivesGOfAlphaTimesR) {
  MachineModel m;
  m.squareness_rad = 100e-6;
  const Evaluation ev = run(m);
  const double g = 100e-6 * kR;  // dr = (alpha R / 2) sin 2theta: zone alpha R
  for (const auto& r : ev.runs) {
    EXPECT_NEAR(r.g_mzc_mm, g, 0.01 * g) << r.label;
    EXPECT_NEAR(r.g_lsc_mm, g, 0.01 * g) << r.label;
    EXPECT_NEAR(*r.f_max_mm, g / 2, 0.01 * g) << r.label;
    EXPECT_NEAR(*r.f_min_mm, -g / 2, 0.01 * g) << r.label;
  }
  EXPECT_LT(ev.hysteresis[0].h_mm, 0.01 * g);  // the same ellipse in both directions
}

TEST(Evaluation, ScaleErrorsGiveEllipseAndRadiusChange) {
  MachineModel m;
  m.x.scale = 50e-6;
  m.y.scale = -30e-6;
  const Evaluation ev = run(m);
  const double mean = kR * (50e-6 - 30e-6) / 2, half = kR * (50e-6 + 30e-6) / 2;
  for (const auto& r : ev.runs) {
    EXPECT_NEAR(r.g_mzc_mm, 2 * half, 0.01 * 2 * half);
    EXPECT_NEAR(*r.f_max_mm, mean + half, 0.01 * 2 * half);
    EXPECT_NEAR(*r.f_min_mm, mean - half, 0.01 * 2 * half);
  }
}

TEST(Evaluation, FollowingErrorShrinksTheRadiusWithFeed) {
  MachineModel m;
  m.x.kv_per_s = m.y.kv_per_s = 30.0;
  for (double feed : {1000.0, 2000.0}) {
    CircleProgram p;
    p.feed_mm_per_min = feed;
    const Evaluation ev = run(m, p);
    const double v = feed / 60.0;
    const double loss = -v * v / (2 * kR * 30.0 * 30.0);
    for (const auto& r : ev.runs) {
      EXPECT_NEAR(*r.f_max_mm, loss, 0.01 * std::abs(loss)) << feed;
      EXPECT_NEAR(*r.f_min_mm, loss, 0.01 * std::abs(loss)) << feed;
      EXPECT_LT(r.g_mzc_mm, 0.01 * std::abs(loss));
    }
  }
}

TEST(Evaluation, GainMismatchTiltFlipsWithDirection) {
  MachineModel m;
  m.x.kv_per_s = 30.0;
  m.y.kv_per_s = 32.0;
  CircleProgram p;
  const Trace trace = sim::simulate(m, p);
  const Evaluation ev = evaluate(trace, {});
  const double v = p.feed_mm_per_min / 60.0;
  const double amp = v / 2 * (1 / 30.0 - 1 / 32.0);  // of sin 2theta, CCW
  for (const auto& r : ev.runs) {
    EXPECT_NEAR(r.g_mzc_mm, 2 * amp, 0.01 * 2 * amp) << r.label;
    const TwoLobe f = two_lobe(trace, r, r.lsc.centre_a_mm, r.lsc.centre_b_mm);
    const double expect = r.run.direction == Direction::CCW ? amp : -amp;
    EXPECT_NEAR(f.s2, expect, 0.01 * amp) << r.label;
  }
  // Opposite tilts: the paths differ by amp sin 2theta - (-amp sin 2theta), 2 amp at 45 deg.
  EXPECT_NEAR(ev.hysteresis[0].h_mm, 2 * amp, 0.01 * 2 * amp);
}

TEST(Evaluation, TemperatureCorrectionTo20Degrees) {
  EvaluationOptions o;
  o.temperatures.machine_C = 25.0;
  o.temperatures.instrument_C = 22.0;
  o.temperatures.instrument_expansion_per_K = 1e-6;
  const Evaluation ev = run({}, {}, o);
  const double f = kR * (1e-6 * 2.0 - 11.5e-6 * 5.0);
  EXPECT_NEAR(*ev.runs[0].f_max_mm, f, 1e-9);
  EXPECT_NEAR(*ev.runs[0].f_min_mm, f, 1e-9);
  EXPECT_NEAR(ev.runs[0].g_mzc_mm, 0.0, 1e-9);  // G needs no calibrated radius
}

TEST(Evaluation, PartialArcUsesTheNominalCentre) {
  MachineModel m;
  m.x.scale = m.y.scale = 40e-6;
  CircleProgram p;
  p.arc_deg = 120.0;
  p.start_deg = 30.0;
  p.centre_mm[0] = 0.0;
  const Evaluation ev = run(m, p);
  ASSERT_EQ(ev.runs.size(), 2u);
  for (const auto& r : ev.runs) {
    EXPECT_NEAR(r.run.sweep_deg, 120.0, 0.2);
    EXPECT_EQ(r.f_centre_method, FCentreMethod::nominal);
    EXPECT_NEAR(*r.f_max_mm, kR * 40e-6, 1e-7);
    EXPECT_NEAR(*r.f_min_mm, kR * 40e-6, 1e-7);
  }
}

TEST(Evaluation, ArcShorterThan90DegreesIsRefused) {
  CircleProgram p;
  p.arc_deg = 60.0;
  try {
    run({}, p);
    FAIL() << "expected an error";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("sweeps 60.0 deg: expected an arc of at least 90 deg"),
              std::string::npos)
        << e.what();
    EXPECT_GT(e.line(), 0u);
  }
}

namespace {

// evaluate(TRACE) refuses a non-finite sample in ROWS with a DataError at the first row's line
// of the trace's file: "WHAT (lines FIRST-LAST): circle fit: ...".
void expect_fit_refusal(const Trace& trace, const circtest::Run& rows, const std::string& what) {
  const std::string lines = std::to_string(trace.line_of_row[rows.begin]) + "-" +
                            std::to_string(trace.line_of_row[rows.end - 1]);
  try {
    evaluate(trace, {});
    FAIL() << "expected an error";
  } catch (const DataError& e) {
    EXPECT_EQ(e.file(), trace.source);
    EXPECT_EQ(e.line(), trace.line_of_row[rows.begin]);
    EXPECT_EQ(e.detail(),
              what + " (lines " + lines + "): circle fit: a coordinate is not a finite number");
  }
}

}  // namespace

TEST(Evaluation, AFitsRefusalNamesTheFileAndTheRunsLines) {
  Trace trace = sim::simulate({}, {});
  trace.source = "t.csv";
  const Evaluation good = evaluate(trace, {});
  ASSERT_EQ(good.runs.size(), 2u);
  // A sample the reader would refuse, put straight into the second run: the circle fit sees it.
  const circtest::Run second = good.runs[1].run;
  const std::size_t row = (second.begin + second.end) / 2;
  trace.values[trace.column_index("x").value()][row] = std::numeric_limits<double>::quiet_NaN();
  expect_fit_refusal(trace, second, "run 2");
}

TEST(Evaluation, TheCommandedCircleFitsRefusalNamesTheFileAndTheLines) {
  // No radius or centre in the metadata: the first run's commanded columns give them, and a
  // bad commanded sample there is refused naming the run's lines (once a bare "circle fit").
  Trace trace = sim::simulate({}, {});
  trace.source = "cmd.csv";
  trace.metadata = {};
  const Evaluation good = evaluate(trace, {});
  ASSERT_EQ(good.nominal_radius_source, ValueSource::commanded);
  const circtest::Run first = good.runs[0].run;
  trace.values[trace.column_index("y_cmd").value()][first.begin + 5] =
      std::numeric_limits<double>::infinity();
  expect_fit_refusal(trace, first, "commanded circle of run 1");
}

TEST(Evaluation, PlanesAndLabels) {
  MachineModel m;
  m.squareness_rad = 100e-6;
  for (Plane plane : {Plane::YZ, Plane::ZX}) {
    CircleProgram p;
    p.plane = plane;
    p.centre_mm[0] = 100;
    p.centre_mm[1] = -50;
    p.centre_mm[2] = 200;
    const Evaluation ev = run(m, p);
    ASSERT_EQ(ev.runs.size(), 2u);
    EXPECT_EQ(ev.plane, plane);
    EXPECT_EQ(ev.runs[0].label, direction_label(plane, Direction::CCW));
    EXPECT_EQ(ev.runs[1].label, direction_label(plane, Direction::CW));
    EXPECT_NEAR(ev.runs[0].g_mzc_mm, 100e-6 * kR, 0.01 * 100e-6 * kR);
  }
}

TEST(Evaluation, AutomaticSegmentationFindsTheMeasuredArcs) {
  MachineModel m;
  m.x.backlash_mm = 0.010;
  m.squareness_rad = 50e-6;
  CircleProgram p;
  p.centre_mm[0] = 1200.0;  // far from the origin
  p.centre_mm[1] = -800.0;
  Trace with = sim::simulate(m, p);
  Trace without = with;
  for (const char* name : {"marker", "segment"}) {
    const auto i = static_cast<std::ptrdiff_t>(without.column_index(name).value());
    without.columns.erase(without.columns.begin() + i);
    without.values.erase(without.values.begin() + i);
  }
  const Evaluation a = evaluate(with, {});
  const Evaluation b = evaluate(without, {});
  EXPECT_EQ(b.segmentation, SegmentationMethod::automatic);
  ASSERT_EQ(b.runs.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(b.runs[i].run.direction, a.runs[i].run.direction);
    EXPECT_NEAR(b.runs[i].run.sweep_deg, 360.0, 1.0);
    EXPECT_NEAR(b.runs[i].g_mzc_mm, a.runs[i].g_mzc_mm, 0.02 * a.runs[i].g_mzc_mm);
  }
  EXPECT_NEAR(b.hysteresis[0].h_mm, a.hysteresis[0].h_mm, 0.02 * a.hysteresis[0].h_mm);
}

TEST(Evaluation, FeedSweepPairsEachCcwWithItsCw) {
  CircleProgram p;
  p.runs = {Direction::CCW, Direction::CW, Direction::CCW, Direction::CW};
  MachineModel m;
  m.y.backlash_mm = 0.008;
  const Evaluation ev = run(m, p);
  ASSERT_EQ(ev.runs.size(), 4u);
  ASSERT_EQ(ev.hysteresis.size(), 2u);
  for (const auto& h : ev.hysteresis) EXPECT_NEAR(h.h_mm, 0.008, 0.01 * 0.008);
  EXPECT_EQ(ev.runs[2].run.segment_id, 3);
}

TEST(Evaluation, RadiusAndCentreFromCommandedColumnsWhenNoMetadata) {
  Trace t = sim::simulate({}, {});
  t.metadata = {};
  const Evaluation ev = evaluate(t, {});
  EXPECT_EQ(ev.nominal_radius_source, ValueSource::commanded);
  EXPECT_NEAR(*ev.nominal_radius_mm, kR, 1e-9);
}

TEST(Evaluation, MalformedCentreMetadataNamesItsLine) {
  Trace t = sim::simulate({}, {});
  t.source = "t.csv";
  TraceMetadata md;
  md.set("centre_mm", "1,2");
  md.set_line(0, 3);
  t.metadata = md;
  try {
    evaluate(t, {});
    FAIL() << "expected an error";
  } catch (const ParseError& e) {
    EXPECT_STREQ(e.what(),
                 "t.csv:3: metadata 'centre_mm': expected three numbers x,y,z, got '1,2'");
  }
}

// The H merge against an analytic truth: paths that cross +-180 deg, one CW, one sweeping
// more than a turn, sampled at unrelated angles.
TEST(Evaluation, RadialDifferenceOfKnownProfiles) {
  constexpr double kPi = 3.14159265358979323846;
  const double radius = 50.0, bump = 0.004, peak = 1.0;  // the difference peaks at 1 rad
  const double ca = 3.0, cb = -2.0;
  std::vector<double> a1, b1, a2, b2;
  for (int i = 0; i < 3000; ++i) {  // CCW from 100 deg over 380 deg
    const double th = (100.0 + 380.0 * i / 2999.0) * kPi / 180.0;
    a1.push_back(ca + radius * std::cos(th));
    b1.push_back(cb + radius * std::sin(th));
  }
  for (int i = 0; i < 2711; ++i) {  // CW from 200 deg over 360 deg
    const double th = (200.0 - 360.0 * i / 2711.0) * kPi / 180.0;
    const double r = radius + bump * (1.0 + std::cos(th - peak)) / 2.0;
    a2.push_back(ca + r * std::cos(th));
    b2.push_back(cb + r * std::sin(th));
  }
  const RadialDifference d = max_radial_difference(a1, b1, a2, b2, ca, cb);
  EXPECT_NEAR(d.max_mm, bump, 1e-8);
  EXPECT_NEAR(d.at_angle_deg, peak * 180.0 / kPi, 0.2);
  EXPECT_NEAR(d.overlap_deg, 360.0, 0.2);
}

namespace {

// A feed sweep long enough (4 runs, ~113,000 samples) for evaluate() to use threads.
Trace sweep_trace() {
  MachineModel m;
  m.x.backlash_mm = 0.01;
  m.squareness_rad = 50e-6;
  m.noise_mm = 0.0002;
  CircleProgram p;
  p.runs = {Direction::CCW, Direction::CW, Direction::CCW, Direction::CW};
  p.run_feeds_mm_per_min = {1000.0, 1000.0, 1200.0, 1200.0};
  return sim::simulate(m, p);
}

EvaluationOptions with_threads(unsigned n) {
  EvaluationOptions o;
  o.threads = n;
  return o;
}

}  // namespace

TEST(EvaluationThreads, RunsSideBySideGiveWhatOneThreadGives) {
  const Trace trace = sweep_trace();
  ASSERT_GT(trace.rows(), std::size_t{1} << 16);
  const Evaluation one = evaluate(trace, with_threads(1));
  ASSERT_EQ(one.runs.size(), 4u);
  ASSERT_EQ(one.hysteresis.size(), 2u);
  for (unsigned n : {2u, 3u, 0u}) {
    const Evaluation ev = evaluate(trace, with_threads(n));
    ASSERT_EQ(ev.runs.size(), one.runs.size());
    for (std::size_t i = 0; i < ev.runs.size(); ++i) {
      EXPECT_EQ(ev.runs[i].run.begin, one.runs[i].run.begin);
      EXPECT_EQ(ev.runs[i].lsc.radius_mm, one.runs[i].lsc.radius_mm);
      EXPECT_EQ(ev.runs[i].g_mzc_mm, one.runs[i].g_mzc_mm);
      EXPECT_EQ(ev.runs[i].f_max_mm, one.runs[i].f_max_mm);
      EXPECT_EQ(ev.runs[i].feed_mm_per_min, one.runs[i].feed_mm_per_min);
    }
    ASSERT_EQ(ev.hysteresis.size(), one.hysteresis.size());
    for (std::size_t i = 0; i < ev.hysteresis.size(); ++i) {
      EXPECT_EQ(ev.hysteresis[i].run_ccw, one.hysteresis[i].run_ccw);
      EXPECT_EQ(ev.hysteresis[i].h_mm, one.hysteresis[i].h_mm);
      EXPECT_EQ(ev.hysteresis[i].at_angle_deg, one.hysteresis[i].at_angle_deg);
      EXPECT_EQ(ev.hysteresis[i].common_lsc.centre_a_mm, one.hysteresis[i].common_lsc.centre_a_mm);
    }
    EXPECT_EQ(ev.notes, one.notes);
  }
  // The backlash shows in H (the sweep's truth): the pairs are the runs 1-2 and 3-4.
  EXPECT_EQ(one.hysteresis[1].run_ccw, 2u);
  EXPECT_NEAR(one.hysteresis[0].h_mm, 0.01, 0.004);
}

TEST(EvaluationThreads, TheFirstRunInOrderNamesTheRefusal) {
  // Outliers in runs 3 and 2: whichever thread finishes first, run 2 is the one reported,
  // as one thread reports it.
  Trace trace = sweep_trace();
  const Evaluation clean = evaluate(trace, with_threads(1));
  auto& x = trace.values[*trace.column_index(column_name::x)];
  for (const std::size_t r : {2u, 1u}) {
    const circtest::Run& seg = clean.runs[r].run;
    x[seg.begin + seg.size() / 3] += 3.0;
  }
  const std::size_t line2 = trace.line_of_row[clean.runs[1].run.begin];
  for (unsigned n : {1u, 2u, 4u}) {
    try {
      evaluate(trace, with_threads(n));
      ADD_FAILURE() << "no refusal with " << n << " threads";
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find("run 2: an outlier"), std::string::npos) << e.what();
      EXPECT_GT(e.line(), line2);
    }
  }
}
