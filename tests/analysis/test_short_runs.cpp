// Runs too short for a quantity: every quantity of the evaluation (H, G, F, the fits, the
// outlier check) and of the diagnosis (the model fit, reversals, spikes, servo lag, cyclic
// search, radius loss) is either finite or refused with a DataError naming the file, never a
// crash, a NaN or an "<input>" in place of the file. Traces written by hand (CSV text as
// docs/trace-format.md has it), over sizes 2..200, identical points, runs of very different
// length, one direction only and random small traces.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/result_json.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace.hpp"
#include "expect_error.hpp"

using namespace circtest;

namespace {

constexpr double kPi = std::numbers::pi;
const std::string kSource = "short-runs.csv";

struct RunSpec {
  std::size_t samples = 8;
  double sweep_deg = 315.0;  // from the first sample to the last
  bool ccw = true;
  double start_deg = 0.0;
  double noise_mm = 0.0;
};

// A trace of marked runs (marker 1, segment 1, 2, ...) on a circle of radius_mm about 0,0,
// one idle row between runs; time at 1 ms steps.
std::string trace_text(const std::vector<RunSpec>& runs, double radius_mm = 25.0, unsigned seed = 1,
                       bool commanded = true) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::string s = "# plane: XY\n# radius_mm: " + std::to_string(radius_mm) + "\n";
  s += commanded ? "t,x,y,x_cmd,y_cmd,marker,segment\n" : "t,x,y,marker,segment\n";
  double t = 0.0;
  int id = 0;
  char buf[256];
  for (const RunSpec& r : runs) {
    ++id;
    for (std::size_t i = 0; i < r.samples; ++i) {
      const double f =
          r.samples > 1 ? static_cast<double>(i) / static_cast<double>(r.samples - 1) : 0.0;
      const double deg = r.start_deg + (r.ccw ? 1.0 : -1.0) * r.sweep_deg * f;
      const double a = deg * kPi / 180.0;
      const double rr = radius_mm + r.noise_mm * gauss(rng);
      const double x = rr * std::cos(a), y = rr * std::sin(a);
      if (commanded) {
        std::snprintf(buf, sizeof buf, "%.6f,%.9f,%.9f,%.9f,%.9f,1,%d\n", t, x, y,
                      radius_mm * std::cos(a), radius_mm * std::sin(a), id);
      } else {
        std::snprintf(buf, sizeof buf, "%.6f,%.9f,%.9f,1,%d\n", t, x, y, id);
      }
      s += buf;
      t += 0.001;
    }
    std::snprintf(buf, sizeof buf, commanded ? "%.6f,0,0,0,0,0,0\n" : "%.6f,0,0,0,0\n", t);
    s += buf;
    t += 0.001;
  }
  return s;
}

bool finite(double v) {
  return std::isfinite(v);
}
bool finite(const std::optional<double>& v) {
  return !v || std::isfinite(*v);
}
bool finite(const Estimate& e) {
  return finite(e.value) && finite(e.standard_error);
}

void expect_finite(const Evaluation& ev) {
  for (const RunResult& r : ev.runs) {
    SCOPED_TRACE("run of " + std::to_string(r.run.size()) + " samples");
    EXPECT_GE(r.run.size(), 8u);
    for (double v : {r.lsc.centre_a_mm, r.lsc.centre_b_mm, r.lsc.radius_mm, r.g_mzc_mm, r.g_lsc_mm,
                     r.mzc.zone_width_mm, r.run.sweep_deg}) {
      EXPECT_TRUE(finite(v)) << v;
    }
    EXPECT_TRUE(finite(r.f_max_mm));
    EXPECT_TRUE(finite(r.f_min_mm));
    EXPECT_TRUE(finite(r.feed_mm_per_min));
  }
  for (const HysteresisResult& h : ev.hysteresis) {
    EXPECT_TRUE(finite(h.h_mm) && finite(h.at_angle_deg) && finite(h.overlap_deg)) << h.h_mm;
  }
}

void expect_finite(const Diagnosis& d) {
  for (const auto* group :
       {&d.backlash_mm, &d.spike_mm, &d.spike_ms, &d.scale_ppm, &d.centre_offset_mm}) {
    for (const Estimate& e : *group) EXPECT_TRUE(finite(e));
  }
  for (const Estimate* e :
       {&d.scale_mismatch_ppm, &d.squareness_urad, &d.servo_mismatch_ms, &d.kv_per_s, &d.lag_ms}) {
    EXPECT_TRUE(finite(*e));
  }
  for (const FeedRadius& f : d.radius_change) EXPECT_TRUE(finite(f.dr_mm));
  for (const auto& c : d.cyclic) {
    if (!c) continue;
    EXPECT_TRUE(finite(c->amplitude_mm) && finite(c->pitch_mm) && finite(c->phase_rad) &&
                finite(c->amplitude_se_mm));
  }
  for (const auto& r : d.backlash_reversals_mm) {
    if (r) {
      EXPECT_TRUE(finite((*r)[0]) && finite((*r)[1]));
    }
  }
  for (const Contribution& c : d.contributions) {
    EXPECT_TRUE(finite(c.g_mm) && finite(c.share_mm) && finite(c.percent)) << c.source;
  }
  EXPECT_TRUE(finite(d.model_g_mm) && finite(d.residual_rms_mm) && finite(d.residual_g_mm));
  EXPECT_TRUE(finite(d.radius_mm));
}

// What the tools do with the trace: the evaluation and the diagnosis each give finite numbers
// or a DataError naming the file. Returns the diagnosis's refusal ("" when it gave numbers, or
// when the evaluation refused).
std::string check_trace(const std::string& text) {
  const Trace trace = parse_trace(text, kSource);
  std::optional<Evaluation> ev;
  try {
    ev = evaluate(trace, {});
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.code(), ExitCode::data) << what;
    EXPECT_EQ(what.rfind(kSource, 0), 0u) << what;
    EXPECT_EQ(what.find("<input>"), std::string::npos) << what;
    return "";
  }
  expect_finite(*ev);
  EXPECT_NO_THROW(to_json(*ev).dump());
  try {
    const Diagnosis d = diagnose(trace, *ev);
    expect_finite(d);
    EXPECT_NO_THROW(to_json(d).dump());
    EXPECT_NO_THROW(text_report(d));
    return "";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.code(), ExitCode::data) << what;
    EXPECT_EQ(what.rfind(kSource, 0), 0u) << what;
    EXPECT_EQ(what.find("<input>"), std::string::npos) << what;
    return what;
  }
}

}  // namespace

// The case of the report: 8 samples at 45 deg steps on R25, marker and segment 1. The
// diagnosis segfaulted in the periodogram; it is refused, naming the samples it needs.
TEST(ShortRuns, EightSamplesAtFortyFiveDegreesAreNotMeasurableForTheDiagnosis) {
  const std::string text = trace_text({{8, 315.0, true, 0.0, 0.0}}, 25.0, 1, false);
  const Trace trace = parse_trace(text, kSource);
  const Evaluation ev = evaluate(trace, {});
  ASSERT_EQ(ev.runs.size(), 1u);
  EXPECT_NEAR(ev.runs[0].g_mzc_mm, 0.0, 1e-6);
  EXPECT_ERROR(diagnose(trace, ev), ExitCode::data,
               "short-runs.csv:4: diagnosis not measurable (8 samples, needs 24");
}

TEST(ShortRuns, EverySizeFromTwoToTwentyIsFiniteOrRefused) {
  for (std::size_t n = 2; n <= 20; ++n) {
    for (bool commanded : {false, true}) {
      SCOPED_TRACE("n = " + std::to_string(n));
      check_trace(trace_text({{n, 315.0, true, 0.0, 0.0}}, 25.0, 1, commanded));
      check_trace(trace_text({{n, 360.0 - 360.0 / static_cast<double>(n), true, 0.0, 0.001},
                              {n, 360.0 - 360.0 / static_cast<double>(n), false, 0.0, 0.001}},
                             25.0, static_cast<unsigned>(n), commanded));
    }
  }
}

TEST(ShortRuns, SizesUpToTwoHundredNeverGiveANaN) {
  for (std::size_t n = 21; n <= 200; n += 7) {
    SCOPED_TRACE("n = " + std::to_string(n));
    check_trace(trace_text({{n, 359.0, true, 10.0, 0.002}, {n, 359.0, false, 10.0, 0.002}}, 50.0,
                           static_cast<unsigned>(n)));
  }
}

TEST(ShortRuns, IdenticalPointsAreRefusedWithTheFileNamed) {
  std::string text = "# plane: XY\n# radius_mm: 25\nt,x,y,marker,segment\n";
  for (int i = 0; i < 40; ++i) text += std::to_string(i * 0.001) + ",25,0,1,1\n";
  const Trace trace = parse_trace(text, kSource);
  EXPECT_ERROR(evaluate(trace, {}), ExitCode::data, "short-runs.csv");
  // Beside a good run: the run of identical points is named by its lines.
  std::string two = trace_text({{100, 359.0, true, 0.0, 0.001}});
  for (int i = 0; i < 40; ++i) two += std::to_string(1.0 + i * 0.001) + ",25,0,25,0,1,2\n";
  EXPECT_ERROR(evaluate(parse_trace(two, kSource), {}), ExitCode::data, "short-runs.csv:");
  const std::string refused = check_trace(two);
  (void)refused;
}

TEST(ShortRuns, TwoRunsOfVeryDifferentLength) {
  for (std::size_t n : {8u, 9u, 12u, 20u, 31u, 40u}) {
    SCOPED_TRACE("short run n = " + std::to_string(n));
    check_trace(trace_text({{5000, 359.9, true, 0.0, 0.001}, {n, 330.0, false, 0.0, 0.001}}, 25.0,
                           static_cast<unsigned>(n)));
    check_trace(trace_text({{n, 330.0, true, 0.0, 0.001}, {5000, 359.9, false, 0.0, 0.001}}, 25.0,
                           static_cast<unsigned>(n)));
  }
}

TEST(ShortRuns, OneDirectionOnly) {
  for (std::size_t n : {8u, 16u, 32u, 33u, 64u, 500u}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    check_trace(trace_text({{n, 359.0, false, 0.0, 0.0005}}, 25.0, static_cast<unsigned>(n)));
    check_trace(trace_text({{n, 120.0, true, 30.0, 0.0005}}, 25.0, static_cast<unsigned>(n)));
  }
}

// Random small traces: sizes, sweeps, directions, starts and noise drawn from a fixed seed.
TEST(ShortRuns, RandomSmallTracesAreFiniteOrRefused) {
  std::mt19937 rng(20261126);
  std::uniform_int_distribution<std::size_t> size(2, 120), count(1, 3);
  std::uniform_real_distribution<double> sweep(10.0, 400.0), start(-180.0, 180.0), noise(0.0, 0.05),
      radius(0.5, 200.0);
  for (int k = 0; k < 150; ++k) {
    std::vector<RunSpec> runs(count(rng));
    bool ccw = rng() % 2 == 0;
    for (RunSpec& r : runs) {
      r = {size(rng), sweep(rng), ccw, start(rng), rng() % 3 == 0 ? 0.0 : noise(rng) * 0.01};
      ccw = !ccw;
    }
    SCOPED_TRACE("case " + std::to_string(k));
    check_trace(trace_text(runs, radius(rng), static_cast<unsigned>(k), rng() % 2 == 0));
  }
}

// Two runs that share no arc: H read 0.0 um there. Not measurable, with the reason.
TEST(ShortRuns, RunsSharingNoArcGiveNoH) {
  const Trace trace = parse_trace(
      trace_text({{500, 120.0, true, 0.0, 0.0}, {500, 120.0, false, 300.0, 0.0}}), kSource);
  const Evaluation ev = evaluate(trace, {});
  ASSERT_EQ(ev.runs.size(), 2u);
  EXPECT_TRUE(ev.hysteresis.empty());
  bool said = false;
  for (const std::string& n : ev.notes) {
    said = said || n.find(
                       "H of runs 1 and 2 not measurable: they share 0.0 deg of arc, needs "
                       "90 deg") != std::string::npos;
  }
  EXPECT_TRUE(said);
}

// A few dozen samples fill too few position bins for the periodogram: the cyclic error is
// named as not measurable instead of silently absent.
TEST(ShortRuns, TheCyclicSearchSaysWhenItHasTooFewSamples) {
  const Trace trace = parse_trace(
      trace_text({{14, 350.0, true, 0.0, 0.001}, {14, 350.0, false, 0.0, 0.001}}), kSource);
  const Diagnosis d = diagnose(trace, evaluate(trace, {}));
  bool said = false;
  for (const std::string& n : d.notes) {
    said = said || n.find("cyclic error of X not measurable (28 samples fill") != std::string::npos;
  }
  EXPECT_TRUE(said) << text_report(d);
  EXPECT_FALSE(d.cyclic[0].has_value());
}

// Found by a random search of small traces: 48 samples on R300 with a time column that stalls
// and jumps (feeds from 11927 to 12007704 mm/min), evaluated with the warnings only. The fit
// gave NaN for backlash and squareness; it is refused instead.
TEST(ShortRuns, AFitWithoutAFiniteSolutionIsRefused) {
  const std::string text =
      "# plane: XY\n"
      "# radius_mm: 300\n"
      "t,x,y,x_cmd,y_cmd,marker\n"
      "0.000000,299.428647687,-18.205348257,299.447031370,-18.206465990,1\n"
      "0.001000,300.028910609,0.709607462,299.999160927,0.709537100,1\n"
      "0.002000,299.353458052,19.622447955,299.357560424,19.622716863,1\n"
      "0.003000,297.527891343,38.458217451,297.524782859,38.457815651,1\n"
      "0.004000,294.516773464,57.141565232,294.508121059,57.139886509,1\n"
      "0.504000,290.307188839,75.591365286,290.319578657,75.594591397,1\n"
      "0.505000,284.996286359,93.755229042,284.975822329,93.748496990,1\n"
      "1.005000,278.479612145,111.521956898,278.498115477,111.529366876,1\n"
      "1.006000,270.908208538,128.864534360,270.912233618,128.866448994,1\n"
      "1.506000,262.246372792,145.689652171,262.248361819,145.690757165,1\n"
      "1.506000,252.541283415,161.935543617,252.540974592,161.935345592,1\n"
      "1.507000,241.831488953,177.537623673,241.828698711,177.535575251,1\n"
      "1.507000,230.149004877,192.425061354,230.154159514,192.429371090,1\n"
      "1.508000,217.556609471,206.550631549,217.563811293,206.557469038,1\n"
      "1.508000,204.105348780,219.861062607,204.107752445,219.863651820,1\n"
      "1.509000,189.831475772,232.285121930,189.839526126,232.294972654,1\n"
      "2.009000,174.824842771,243.814427670,174.815907197,243.801965929,1\n"
      "2.009000,159.085265519,254.320602252,159.096676311,254.338844039,1\n"
      "2.010000,142.746544549,263.867676986,142.744382036,263.863679572,1\n"
      "2.011000,125.818613727,272.326714816,125.824091974,272.338572147,1\n"
      "2.012000,108.409163648,279.745358889,108.403133841,279.729799223,1\n"
      "2.013000,90.555217408,286.021815742,90.550827570,286.007950285,1\n"
      "2.014000,72.335832463,291.138476835,72.338209475,291.148043871,1\n"
      "2.015000,53.839233688,295.137762552,53.837749590,295.129626976,1\n"
      "2.515000,35.124312075,297.947449314,35.123063306,297.936856438,1\n"
      "2.515000,16.268646099,299.559071214,16.268618443,299.558561977,1\n"
      "2.516000,-2.650533900,299.985216287,-2.650561064,299.988290648,1\n"
      "2.517000,-21.559039492,299.222192321,-21.559193694,299.224332512,1\n"
      "2.518000,-40.382937167,297.276332677,-40.382039891,297.269727443,1\n"
      "2.518000,-59.041616416,294.119375499,-59.044201457,294.132253033,1\n"
      "2.519000,-77.473338652,289.831573021,-77.471419571,289.824393642,1\n"
      "2.520000,-95.590250781,284.362935230,-95.590370281,284.363290721,1\n"
      "3.020000,-113.327477797,277.767050862,-113.328956266,277.770674607,1\n"
      "3.020000,-130.608513255,270.056070279,-130.616593716,270.072778054,1\n"
      "3.021000,-147.382798621,261.297227507,-147.384493198,261.300231850,1\n"
      "3.521000,-163.569034553,251.492711096,-163.565933373,251.487942931,1\n"
      "3.522000,-179.105399158,240.686878831,-179.096526489,240.674955489,1\n"
      "3.523000,-193.906261165,228.894600156,-193.914474587,228.904295604,1\n"
      "4.023000,0,0,0,0,0\n"
      "4.024000,-291.161163254,72.354397054,-291.145018480,72.350385030,1\n"
      "4.025000,-216.947863460,207.201221700,-216.949404127,207.202693151,1\n"
      "4.026000,-85.644427351,287.503816043,-85.647562026,287.514338980,1\n"
      "4.027000,68.197270675,292.139058484,68.198749384,292.145392882,1\n"
      "4.028000,204.101285193,219.885203633,204.093532741,219.876851654,1\n"
      "4.029000,286.261368799,89.730039044,286.266058554,89.731509070,1\n"
      "4.030000,293.085514706,-64.033064089,293.086569450,-64.033294529,1\n"
      "4.030000,222.762215047,-200.945244502,222.759745224,-200.943016569,1\n"
      "4.031000,93.790488529,-284.939158043,93.797273692,-284.959771631,1\n"
      "4.031000,-59.855776104,-293.972834597,-59.854864516,-293.968357470,1\n"
      "4.031000,0,0,0,0,0\n";
  EvaluationOptions options;
  options.input_checks.warn_only = true;
  const Trace trace = parse_trace(text, kSource);
  const Evaluation ev = evaluate(trace, options);
  EXPECT_ERROR(diagnose(trace, ev), ExitCode::data,
               "short-runs.csv:4: diagnosis not measurable: the model fit gives no finite");
}
