// circfric's kernel on friction-like command profiles: the axis velocities of a circle at
// 1 kHz with noise, standstill, slow jogs over a reversal; the pulse's shape against the
// formula; and the bound |offset| <= amplitude-max for any parameter values.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "circfric_kernel.hpp"

namespace fric = circtest::fric;

namespace {

constexpr double kPeriodS = 1e-3;

fric::Params tuned() {
  fric::Params p;
  p.enable = true;
  p.amplitude = 0.004;
  p.amplitude_max = 0.008;
  p.decay_ms = 20.0;
  p.vel_threshold = 0.02;
  p.min_travel = 0.001;
  return p;
}

struct Trace {
  std::vector<double> offset;
  std::vector<int> direction;
  std::vector<std::size_t> reversal_at;  // sample indices where the count rose
  std::uint32_t reversals = 0;
};

Trace run(fric::Compensator& c, const std::vector<double>& velocity, const fric::Params& p) {
  Trace r;
  std::uint32_t before = c.reversals();
  for (std::size_t i = 0; i < velocity.size(); ++i) {
    r.offset.push_back(c.step(velocity[i], kPeriodS, p));
    r.direction.push_back(c.direction());
    if (c.reversals() != before) r.reversal_at.push_back(i);
    before = c.reversals();
  }
  r.reversals = c.reversals();
  return r;
}

Trace run(const std::vector<double>& velocity, const fric::Params& p) {
  fric::Compensator c;
  return run(c, velocity, p);
}

// The X and Y velocities of a circle of radius R at feed F: x = R cos(w t), y = R sin(w t),
// from the phase phase0 on, plus Gaussian noise of sigma (mm/s).
struct Circle {
  double radius_mm = 50.0;
  double feed_mm_s = 1000.0 / 60.0;
  double phase0_rad = std::numbers::pi / 4;
  double turns = 3.0;
  double noise_mm_s = 0.0;
  unsigned seed = 1;
};

std::vector<double> circle_velocity(const Circle& c, bool y_axis) {
  const double w = c.feed_mm_s / c.radius_mm;
  const auto n = static_cast<std::size_t>(c.turns * 2 * std::numbers::pi / w / kPeriodS);
  std::mt19937 rng(c.seed);
  std::normal_distribution<double> noise(0.0, c.noise_mm_s > 0 ? c.noise_mm_s : 1.0);
  std::vector<double> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double phase = c.phase0_rad + w * static_cast<double>(i) * kPeriodS;
    const double ideal =
        y_axis ? c.radius_mm * w * std::cos(phase) : -c.radius_mm * w * std::sin(phase);
    v[i] = ideal + (c.noise_mm_s > 0 ? noise(rng) : 0.0);
  }
  return v;
}

// Appends n samples of a velocity ramp from v0 to v1 (inclusive of neither end's repeat),
// plus noise.
void ramp(std::vector<double>& v, double v0, double v1, std::size_t n, double sigma,
          std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, sigma > 0 ? sigma : 1.0);
  for (std::size_t i = 0; i < n; ++i) {
    const double f = n > 1 ? static_cast<double>(i) / static_cast<double>(n - 1) : 1.0;
    v.push_back(v0 + (v1 - v0) * f + (sigma > 0 ? noise(rng) : 0.0));
  }
}

TEST(CircFricKernel, CircleReversalsCountedExactlyUnderNoise) {
  for (const double sigma : {0.0, 0.002, 0.005}) {
    for (const bool y_axis : {false, true}) {
      Circle c;
      c.noise_mm_s = sigma;
      c.seed = 7 + static_cast<unsigned>(y_axis);
      const std::vector<double> v = circle_velocity(c, y_axis);
      const Trace r = run(v, tuned());
      // Three turns: each axis's velocity crosses zero six times; the first direction is
      // set at the start and is not a reversal.
      EXPECT_EQ(r.reversals, 6u) << "sigma " << sigma << (y_axis ? " Y" : " X");
      ASSERT_EQ(r.reversal_at.size(), 6u);

      // Each detection is near a true zero crossing: after it by no more than the band's
      // delay (threshold + 5 sigma) / acceleration, before it only when the noise beyond
      // 5 sigma leaves the band early; and its pulse points the new way.
      const double w = c.feed_mm_s / c.radius_mm;
      const double accel = c.radius_mm * w * w;
      const double max_delay_s = (0.02 + 5 * sigma) / accel + kPeriodS;
      const double max_early_s = std::max(0.0, 5 * sigma - 0.02) / accel + kPeriodS;
      for (std::size_t k = 0; k < r.reversal_at.size(); ++k) {
        const std::size_t i = r.reversal_at[k];
        const double t = static_cast<double>(i) * kPeriodS;
        const double phase = c.phase0_rad + w * t;
        // Zero crossings of sin (X) are at k pi, of cos (Y) at pi/2 + k pi.
        const double base = y_axis ? std::numbers::pi / 2 : 0.0;
        const double crossing_phase =
            base + std::round((phase - base) / std::numbers::pi) * std::numbers::pi;
        const double delay_s = (phase - crossing_phase) / w;
        EXPECT_GE(delay_s, -max_early_s) << "reversal " << k << " sigma " << sigma;
        EXPECT_LE(delay_s, max_delay_s) << "reversal " << k << " sigma " << sigma;
        const double ideal_after =
            y_axis ? std::cos(phase + w * 0.05) : -std::sin(phase + w * 0.05);
        const int new_direction = ideal_after > 0 ? 1 : -1;
        EXPECT_EQ(r.direction[i], new_direction);
        EXPECT_DOUBLE_EQ(r.offset[i], new_direction * 0.004);
      }
    }
  }
}

TEST(CircFricKernel, NoChatterAtStandstillWithNoise) {
  for (const double move : {10.0, -10.0}) {
    std::mt19937 rng(3);
    std::vector<double> v;
    ramp(v, move, move, 500, 0.0, rng);    // a move ...
    ramp(v, 0.0, 0.0, 60000, 0.004, rng);  // ... then a minute at rest, noise 1/5 of the band
    const Trace r = run(v, tuned());
    EXPECT_EQ(r.reversals, 0u) << move;
    for (std::size_t i = 0; i < v.size(); ++i) ASSERT_EQ(r.offset[i], 0.0) << i;
  }
}

// Noise beyond the band (a vel-threshold set too low: the limit docs/circfric.md states)
// flips the direction every few periods; min-travel keeps that from becoming chatter: a pulse
// needs a stroke of 1 um, which the noise's random walk reaches only rarely.
TEST(CircFricKernel, NoiseBeyondTheBandDoesNotChatterThanksToMinTravel) {
  std::mt19937 rng(4);
  std::vector<double> v;
  ramp(v, 10.0, 10.0, 500, 0.0, rng);
  ramp(v, 0.0, 0.0, 60000, 0.05, rng);  // a minute at rest, noise 2.5x the band
  fric::Params p = tuned();
  const Trace guarded = run(v, p);
  std::size_t changes = 0;
  for (std::size_t i = 1; i < v.size(); ++i) {
    changes += guarded.direction[i] != guarded.direction[i - 1];
  }
  EXPECT_GT(changes, 10000u);  // the band alone does not hold this noise
  // The stop after the 5 mm move, and a few more in the minute; never two within a second.
  EXPECT_GE(guarded.reversals, 1u);
  EXPECT_LE(guarded.reversals, 10u);
  for (std::size_t k = 1; k < guarded.reversal_at.size(); ++k) {
    EXPECT_GT(guarded.reversal_at[k] - guarded.reversal_at[k - 1], 1000u);
  }

  // Without the stroke guard the same noise chatters: what the checks above rule out.
  p.min_travel = 0.0;
  EXPECT_GT(run(v, p).reversals, 5000u);
}

TEST(CircFricKernel, SlowJogOverAReversalFiresOnce) {
  const double f10 = 10.0 / 60.0;  // F10 in mm/s
  for (const std::size_t ramp_periods : {std::size_t{1}, std::size_t{50}, std::size_t{4000}}) {
    for (const double sigma : {0.0, 0.004}) {
      std::mt19937 rng(static_cast<unsigned>(ramp_periods) + 11);
      std::vector<double> v;
      ramp(v, f10, f10, 3000, sigma, rng);
      ramp(v, f10, -f10, ramp_periods, sigma, rng);
      ramp(v, -f10, -f10, 3000, sigma, rng);
      const Trace r = run(v, tuned());
      EXPECT_EQ(r.reversals, 1u) << "ramp " << ramp_periods << " sigma " << sigma;
      ASSERT_EQ(r.reversal_at.size(), 1u);
      EXPECT_DOUBLE_EQ(r.offset[r.reversal_at[0]], -0.004);
    }
  }
}

TEST(CircFricKernel, StopThenOnwardIsNotAReversalStopThenBackIsOne) {
  std::mt19937 rng(5);
  std::vector<double> onward;
  ramp(onward, 2.0, 2.0, 1000, 0.0, rng);
  ramp(onward, 0.0, 0.0, 2000, 0.004, rng);
  ramp(onward, 2.0, 2.0, 1000, 0.0, rng);
  EXPECT_EQ(run(onward, tuned()).reversals, 0u);

  std::vector<double> back;
  ramp(back, 2.0, 2.0, 1000, 0.0, rng);
  ramp(back, 0.0, 0.0, 2000, 0.004, rng);
  ramp(back, -2.0, -2.0, 1000, 0.0, rng);
  const Trace r = run(back, tuned());
  EXPECT_EQ(r.reversals, 1u);
  ASSERT_EQ(r.reversal_at.size(), 1u);
  EXPECT_EQ(r.reversal_at[0], 3000u);  // when the move back starts, not when it stopped
}

TEST(CircFricKernel, FirstMoveAndShortStrokesAreNotReversals) {
  std::mt19937 rng(6);
  std::vector<double> v;
  ramp(v, -1.0, -1.0, 100, 0.0, rng);  // start-up: direction set, no reversal
  ramp(v, 0.1, 0.1, 5, 0.0, rng);      // 0.1 mm of -, reversal; then only 0.0005 mm of +
  ramp(v, -0.1, -0.1, 20, 0.0, rng);   // back: a stroke below min-travel, not counted
  ramp(v, 0.1, 0.1, 5, 0.0, rng);      // 0.002 mm of -: counted
  const Trace r = run(v, tuned());
  ASSERT_EQ(r.reversal_at.size(), 2u);
  EXPECT_EQ(r.reversal_at[0], 100u);
  EXPECT_EQ(r.reversal_at[1], 125u);
  EXPECT_EQ(r.direction[0], -1);

  // Also with no stroke required, the first move is not a reversal.
  fric::Params p = tuned();
  p.min_travel = 0.0;
  const Trace first = run(std::vector<double>(10, 1.0), p);
  EXPECT_EQ(first.reversals, 0u);
  EXPECT_EQ(first.offset[0], 0.0);
}

TEST(CircFricKernel, PulseShapeIsTheDecayingExponentialInTheNewDirection) {
  fric::Params p = tuned();
  std::mt19937 rng(8);
  std::vector<double> v;
  ramp(v, 1.0, 1.0, 100, 0.0, rng);
  ramp(v, -1.0, -1.0, 500, 0.0, rng);
  const Trace r = run(v, p);
  ASSERT_EQ(r.reversal_at.size(), 1u);
  const std::size_t k0 = r.reversal_at[0];
  ASSERT_EQ(k0, 100u);
  EXPECT_EQ(r.offset[k0 - 1], 0.0);
  EXPECT_EQ(r.offset[k0], -p.amplitude);  // t = 0: the amplitude, in the new (-) direction
  EXPECT_NEAR(r.offset[k0 + 20], -p.amplitude / std::numbers::e, 1e-12);  // t = decay
  for (std::size_t k = 0; k < 400; ++k) {
    const double t_s = static_cast<double>(k) * kPeriodS;
    ASSERT_NEAR(r.offset[k0 + k], -p.amplitude * std::exp(-t_s / 0.020), 1e-15) << k;
  }
  // Ended after 20 time constants (the sum of the periods reaches 0.4 s in the 400th or
  // 401st): exactly 0, not a tail of denormals.
  EXPECT_NE(r.offset[k0 + 399], 0.0);
  EXPECT_EQ(r.offset[k0 + 401], 0.0);
  EXPECT_EQ(r.offset.back(), 0.0);

  // The next reversal, within the pulse, flips the sign and restarts at the amplitude.
  fric::Compensator c;
  std::vector<double> w;
  ramp(w, 1.0, 1.0, 100, 0.0, rng);
  ramp(w, -1.0, -1.0, 10, 0.0, rng);
  ramp(w, 1.0, 1.0, 50, 0.0, rng);
  const Trace flip = run(c, w, p);
  ASSERT_EQ(flip.reversal_at.size(), 2u);
  EXPECT_NEAR(flip.offset[109], -p.amplitude * std::exp(-9 * kPeriodS / 0.020), 1e-15);
  EXPECT_EQ(flip.offset[110], p.amplitude);
  EXPECT_GT(flip.offset[111], 0.0);
}

// With a rise time the pulse starts at 0, peaks at exactly the amplitude at
// t_peak = ln(decay / rise) decay rise / (decay - rise), and follows the difference of the two
// exponentials; amplitude-max bounds it as it bounds the plain pulse.
TEST(CircFricKernel, PulseWithARiseStartsAtZeroAndPeaksAtTheAmplitude) {
  fric::Params p = tuned();
  p.decay_ms = 40.0;
  p.rise_ms = 10.0;
  const double td = 0.040, tr = 0.010;
  const double tp = std::log(td / tr) * td * tr / (td - tr);  // 18.48 ms
  EXPECT_NEAR(fric::pulse_peak_time(td, tr), tp, 1e-15);
  EXPECT_EQ(fric::pulse_peak_time(td, 0.0), 0.0);
  const double peak = std::exp(-tp / td) - std::exp(-tp / tr);
  std::mt19937 rng(9);
  std::vector<double> v;
  ramp(v, 1.0, 1.0, 100, 0.0, rng);
  ramp(v, -1.0, -1.0, 900, 0.0, rng);
  const Trace r = run(v, p);
  ASSERT_EQ(r.reversal_at.size(), 1u);
  const std::size_t k0 = r.reversal_at[0];
  EXPECT_EQ(r.offset[k0], 0.0);
  double highest = 0.0;
  std::size_t at = 0;
  for (std::size_t k = 0; k < 800; ++k) {
    const double t_s = static_cast<double>(k) * kPeriodS;
    const double want = -p.amplitude * (std::exp(-t_s / td) - std::exp(-t_s / tr)) / peak;
    ASSERT_NEAR(r.offset[k0 + k], want, 1e-15) << k;
    if (std::fabs(r.offset[k0 + k]) > highest) highest = std::fabs(r.offset[k0 + k]), at = k;
  }
  EXPECT_EQ(at, 18u);  // the sample nearest 18.48 ms
  EXPECT_LE(highest, p.amplitude);
  EXPECT_NEAR(highest, p.amplitude, 1e-3 * p.amplitude);
  EXPECT_EQ(r.offset[k0 + 801], 0.0);  // ended after 20 decay time constants

  // Bounded: amplitude-max below the amplitude flattens the top.
  p.amplitude_max = 0.5 * p.amplitude;
  const Trace b = run(v, p);
  double top = 0.0;
  for (const double o : b.offset) top = std::max(top, std::fabs(o));
  EXPECT_LE(top, p.amplitude_max);
  // The shortest rise still gives a finite pulse that peaks at the amplitude.
  p = tuned();
  p.rise_ms = 0.95 * p.decay_ms;
  fric::Compensator c;
  double most = 0.0;
  for (int i = 0; i < 50; ++i) c.step(1.0, kPeriodS, p);
  for (int i = 0; i < 400; ++i) most = std::max(most, std::fabs(c.step(-1.0, kPeriodS, p)));
  EXPECT_EQ(c.rejected(), 0u);
  EXPECT_NEAR(most, p.amplitude, 1e-3 * p.amplitude);
}

// The decay is in time, not in periods: a 4 kHz servo thread gives the same pulse.
TEST(CircFricKernel, DecayIsInMillisecondsWhateverThePeriod) {
  const fric::Params p = tuned();
  for (const double period_s : {250e-6, 2e-3}) {
    fric::Compensator c;
    for (int i = 0; i < 400; ++i) c.step(1.0, period_s, p);
    ASSERT_EQ(c.step(-1.0, period_s, p), -p.amplitude);
    const auto periods = static_cast<int>(std::lround(0.020 / period_s));
    double at_decay = 0.0;
    for (int k = 1; k <= periods; ++k) at_decay = c.step(-1.0, period_s, p);
    EXPECT_NEAR(at_decay, -p.amplitude / std::numbers::e, 1e-12) << period_s;
  }
}

TEST(CircFricKernel, AmplitudeIsBoundedByAmplitudeMaxAlsoWhenLoweredMidPulse) {
  fric::Params p = tuned();
  p.amplitude = 0.05;
  p.amplitude_max = 0.003;
  fric::Compensator c;
  for (int i = 0; i < 50; ++i) c.step(1.0, kPeriodS, p);
  EXPECT_EQ(c.step(-1.0, kPeriodS, p), -0.003);
  p.amplitude_max = 0.001;
  EXPECT_EQ(c.step(-1.0, kPeriodS, p), -0.001);
  p.amplitude_max = 0.0;
  EXPECT_EQ(c.step(-1.0, kPeriodS, p), 0.0);

  // Raised again mid-pulse, the bound does not lift the pulse above the amplitude it started
  // with (the smaller of amplitude and amplitude-max at the reversal).
  p.amplitude_max = 0.5;
  const double raised = c.step(-1.0, kPeriodS, p);
  EXPECT_LT(raised, 0.0);
  EXPECT_GE(raised, -0.003);
}

TEST(CircFricKernel, EnableFalseGivesZeroInTheNextPeriodAndDetectionGoesOn) {
  fric::Params p = tuned();
  fric::Compensator c;
  for (int i = 0; i < 50; ++i) c.step(1.0, kPeriodS, p);
  EXPECT_EQ(c.step(-1.0, kPeriodS, p), -p.amplitude);
  EXPECT_LT(c.step(-1.0, kPeriodS, p), 0.0);
  p.enable = false;
  EXPECT_EQ(c.step(-1.0, kPeriodS, p), 0.0);
  EXPECT_FALSE(c.active());
  for (int i = 0; i < 50; ++i) c.step(1.0, kPeriodS, p);  // a reversal while disabled
  EXPECT_EQ(c.reversals(), 2u);
  EXPECT_EQ(c.offset(), 0.0);
  p.enable = true;  // no pulse after the fact: the next reversal starts one
  EXPECT_EQ(c.step(1.0, kPeriodS, p), 0.0);
  EXPECT_EQ(c.step(-1.0, kPeriodS, p), -p.amplitude);
}

TEST(CircFricKernel, NonsenseParametersAreRejectedFlaggedAndGiveZero) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* what;
    void (*spoil)(fric::Params&, double, double);
    std::uint32_t bit;
  };
  const Case cases[] = {
      {"amplitude NaN", [](fric::Params& p, double n, double) { p.amplitude = n; },
       fric::kRejectAmplitude},
      {"amplitude -1e-6", [](fric::Params& p, double, double) { p.amplitude = -1e-6; },
       fric::kRejectAmplitude},
      {"amplitude 2", [](fric::Params& p, double, double) { p.amplitude = 2.0; },
       fric::kRejectAmplitude},
      {"amplitude-max inf", [](fric::Params& p, double, double i) { p.amplitude_max = i; },
       fric::kRejectAmplitudeMax},
      {"amplitude-max -0.1", [](fric::Params& p, double, double) { p.amplitude_max = -0.1; },
       fric::kRejectAmplitudeMax},
      {"decay 0", [](fric::Params& p, double, double) { p.decay_ms = 0.0; }, fric::kRejectDecay},
      {"decay -5", [](fric::Params& p, double, double) { p.decay_ms = -5.0; }, fric::kRejectDecay},
      {"decay NaN", [](fric::Params& p, double n, double) { p.decay_ms = n; }, fric::kRejectDecay},
      {"decay 5e-324", [](fric::Params& p, double, double) { p.decay_ms = 5e-324; },
       fric::kRejectDecay},
      {"decay 1001", [](fric::Params& p, double, double) { p.decay_ms = 1001.0; },
       fric::kRejectDecay},
      {"threshold -1", [](fric::Params& p, double, double) { p.vel_threshold = -1.0; },
       fric::kRejectThreshold},
      {"threshold NaN", [](fric::Params& p, double n, double) { p.vel_threshold = n; },
       fric::kRejectThreshold},
      {"min-travel inf", [](fric::Params& p, double, double i) { p.min_travel = i; },
       fric::kRejectMinTravel},
      {"rise -1", [](fric::Params& p, double, double) { p.rise_ms = -1.0; }, fric::kRejectRise},
      {"rise NaN", [](fric::Params& p, double n, double) { p.rise_ms = n; }, fric::kRejectRise},
      {"rise 5e-324", [](fric::Params& p, double, double) { p.rise_ms = 5e-324; },
       fric::kRejectRise},
      {"rise = decay", [](fric::Params& p, double, double) { p.rise_ms = p.decay_ms; },
       fric::kRejectRise},
      {"rise 0.96 decay", [](fric::Params& p, double, double) { p.rise_ms = 0.96 * p.decay_ms; },
       fric::kRejectRise},
  };
  for (const Case& k : cases) {
    fric::Params p = tuned();
    fric::Compensator c;
    for (int i = 0; i < 50; ++i) c.step(1.0, kPeriodS, p);
    EXPECT_EQ(c.step(-1.0, kPeriodS, p), -p.amplitude);  // a pulse is running
    EXPECT_LT(c.step(-1.0, kPeriodS, p), 0.0);
    k.spoil(p, nan, inf);
    EXPECT_EQ(c.step(-1.0, kPeriodS, p), 0.0) << k.what;
    EXPECT_EQ(c.rejected(), k.bit) << k.what;
    EXPECT_FALSE(c.active()) << k.what;
    // Detection holds while rejected: a move back is not seen ...
    for (int i = 0; i < 50; ++i) EXPECT_EQ(c.step(1.0, kPeriodS, p), 0.0) << k.what;
    EXPECT_EQ(c.direction(), -1) << k.what;
    EXPECT_EQ(c.reversals(), 1u) << k.what;
    // ... and once the parameter is good again, the pulse starts on the next reversal.
    const fric::Params good = tuned();
    EXPECT_EQ(c.step(1.0, kPeriodS, good), good.amplitude) << k.what;
    EXPECT_EQ(c.rejected(), 0u);
  }

  fric::Compensator c;
  EXPECT_EQ(c.step(nan, kPeriodS, tuned()), 0.0);
  EXPECT_EQ(c.rejected(), fric::kRejectVelocity);
  EXPECT_EQ(c.step(-inf, kPeriodS, tuned()), 0.0);
  EXPECT_EQ(c.direction(), 0);
  EXPECT_EQ(c.step(1.0, 0.0, tuned()), 0.0);
  EXPECT_EQ(c.rejected(), fric::kRejectPeriod);
  EXPECT_EQ(c.step(1.0, 1.0, tuned()), 0.0);
  EXPECT_EQ(c.rejected(), fric::kRejectPeriod);
  EXPECT_EQ(fric::check(tuned(), 0.0, kPeriodS), 0u);
}

// For any parameter values (finite or not), |offset| <= amplitude-max when that is valid and
// 0 when it is not, and the output is finite; random steps with reversals, so pulses run.
TEST(CircFricKernel, OutputNeverExceedsAmplitudeMaxForAnyParameters) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const double pool[] = {nan,   inf,  -inf, -1.0, -1e-300, 0.0,    5e-324, 1e-9,   1e-4,
                         0.002, 0.01, 0.5,  1.0,  1.0001,  20.0,   999.0,  1000.0, 1e300,
                         -0.0,  3e-3, 7e-6, 0.25, 100.0,   4.9e-4, 1e-3,   2.0};
  const double velocities[] = {nan, inf,  -inf, 0.0,   1e-3,  -1e-3,
                               0.5, -0.5, 30.0, -30.0, 1e308, -1e308};
  std::mt19937 rng(12345);
  std::uniform_int_distribution<std::size_t> pick(0, std::size(pool) - 1);
  std::uniform_int_distribution<std::size_t> pick_v(0, std::size(velocities) - 1);
  std::uniform_int_distribution<int> coin(0, 9);
  fric::Compensator c;
  fric::Params p = tuned();
  std::size_t pulsing = 0;
  for (int i = 0; i < 400000; ++i) {
    if (coin(rng) == 0) {  // a parameter changes now and then
      switch (coin(rng) % 7) {
        case 0:
          p.amplitude = pool[pick(rng)];
          break;
        case 1:
          p.amplitude_max = pool[pick(rng)];
          break;
        case 2:
          p.decay_ms = pool[pick(rng)];
          break;
        case 3:
          p.vel_threshold = pool[pick(rng)];
          break;
        case 4:
          p.min_travel = pool[pick(rng)];
          break;
        case 5:
          p.rise_ms = pool[pick(rng)];
          break;
        default:
          p.enable = coin(rng) < 8;
          break;
      }
    }
    if (coin(rng) == 0) p = tuned();  // back to sane values, so pulses keep happening
    // Long strokes of one sign with an odd value from the list in between.
    const double v = coin(rng) == 0 ? velocities[pick_v(rng)] : ((i / 300) % 2 ? 5.0 : -5.0);
    const double out = c.step(v, kPeriodS, p);
    ASSERT_TRUE(std::isfinite(out)) << i;
    const bool max_ok = p.amplitude_max >= 0.0 && p.amplitude_max <= fric::kMaxAmplitude;
    ASSERT_LE(std::fabs(out), max_ok ? p.amplitude_max : 0.0) << i;
    if (c.rejected() != 0) {
      ASSERT_EQ(out, 0.0) << i;
    }
    if (!p.enable) {
      ASSERT_EQ(out, 0.0) << i;
    }
    pulsing += out != 0.0;
  }
  EXPECT_GT(pulsing, 10000u);  // the property held while pulses ran, not only at rest
}

}  // namespace
