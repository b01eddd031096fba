// The uncertainty budget against a Monte Carlo simulation: the contributions are drawn from
// their stated distributions into simulated traces, each trace is evaluated with the real
// evaluate(), and the spread of G, H and F (2 x standard deviation) must agree with the
// stated U (k = 2) within 15 %; a budget that leaves a drawn contribution out must not.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>
#include <vector>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/report.hpp"
#include "circtest/analysis/result_json.hpp"
#include "circtest/analysis/uncertainty.hpp"
#include "machine_sim.hpp"

using namespace circtest;

namespace {

constexpr double kNominalR = 50.0;
constexpr double kAlphaMachine = 11.5e-6;

// A mill with an X scale error (a two-lobe r = R + A cos 2theta, A = R s / 2) and one CCW and
// one CW run, 4 ms samples.
sim::CircleProgram program(std::vector<Direction> runs = {Direction::CCW, Direction::CW}) {
  sim::CircleProgram p;
  p.radius_mm = kNominalR;
  p.feed_mm_per_min = 2000.0;
  p.period_s = 0.004;
  p.runs = std::move(runs);
  return p;
}

Trace base_trace(std::vector<Direction> runs = {Direction::CCW, Direction::CW}) {
  sim::MachineModel m;
  m.x.scale = 1e-4;
  Trace t = sim::simulate(m, program(std::move(runs)));
  t.metadata.set("sample_period_s", "0.004");
  t.metadata.set("instrument", "grid encoder");
  return t;
}

// A CCW run this much wider than a CW run (a direction-dependent servo error): H's base.
constexpr double kHBaseMm = 0.003;

struct Draws {
  double calibration_mm = 0.0;  // radius error of the instrument (normal)
  double temperature_K = 0.0;   // deviation from 20 deg C (rectangular), not recorded
  double centre_a_mm = 0.0, centre_b_mm = 0.0;  // set-up offset of the instrument
  double lobe_mm = 0.0;                         // test-to-test change of the two-lobe's amplitude
  std::vector<double> offset_mm;                // per run: run-to-run change of its radius
};

// The base trace with one draw of every contribution applied.
Trace perturbed(const Trace& base, const Draws& d, double resolution_mm) {
  Trace t = base;
  auto& x = t.values[*t.column_index("x")];
  auto& y = t.values[*t.column_index("y")];
  const auto& segment = *t.column("segment");
  const double scale = 1.0 + d.calibration_mm / kNominalR + kAlphaMachine * d.temperature_K;
  for (std::size_t i = 0; i < t.rows(); ++i) {
    double a = x[i], b = y[i];
    const double th = std::atan2(b, a);
    const auto run = static_cast<std::size_t>(segment[i]);
    double dr = d.lobe_mm * std::cos(2.0 * th);
    if (run >= 1 && run <= d.offset_mm.size()) {
      dr += d.offset_mm[run - 1] + (run % 2 == 1 ? kHBaseMm : 0.0);
    }
    a = (a + dr * std::cos(th)) * scale + d.centre_a_mm;
    b = (b + dr * std::sin(th)) * scale + d.centre_b_mm;
    x[i] = resolution_mm * std::round(a / resolution_mm);
    y[i] = resolution_mm * std::round(b / resolution_mm);
  }
  return t;
}

double two_sd(const std::vector<double>& v) {
  double mean = 0.0;
  for (double e : v) mean += e;
  mean /= static_cast<double>(v.size());
  double ss = 0.0;
  for (double e : v) ss += (e - mean) * (e - mean);
  return 2.0 * std::sqrt(ss / static_cast<double>(v.size() - 1));
}

struct Spread {
  double g, h, f;
};

// The stated budget of the simulated test: the grid encoder's profile, no temperatures, and
// the repeatability the draws imply. A change d of the two-lobe's amplitude moves the
// minimum-zone G by 2 d and F_max (about the LSC) by d, and cancels in H (both runs share
// it); a run's radius change e moves F_max by e, not G, and H (a constant difference of the
// two runs) by e_ccw - e_cw.
constexpr double kSigmaLobeMm = 0.0003;
constexpr double kSigmaOffsetMm = 0.0003;
UncertaintyOptions stated() {
  UncertaintyOptions o;
  o.profile = InstrumentProfile::grid_encoder;
  o.repeatability_g_mm = 2.0 * kSigmaLobeMm;
  o.repeatability_f_mm = std::hypot(kSigmaLobeMm, kSigmaOffsetMm);
  o.repeatability_h_mm = std::sqrt(2.0) * kSigmaOffsetMm;
  return o;
}

class MonteCarlo : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const Trace base = base_trace();
    EvaluationOptions eo;
    eo.threads = 1;
    eo.uncertainty = stated();
    const Evaluation nominal = evaluate(base, eo);
    budget_ = uncertainty_budget(nominal, eo.uncertainty);
    // The profile's stated values, drawn from their stated distributions.
    const double u_cal = 0.0005, centring = 0.005, half_width_K = 2.0, resolution = 1e-6;
    std::mt19937_64 rng(20261129);
    std::normal_distribution<double> normal(0.0, 1.0);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    std::vector<double> g, h, f;
    constexpr int kTrials = 240;
    for (int k = 0; k < kTrials; ++k) {
      Draws d;
      d.calibration_mm = u_cal * normal(rng);
      d.temperature_K = half_width_K * uniform(rng);
      d.centre_a_mm = centring * normal(rng);
      d.centre_b_mm = centring * normal(rng);
      d.lobe_mm = kSigmaLobeMm * normal(rng);
      d.offset_mm = {kSigmaOffsetMm * normal(rng), kSigmaOffsetMm * normal(rng)};
      const Evaluation ev = evaluate(perturbed(base, d, resolution), eo);
      g.push_back(ev.runs.at(0).g_mzc_mm);
      f.push_back(*ev.runs.at(0).f_max_mm);
      h.push_back(ev.hysteresis.at(0).h_mm);
    }
    spread_ = {two_sd(g), two_sd(h), two_sd(f)};
  }
  static UncertaintyBudget budget_;
  static Spread spread_;
};
UncertaintyBudget MonteCarlo::budget_;
Spread MonteCarlo::spread_;

double relative(double a, double b) {
  return std::abs(a - b) / b;
}

TEST_F(MonteCarlo, SpreadOfGHFAgreesWithTheStatedU) {
  EXPECT_EQ(budget_.profile, InstrumentProfile::grid_encoder);
  EXPECT_LT(relative(spread_.g, budget_.u_g_mm), 0.15)
      << "MC 2 sd " << spread_.g << " mm, U_G " << budget_.u_g_mm;
  EXPECT_LT(relative(spread_.h, budget_.u_h_mm), 0.15)
      << "MC 2 sd " << spread_.h << " mm, U_H " << budget_.u_h_mm;
  EXPECT_LT(relative(spread_.f, budget_.u_f_mm), 0.15)
      << "MC 2 sd " << spread_.f << " mm, U_F " << budget_.u_f_mm;
  std::printf("MC: 2 sd G %.3f um vs U_G %.3f um; H %.3f vs %.3f; F %.3f vs %.3f\n",
              spread_.g * 1e3, budget_.u_g_mm * 1e3, spread_.h * 1e3, budget_.u_h_mm * 1e3,
              spread_.f * 1e3, budget_.u_f_mm * 1e3);
}

TEST_F(MonteCarlo, ABudgetWithoutAContributionDisagrees) {
  const UncertaintyBudget no_rep = without_contribution(budget_, "repeatability");
  EXPECT_GT(relative(spread_.g, no_rep.u_g_mm), 0.15) << no_rep.u_g_mm;
  EXPECT_GT(relative(spread_.h, no_rep.u_h_mm), 0.15) << no_rep.u_h_mm;
  const UncertaintyBudget no_temp = without_contribution(budget_, "temperature");
  EXPECT_GT(relative(spread_.f, no_temp.u_f_mm), 0.15) << no_temp.u_f_mm;
  // Leaving out a contribution the budget says does not enter G changes nothing.
  EXPECT_DOUBLE_EQ(no_temp.u_g_mm, budget_.u_g_mm);
}

// Repeated runs: the repeatability is measured, not the stated default.
TEST(Uncertainty, RepeatabilityIsMeasuredFromRepeatedRuns) {
  std::vector<Direction> runs;
  for (int i = 0; i < 8; ++i) {
    runs.push_back(Direction::CCW);
    runs.push_back(Direction::CW);
  }
  const Trace base = base_trace(runs);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, kSigmaLobeMm);
  Draws d;
  for (std::size_t i = 0; i < runs.size(); ++i) d.offset_mm.push_back(normal(rng));
  EvaluationOptions eo;
  eo.threads = 1;
  const Evaluation ev = evaluate(perturbed(base, d, 1e-6), eo);
  ASSERT_EQ(ev.runs.size(), runs.size());
  const UncertaintyBudget b = uncertainty_budget(ev, {});
  const auto* g = &b.contributions.front();
  for (const auto& c : b.contributions) {
    if (c.name == "repeatability of G") g = &c;
  }
  EXPECT_EQ(g->source, "measured");
  // A run's radius change leaves G alone: its repeatability is near 0, not the default.
  EXPECT_LT(g->value_mm, 0.05 * kDefaultRepeatabilityMm);
  const auto* f = g;
  for (const auto& c : b.contributions) {
    if (c.name == "repeatability of F") f = &c;
  }
  EXPECT_EQ(f->source, "measured");
  // 14 degrees of freedom: the sample standard deviation is within +-40 % of the truth
  // (2 sigma of its sampling distribution).
  EXPECT_NEAR(f->value_mm, kSigmaOffsetMm, 0.4 * kSigmaOffsetMm);
}

TEST(Uncertainty, UnmeasuredRepeatabilityIsAStatedDefault) {
  EvaluationOptions eo;
  eo.threads = 1;
  const Evaluation ev = evaluate(base_trace(), eo);
  const UncertaintyBudget b = uncertainty_budget(ev, {});
  bool found = false;
  for (const auto& c : b.contributions) {
    if (c.name != "repeatability of G") continue;
    found = true;
    EXPECT_EQ(c.source, "stated assumption");
    EXPECT_NE(c.note.find("not measured"), std::string::npos);
    EXPECT_DOUBLE_EQ(c.value_mm, kDefaultRepeatabilityMm);
  }
  EXPECT_TRUE(found);
}

TEST(Uncertainty, FeedbackTestStatesWhatTheScalesCannotSee) {
  Trace t = base_trace();
  t.metadata.set("instrument", "feedback");
  EvaluationOptions eo;
  eo.threads = 1;
  const UncertaintyBudget b = uncertainty_budget(evaluate(t, eo), {});
  EXPECT_EQ(b.profile, InstrumentProfile::scales);
  EXPECT_EQ(b.contributions.back().name, "what the scales cannot see");
  EXPECT_EQ(b.contributions.back().source, "stated assumption");
}

TEST(Uncertainty, DecisionRuleOfIso14253) {
  // G = 19.6 um against 20 um with U = 1.5 um: not a pass.
  EXPECT_EQ(decide(0.0196, 0.0015, 0.020), Decision::not_decided);
  EXPECT_EQ(decide(0.0180, 0.0015, 0.020), Decision::pass);
  EXPECT_EQ(decide(0.0185, 0.0015, 0.020), Decision::pass);  // value + U == limit
  EXPECT_EQ(decide(0.0216, 0.0015, 0.020), Decision::fail);
  EXPECT_EQ(decide(0.0215, 0.0015, 0.020), Decision::not_decided);  // value - U == limit
}

TEST(Uncertainty, RectangularHalfWidthIsDividedBySqrt3) {
  UncertaintyContribution c;
  c.value_mm = 0.003;
  c.distribution = Distribution::rectangular;
  EXPECT_DOUBLE_EQ(c.standard_mm(), 0.003 / std::sqrt(3.0));
}

// The JSON carries U_G, U_F, U_H and the budget, and reads back to the same document with
// stated inputs.
TEST(Uncertainty, JsonCarriesTheBudgetAndReadsBack) {
  EvaluationOptions eo;
  eo.threads = 1;
  eo.uncertainty = stated();
  eo.uncertainty.calibration_mm = 0.002;
  const Evaluation ev = evaluate(base_trace(), eo);
  const auto doc = to_json(ev);
  const UncertaintyBudget b = uncertainty_budget(ev, eo.uncertainty);
  EXPECT_DOUBLE_EQ(doc["runs"][0]["U_G"].get<double>(), b.u_g_mm);
  EXPECT_DOUBLE_EQ(doc["runs"][1]["U_F"].get<double>(), b.u_f_mm);
  EXPECT_DOUBLE_EQ(doc["U_H"].get<double>(), b.u_h_mm);
  EXPECT_EQ(doc["uncertainty"]["contributions"][0]["name"], "instrument calibration");
  EXPECT_DOUBLE_EQ(doc["uncertainty"]["contributions"][0]["value_mm"].get<double>(), 0.002);
  EXPECT_EQ(doc["uncertainty"]["contributions"][0]["source"], "option");
  // The existing keys keep their place: U_G comes after every key a run had.
  EXPECT_EQ(std::prev(doc["runs"][0].end()).key(), "U_F");
  EXPECT_EQ(to_json(evaluation_from_json(doc)), doc);
}

// The text says "G = ..., U = ... (k = 2)" per run and judges a limit within U as not decided.
TEST(Uncertainty, TextAndLimitsFollowTheRule) {
  EvaluationOptions eo;
  eo.threads = 1;
  eo.uncertainty = stated();
  const Evaluation ev = evaluate(base_trace(), eo);
  const UncertaintyBudget b = uncertainty_budget(ev, eo.uncertainty);
  const std::string text = text_report(ev);
  EXPECT_NE(text.find(fmt::format("G_XY = {:.1f} um, U = {:.1f} um (k = 2)",
                                  ev.runs[0].g_mzc_mm * 1e3, b.u_g_mm * 1e3)),
            std::string::npos)
      << text;
  const double g = std::max(ev.runs[0].g_mzc_mm, ev.runs[1].g_mzc_mm);
  ResultLimits limits;
  limits.g_mm = g + b.u_g_mm / 2;  // within U of the value
  limits.h_mm = 1.0;
  auto d = decide_limits(ev, b, limits);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_STREQ(d[0].quantity, "H");
  EXPECT_EQ(d[0].decision, Decision::pass);
  EXPECT_EQ(d[1].decision, Decision::not_decided);
  EXPECT_FALSE(all_pass(d));
  const std::string words = limits_text(d);
  EXPECT_NE(words.find(kDecisionRule), std::string::npos);
  EXPECT_NE(words.find("not decided: within the uncertainty"), std::string::npos);
  limits.g_mm = g + 1.01 * b.u_g_mm;
  EXPECT_TRUE(all_pass(decide_limits(ev, b, limits)));
  limits.f_mm = 1.0;
  Evaluation no_f = ev;
  for (auto& r : no_f.runs) r.f_max_mm.reset(), r.f_min_mm.reset();
  d = decide_limits(no_f, b, limits);
  EXPECT_FALSE(d.back().decision.has_value());  // not measured: does not pass
  EXPECT_FALSE(all_pass(d));
}

// Recorded temperatures: each enters F with R sqrt((a u_T)^2 + (u_a (T - 20))^2).
TEST(Uncertainty, RecordedTemperaturesEnterFOnly) {
  Trace t = base_trace();
  t.metadata.set("temperature_machine_C", "22");
  EvaluationOptions eo;
  eo.threads = 1;
  const Evaluation ev = evaluate(t, eo);
  const UncertaintyBudget b = uncertainty_budget(ev, {});
  const UncertaintyContribution* machine = nullptr;
  for (const auto& c : b.contributions) {
    if (c.name == "temperature of the machine") machine = &c;
  }
  ASSERT_NE(machine, nullptr);
  EXPECT_EQ(machine->source, "measured");
  const double a = kAlphaMachine;
  EXPECT_NEAR(machine->value_mm, kNominalR * std::hypot(a * 0.2, 0.1 * a * 2.0), 1e-12);
  EXPECT_EQ(machine->c_g, 0.0);
  EXPECT_EQ(machine->c_f, 1.0);
}

}  // namespace
