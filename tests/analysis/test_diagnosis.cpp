// The diagnosis against the test simulator's injected errors (tests/support/machine_sim): each
// source alone and all together with noise, in the three planes, on full circles and 220 deg
// arcs. Tolerance per parameter: 5 % of the injected value or an absolute floor (0.3 um,
// 2 urad, 3 ppm, 0.05 ms), whichever is larger.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/core/error.hpp"
#include "machine_sim.hpp"

using namespace circtest;

namespace {

constexpr double kUm = 1e-3;  // mm

struct Truth {
  double backlash_a = 0, backlash_b = 0;  // mm
  double spike_a = 0, spike_ms_a = 0, spike_b = 0, spike_ms_b = 0;
  double squareness = 0;  // rad
  double scale_a = 0, scale_b = 0;
  double kv_a = 0, kv_b = 0;  // 0: ideal
  double cyclic_a = 0, pitch_a = 0;
  double noise = 0;
};

sim::AxisModel& axis(sim::MachineModel& m, char letter) {
  return letter == 'x' ? m.x : (letter == 'y' ? m.y : m.z);
}

sim::CircleProgram program(Plane plane, double arc_deg) {
  sim::CircleProgram p;
  p.plane = plane;
  p.radius_mm = 50.0;
  p.feed_mm_per_min = 2000.0;
  p.arc_deg = arc_deg;
  p.centre_mm[0] = 10.0;
  p.centre_mm[1] = -20.0;
  p.centre_mm[2] = 5.0;
  return p;
}

Trace simulate(const Truth& t, const sim::CircleProgram& p) {
  sim::MachineModel m;
  const PlaneAxes pa = plane_axes(p.plane);
  sim::AxisModel& a = axis(m, pa.first);
  sim::AxisModel& b = axis(m, pa.second);
  a.backlash_mm = t.backlash_a;
  b.backlash_mm = t.backlash_b;
  a.spike_mm = t.spike_a;
  a.spike_ms = t.spike_ms_a;
  b.spike_mm = t.spike_b;
  b.spike_ms = t.spike_ms_b;
  a.scale = t.scale_a;
  b.scale = t.scale_b;
  a.kv_per_s = t.kv_a;
  b.kv_per_s = t.kv_b;
  a.cyclic_amplitude_mm = t.cyclic_a;
  a.cyclic_pitch_mm = t.pitch_a;
  a.cyclic_phase_rad = 0.7;
  m.squareness_rad = t.squareness;
  m.noise_mm = t.noise;
  m.seed = 7;
  return sim::simulate(m, p);
}

double tol(double truth, double floor) {
  return std::max(0.05 * std::abs(truth), floor);
}

// Lag of an axis in the simulator (exact first-order loop): 1/Kv, 0 when ideal.
double lag(double kv) {
  return kv > 0 ? 1.0 / kv : 0.0;
}

// Every parameter the trace identifies, against the truth.
void expect_recovered(const Diagnosis& d, const Truth& t, const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_TRUE(d.backlash_mm[0].value);
  ASSERT_TRUE(d.backlash_mm[1].value);
  EXPECT_NEAR(*d.backlash_mm[0].value, t.backlash_a, tol(t.backlash_a, 0.3 * kUm));
  EXPECT_NEAR(*d.backlash_mm[1].value, t.backlash_b, tol(t.backlash_b, 0.3 * kUm));
  // Each end on its own, where the arcs cover both: the same play at both.
  for (std::size_t k = 0; k < 2; ++k) {
    const double b = k == 0 ? t.backlash_a : t.backlash_b;
    if (const auto& e = d.backlash_reversals_mm[k]) {
      EXPECT_NEAR((*e)[0], b, tol(b, 0.3 * kUm)) << "+ end of axis " << k;
      EXPECT_NEAR((*e)[1], b, tol(b, 0.3 * kUm)) << "- end of axis " << k;
    }
  }
  for (int k = 0; k < 2; ++k) {
    const double h = k == 0 ? t.spike_a : t.spike_b;
    const double ms = k == 0 ? t.spike_ms_a : t.spike_ms_b;
    ASSERT_TRUE(d.spike_mm[static_cast<std::size_t>(k)].value) << "axis " << k;
    EXPECT_NEAR(*d.spike_mm[static_cast<std::size_t>(k)].value, h, tol(h, 0.3 * kUm))
        << "axis " << k;
    if (h > 0) {
      ASSERT_TRUE(d.spike_ms[static_cast<std::size_t>(k)].value) << "axis " << k;
      EXPECT_NEAR(*d.spike_ms[static_cast<std::size_t>(k)].value, ms, tol(ms, 0.05))
          << "axis " << k;
    } else {
      EXPECT_FALSE(d.spike_ms[static_cast<std::size_t>(k)].value) << "axis " << k;
    }
  }
  ASSERT_TRUE(d.squareness_urad.value);
  EXPECT_NEAR(*d.squareness_urad.value, t.squareness * 1e6, tol(t.squareness * 1e6, 2.0));
  ASSERT_TRUE(d.scale_mismatch_ppm.value);
  const double ds = (t.scale_a - t.scale_b) * 1e6;
  EXPECT_NEAR(*d.scale_mismatch_ppm.value, ds, tol(ds, 3.0));
  ASSERT_TRUE(d.scale_ppm[0].value);
  ASSERT_TRUE(d.scale_ppm[1].value);
  EXPECT_NEAR(*d.scale_ppm[0].value, t.scale_a * 1e6, tol(t.scale_a * 1e6, 3.0));
  EXPECT_NEAR(*d.scale_ppm[1].value, t.scale_b * 1e6, tol(t.scale_b * 1e6, 3.0));
  ASSERT_TRUE(d.servo_mismatch_ms.value);
  const double dtau = (lag(t.kv_a) - lag(t.kv_b)) * 1e3;
  EXPECT_NEAR(*d.servo_mismatch_ms.value, dtau, tol(dtau, 0.05));
  if (t.cyclic_a > 0) {
    ASSERT_TRUE(d.cyclic[0]);
    EXPECT_NEAR(d.cyclic[0]->amplitude_mm, t.cyclic_a, tol(t.cyclic_a, 0.3 * kUm));
    EXPECT_NEAR(d.cyclic[0]->pitch_mm, t.pitch_a, 0.01 * t.pitch_a);
  } else {
    EXPECT_FALSE(d.cyclic[0]) << "spurious cyclic term on A";
  }
  EXPECT_FALSE(d.cyclic[1]) << "spurious cyclic term on B";
  // The parts of the modelled G add up to it.
  double sum = 0.0;
  for (const auto& c : d.contributions) sum += c.share_mm;
  EXPECT_NEAR(sum, d.model_g_mm, 0.05 * d.model_g_mm + 1e-9);
}

struct Case {
  Plane plane;
  double arc_deg;
};

class Diagnose : public ::testing::TestWithParam<Case> {
 protected:
  Diagnosis run(const Truth& t) {
    const Trace trace = simulate(t, program(GetParam().plane, GetParam().arc_deg));
    return diagnose(trace);
  }
};

std::string name(const ::testing::TestParamInfo<Case>& info) {
  return std::string(plane_name(info.param.plane)) + "_" +
         std::to_string(static_cast<int>(info.param.arc_deg));
}

}  // namespace

TEST_P(Diagnose, NoErrorsGiveZerosAndNoCyclicTerm) {
  Truth t;
  t.noise = 0.3 * kUm;
  const Diagnosis d = run(t);
  expect_recovered(d, t, "noise only");
  EXPECT_LT(d.residual_rms_mm, 0.4 * kUm);
}

TEST_P(Diagnose, BacklashAlone) {
  Truth t;
  t.backlash_a = 12 * kUm;
  expect_recovered(run(t), t, "backlash A");
  Truth u;
  u.backlash_b = 8 * kUm;
  expect_recovered(run(u), u, "backlash B");
}

TEST_P(Diagnose, ReversalSpikeAlone) {
  Truth t;
  t.spike_a = 6 * kUm;
  t.spike_ms_a = 15.0;
  expect_recovered(run(t), t, "spike A");
  Truth u;
  u.spike_b = 4 * kUm;
  u.spike_ms_b = 40.0;
  expect_recovered(run(u), u, "spike B");
}

TEST_P(Diagnose, SquarenessAlone) {
  Truth t;
  t.squareness = 80e-6;
  expect_recovered(run(t), t, "squareness");
}

TEST_P(Diagnose, ScaleAlone) {
  Truth t;
  t.scale_a = 40e-6;
  expect_recovered(run(t), t, "scale A");
  Truth u;
  u.scale_b = -30e-6;
  expect_recovered(run(u), u, "scale B");
}

TEST_P(Diagnose, ServoMismatchAlone) {
  Truth t;
  t.kv_a = 30;
  t.kv_b = 33;
  const Diagnosis d = run(t);
  expect_recovered(d, t, "Kv 30/33");
  // One feed: Kv from the following lag against the commanded columns.
  ASSERT_TRUE(d.kv_per_s.value);
  EXPECT_EQ(d.kv_source, "lag");
  EXPECT_NEAR(*d.kv_per_s.value, 2.0 / (1.0 / 30 + 1.0 / 33), 0.05 * 31.4);
}

TEST_P(Diagnose, CyclicAlone) {
  Truth t;
  t.cyclic_a = 2 * kUm;
  t.pitch_a = 5.0;
  t.noise = 0.2 * kUm;
  const Diagnosis d = run(t);
  expect_recovered(d, t, "cyclic A by periodogram");
  ASSERT_TRUE(d.cyclic[0]);
  EXPECT_EQ(d.cyclic[0]->pitch_source, "periodogram");
  DiagnosisOptions o;
  o.pitch_mm[plane_axes(GetParam().plane).first] = 5.0;
  const Diagnosis given = diagnose(simulate(t, program(GetParam().plane, GetParam().arc_deg)), o);
  ASSERT_TRUE(given.cyclic[0]);
  EXPECT_EQ(given.cyclic[0]->pitch_source, "option");
  EXPECT_NEAR(given.cyclic[0]->amplitude_mm, t.cyclic_a, tol(t.cyclic_a, 0.3 * kUm));
}

TEST_P(Diagnose, AllCombinedWithNoise) {
  Truth t;
  t.backlash_a = 10 * kUm;
  t.backlash_b = 6 * kUm;
  t.spike_a = 5 * kUm;
  t.spike_ms_a = 20.0;
  t.spike_b = 4 * kUm;
  t.spike_ms_b = 50.0;
  t.squareness = 100e-6;
  t.scale_a = 30e-6;
  t.scale_b = -10e-6;
  t.kv_a = 30;
  t.kv_b = 33;
  t.cyclic_a = 2 * kUm;
  t.pitch_a = 5.0;
  // 0.2 um of noise: the decay of the slower spike then has a standard error of 0.6-0.9 ms,
  // at most half the 5 % tolerance (at 0.3 um it is 1.2 ms and 5 % is only 2 of them).
  t.noise = 0.2 * kUm;
  const Diagnosis d = run(t);
  expect_recovered(d, t, "all combined");
  EXPECT_LT(d.residual_rms_mm, 0.3 * kUm);
  ASSERT_TRUE(d.spike_ms[1].standard_error);
  EXPECT_LT(*d.spike_ms[1].standard_error, 0.025 * 50.0);
}

INSTANTIATE_TEST_SUITE_P(Planes, Diagnose,
                         ::testing::Values(Case{Plane::XY, 360}, Case{Plane::YZ, 360},
                                           Case{Plane::ZX, 360}, Case{Plane::XY, 220},
                                           Case{Plane::YZ, 220}, Case{Plane::ZX, 220}),
                         name);

// The two reversals of an axis apart: 10 um of play, and 4 um more lost at the + end of X that
// the table then recovers evenly until the - end (x += e (1 - phi / pi) while X moves -, phi
// the angle since the + end). The + end steps 14 um, the - end 10 um; the mean is what the
// model's single backlash gets.
TEST(DiagnoseReversals, TheTwoEndsOfAnAxisSeparately) {
  Truth t;
  t.backlash_a = 10 * kUm;
  t.noise = 0.2 * kUm;
  sim::CircleProgram p = program(Plane::XY, 360);
  p.start_deg = 45.0;  // both ends of X inside the runs, not at their start
  Trace trace = simulate(t, p);
  const double e = 4 * kUm;
  auto& x = trace.values[trace.column_index("x").value()];
  const auto& y = *trace.column("y");
  const auto& seg = *trace.column("segment");
  for (std::size_t i = 0; i < trace.rows(); ++i) {
    if (seg[i] < 1) continue;
    const double dir = seg[i] == 1 ? 1.0 : -1.0;  // the program's runs: CCW, then CW
    double phi = std::fmod(dir * std::atan2(y[i] - p.centre_mm[1], x[i] - p.centre_mm[0]),
                           2 * std::numbers::pi);
    if (phi < 0) phi += 2 * std::numbers::pi;
    if (phi < std::numbers::pi) x[i] += e * (1.0 - phi / std::numbers::pi);
  }
  const Diagnosis d = diagnose(trace);
  ASSERT_TRUE(d.backlash_reversals_mm[0]);
  std::printf("X backlash %.3f um, + end %.3f um (14), - end %.3f um (10)\n",
              *d.backlash_mm[0].value * 1e3, (*d.backlash_reversals_mm[0])[0] * 1e3,
              (*d.backlash_reversals_mm[0])[1] * 1e3);
  EXPECT_NEAR((*d.backlash_reversals_mm[0])[0], 14 * kUm, 0.5 * kUm);
  EXPECT_NEAR((*d.backlash_reversals_mm[0])[1], 10 * kUm, 0.5 * kUm);
  ASSERT_TRUE(d.backlash_reversals_mm[1]);  // Y: no play at either end
  EXPECT_NEAR((*d.backlash_reversals_mm[1])[0], 0.0, 0.3 * kUm);
  EXPECT_NEAR((*d.backlash_reversals_mm[1])[1], 0.0, 0.3 * kUm);
  const std::string text = text_report(d);
  EXPECT_NE(text.find("at the + end of X 1"), std::string::npos) << text;
}

// The modelled G is the G the instrument measured, less what the model leaves.
TEST(DiagnoseContributions, ModelledGIsTheMeasuredG) {
  Truth t;
  t.backlash_a = 10 * kUm;
  t.squareness = 100e-6;
  t.kv_a = 30;
  t.kv_b = 33;
  const Trace trace = simulate(t, program(Plane::XY, 360));
  const Evaluation ev = evaluate(trace, {});
  const Diagnosis d = diagnose(trace, ev);
  double g = 0.0;
  for (const auto& r : ev.runs) g = std::max(g, r.g_lsc_mm);
  EXPECT_NEAR(d.model_g_mm, g, 0.05 * g);
  ASSERT_FALSE(d.contributions.empty());
  EXPECT_EQ(d.contributions.front().source, "servo mismatch");  // ranked: the largest first
  double percent = 0.0;
  for (const auto& c : d.contributions) percent += c.percent;
  EXPECT_NEAR(percent, 100.0, 5.0);
}

// Two feeds: the radius shrinks with v^2 as the position loop predicts; Kv follows from it.
TEST(DiagnoseFeeds, KvFromTheRadiusChangeOverFeeds) {
  Truth t;
  t.kv_a = 30;
  t.kv_b = 33;
  t.scale_a = 20e-6;
  t.scale_b = 20e-6;
  sim::CircleProgram p = program(Plane::XY, 360);
  p.runs = {Direction::CCW, Direction::CW, Direction::CCW, Direction::CW};
  p.run_feeds_mm_per_min = {1000, 1000, 3000, 3000};
  const Diagnosis d = diagnose(simulate(t, p));
  ASSERT_EQ(d.feeds_mm_per_min.size(), 2u);
  ASSERT_TRUE(d.kv_per_s.value);
  EXPECT_EQ(d.kv_source, "feeds");
  const double kv = std::sqrt(2.0 / (1.0 / 900 + 1.0 / 1089));
  EXPECT_NEAR(*d.kv_per_s.value, kv, 0.05 * kv);
  ASSERT_EQ(d.radius_change.size(), 2u);
  for (const auto& fr : d.radius_change) {
    const double v = fr.feed_mm_per_min / 60.0;
    const double loss = -v * v / (2 * 50.0 * kv * kv);
    ASSERT_TRUE(fr.dr_mm.value);
    EXPECT_NEAR(*fr.dr_mm.value, 50.0 * 20e-6 + loss, 0.05 * std::abs(loss) + 0.3 * kUm);
  }
  ASSERT_TRUE(d.scale_ppm[0].value);
  EXPECT_NEAR(*d.scale_ppm[0].value, 20.0, 3.0);
  ASSERT_TRUE(d.servo_mismatch_ms.value);
  EXPECT_NEAR(*d.servo_mismatch_ms.value, (1.0 / 30 - 1.0 / 33) * 1e3, 0.05);
}

// One run: squareness and servo mismatch look the same; neither is reported, the note says so.
TEST(DiagnoseBadInput, OneRunLeavesSquarenessAndServoOpen) {
  Truth t;
  t.squareness = 100e-6;
  t.backlash_a = 10 * kUm;
  sim::CircleProgram p = program(Plane::XY, 360);
  p.runs = {Direction::CCW};
  const Diagnosis d = diagnose(simulate(t, p));
  EXPECT_FALSE(d.squareness_urad.value);
  EXPECT_FALSE(d.servo_mismatch_ms.value);
  bool said = false;
  for (const auto& n : d.notes) said = said || n.find("sin 2theta") != std::string::npos;
  EXPECT_TRUE(said);
  // ... and the document lists them as terms the trace cannot separate.
  EXPECT_EQ(d.unseparable, (std::vector<std::string>{"squareness_urad", "servo_mismatch_ms"}));
  EXPECT_EQ(to_json(d)["unseparable"].get<std::vector<std::string>>(), d.unseparable);
  // What it does report is right.
  ASSERT_TRUE(d.backlash_mm[0].value);
  EXPECT_NEAR(*d.backlash_mm[0].value, t.backlash_a, 0.05 * t.backlash_a);
}

// An arc on which X never reverses: no X backlash, with the reason.
TEST(DiagnoseBadInput, NoReversalOfAnAxis) {
  Truth t;
  t.backlash_a = 10 * kUm;
  t.backlash_b = 5 * kUm;
  sim::CircleProgram p = program(Plane::XY, 160);
  p.start_deg = 10;
  const Diagnosis d = diagnose(simulate(t, p));
  EXPECT_FALSE(d.backlash_mm[0].value);
  EXPECT_FALSE(d.spike_mm[0].value);
  bool said = false;
  for (const auto& n : d.notes) said = said || n.find("no reversal of X") != std::string::npos;
  EXPECT_TRUE(said);
  ASSERT_TRUE(d.backlash_mm[1].value);
  EXPECT_NEAR(*d.backlash_mm[1].value, t.backlash_b, 0.05 * t.backlash_b);
}

// A 90 deg arc separates little: whatever is reported is right, the rest is null with notes.
TEST(DiagnoseBadInput, QuarterArc) {
  Truth t;
  t.backlash_b = 10 * kUm;
  t.squareness = 100e-6;
  t.noise = 0.2 * kUm;
  sim::CircleProgram p = program(Plane::XY, 95);
  p.start_deg = 42.5;
  const Diagnosis d = diagnose(simulate(t, p));
  EXPECT_FALSE(d.notes.empty());
  std::size_t nulls = 0;
  if (d.squareness_urad.value) {
    EXPECT_NEAR(*d.squareness_urad.value, 100.0, 5.0 + 3 * *d.squareness_urad.standard_error);
  } else {
    ++nulls;
  }
  if (d.scale_mismatch_ppm.value) {
    EXPECT_NEAR(*d.scale_mismatch_ppm.value, 0.0, 3.0 + 3 * *d.scale_mismatch_ppm.standard_error);
  } else {
    ++nulls;
  }
  if (d.backlash_mm[1].value) {
    EXPECT_NEAR(*d.backlash_mm[1].value, t.backlash_b, 0.05 * t.backlash_b);
  }
  EXPECT_FALSE(d.backlash_mm[0].value) << "X does not reverse on 45..135 deg";
  for (const auto& n : d.notes) std::printf("note: %s\n", n.c_str());
  std::printf("quarter arc: %zu of squareness/scale mismatch left null\n", nulls);
}

// Without a time column nothing needs a speed: the rest is still fitted.
TEST(DiagnoseBadInput, NoTimeColumn) {
  Truth t;
  t.backlash_a = 10 * kUm;
  Trace trace = simulate(t, program(Plane::XY, 360));
  const auto ti = static_cast<std::ptrdiff_t>(trace.column_index("t").value());
  trace.columns.erase(trace.columns.begin() + ti);
  trace.values.erase(trace.values.begin() + ti);
  const Diagnosis d = diagnose(trace);
  ASSERT_TRUE(d.backlash_mm[0].value);
  EXPECT_NEAR(*d.backlash_mm[0].value, t.backlash_a, 0.05 * t.backlash_a);
  EXPECT_FALSE(d.spike_ms[0].value);
}

// The trace without its feed: no time column and no feed metadata, as a ball bar's polar
// export often is.
Trace without_feed(Trace trace) {
  const auto ti = static_cast<std::ptrdiff_t>(trace.column_index("t").value());
  trace.columns.erase(trace.columns.begin() + ti);
  trace.values.erase(trace.values.begin() + ti);
  TraceMetadata kept;
  for (const auto& [key, value] : trace.metadata.entries()) {
    if (key != "feed_mm_per_min" && key != "feeds_mm_per_min" && key != "sample_period_s")
      kept.set(key, value);
  }
  trace.metadata = kept;
  return trace;
}

// Unequal position loops make a direction-dependent ellipse whether the feed is known or not:
// without the feed it is still fitted (as a phase), so it does not go into the backlash.
TEST(DiagnoseBadInput, WithoutTheFeedTheServoEllipseStaysOutOfTheBacklash) {
  Truth t;
  t.backlash_a = 8 * kUm;
  t.kv_a = 30;
  t.kv_b = 40;
  const Diagnosis known = diagnose(simulate(t, program(Plane::XY, 360)));
  const Diagnosis d = diagnose(without_feed(simulate(t, program(Plane::XY, 360))));
  ASSERT_TRUE(known.backlash_mm[0].value);
  EXPECT_NEAR(*known.backlash_mm[0].value, t.backlash_a, 0.05 * t.backlash_a);
  EXPECT_TRUE(d.feeds_mm_per_min.empty());
  // Never a confident wrong number: the truth within 5 %, or not reported and said so.
  if (d.backlash_mm[0].value) {
    EXPECT_NEAR(*d.backlash_mm[0].value, t.backlash_a, 0.05 * t.backlash_a);
  } else {
    EXPECT_NE(std::find(d.unseparable.begin(), d.unseparable.end(), "backlash_mm.X"),
              d.unseparable.end());
  }
  if (d.backlash_mm[1].value) {
    EXPECT_NEAR(*d.backlash_mm[1].value, 0.0, 0.4 * kUm);
  }
  // The ellipse needs the feed for a lag: no number in ms, a note with its phase.
  EXPECT_FALSE(d.servo_mismatch_ms.value);
  bool said = false;
  for (const auto& n : d.notes) said = said || n.find("fitted as a phase") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(DiagnoseJson, ContractKeys) {
  Truth t;
  t.backlash_a = 10 * kUm;
  t.cyclic_a = 2 * kUm;
  t.pitch_a = 5.0;
  const auto j = to_json(diagnose(simulate(t, program(Plane::ZX, 360))));
  EXPECT_EQ(j["schema"], "circtest.diagnosis/1");
  EXPECT_EQ(j["plane"], "ZX");
  EXPECT_EQ(j["axes"][0], "Z");
  EXPECT_EQ(j["axes"][1], "X");
  for (const char* k :
       {"units", "feeds_mm_per_min", "backlash_mm", "reversal_spike_mm", "reversal_spike_ms",
        "scale_ppm", "scale_mismatch_ppm", "squareness_urad", "servo_mismatch_ms",
        "radius_change_mm", "kv_per_s", "cyclic", "centre_offset_mm", "contributions", "residual",
        "standard_error", "ini_sha256", "source", "notes"}) {
    EXPECT_TRUE(j.contains(k)) << k;
  }
  EXPECT_NEAR(j["backlash_mm"]["Z"].get<double>(), 0.010, 0.0005);
  EXPECT_NEAR(j["cyclic"]["Z"]["pitch_mm"].get<double>(), 5.0, 0.05);
  EXPECT_TRUE(j["cyclic"]["X"].is_null());
  EXPECT_TRUE(j["residual"].contains("rms_mm"));
  EXPECT_TRUE(j["residual"].contains("G_mm"));
  EXPECT_TRUE(j["standard_error"]["backlash_mm"].contains("Z"));
  EXPECT_TRUE(j["radius_change_mm"][0].contains("feed_mm_per_min"));
  EXPECT_TRUE(j["radius_change_mm"][0].contains("dr"));
}
