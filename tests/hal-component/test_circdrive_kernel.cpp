// circdrive's kernel against the analytic model of each of its parts: the first-order motor
// lag (forward Euler, exact to rounding), the velocity a drive without integral action loses
// to Coulomb friction, the integral action that wins it back, stiction that holds the motor
// until the effort beats the breakaway, the stop at a reversal, and the refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "circdrive_kernel.hpp"

namespace drive = circtest::drive;

namespace {

constexpr double kT = 0.001;  // s, the servo period

drive::Params params(double tau, double ti = 0.0, double coulomb = 0.0, double breakaway = 0.0) {
  drive::Params p;
  p.enable = true;
  p.tau_s = tau;
  p.ti_s = ti;
  p.coulomb = coulomb;
  p.breakaway = breakaway;
  return p;
}

}  // namespace

// v_k = V (1 - (1 - T / tau)^k) and the position its running sum times T.
TEST(CircdriveKernel, FirstOrderLagWithoutFriction) {
  drive::Drive d;
  const auto p = params(0.004);
  const double v_cmd = 10.0;
  double pos = 0.0;
  for (int k = 1; k <= 50; ++k) {
    d.step(v_cmd, kT, p);
    const double v = v_cmd * (1.0 - std::pow(1.0 - kT / 0.004, k));
    pos += v * kT;
    ASSERT_NEAR(d.velocity(), v, 1e-12) << k;
    ASSERT_NEAR(d.position(), pos, 1e-12) << k;
  }
  EXPECT_EQ(d.breakaways(), 1u);
  EXPECT_EQ(d.rejected(), drive::kRejectNone);
}

// Without integral action the motor runs Coulomb friction's velocity short, and with it the
// drive wins that back: the steady velocity is the command.
TEST(CircdriveKernel, CoulombLossAndIntegralAction) {
  drive::Drive p_only, pi;
  for (int k = 0; k < 2000; ++k) {
    p_only.step(10.0, kT, params(0.004, 0.0, 0.5, 0.8));
    pi.step(10.0, kT, params(0.004, 0.02, 0.5, 0.8));
  }
  EXPECT_NEAR(p_only.velocity(), 9.5, 1e-9);
  EXPECT_NEAR(p_only.friction(), 0.5 / 0.004, 1e-9);
  EXPECT_NEAR(pi.velocity(), 10.0, 1e-6);
}

// At rest the motor stays exactly where it is while the effort is within the breakaway; a
// command beyond it breaks it free once.
TEST(CircdriveKernel, StictionHoldsUntilBreakaway) {
  drive::Drive d;
  d.reset(2.5);
  for (int k = 0; k < 1000; ++k) d.step(0.79, kT, params(0.004, 0.0, 0.5, 0.8));
  EXPECT_EQ(d.position(), 2.5);
  EXPECT_TRUE(d.stuck());
  EXPECT_EQ(d.breakaways(), 0u);
  EXPECT_NEAR(d.friction(), 0.79 / 0.004, 1e-9) << "static friction equals the effort";
  d.step(0.81, kT, params(0.004, 0.0, 0.5, 0.8));
  EXPECT_GT(d.position(), 2.5);
  EXPECT_EQ(d.breakaways(), 1u);
  // Once sliding, only Coulomb friction acts: 0.6 mm/s keeps it moving at 0.1 mm/s.
  for (int k = 0; k < 1000; ++k) d.step(0.6, kT, params(0.004, 0.0, 0.5, 0.8));
  EXPECT_NEAR(d.velocity(), 0.1, 1e-9);
}

// With integral action a command below the breakaway still breaks the motor free: the
// integral winds up while it sticks (the cause of the quadrant spike).
TEST(CircdriveKernel, IntegralWindsUpWhileStuck) {
  drive::Drive d;
  int stuck_periods = 0;
  while (d.breakaways() == 0 && stuck_periods < 10000) {
    d.step(0.15, kT, params(0.004, 0.02, 0.5, 0.8));
    ++stuck_periods;
  }
  // effort = (0.15 + 0.15 k T / ti) / tau > 0.8 / tau  <=>  k > 0.65 ti / (0.15 T) = 86.7
  EXPECT_EQ(stuck_periods, 87);
}

// A command that reverses: friction stops the motor at the turning point (never pushes it
// backwards), it sticks, breaks free the other way; the position moves on without a jump.
TEST(CircdriveKernel, ReversalStopsAndBreaksFreeOnce) {
  drive::Drive d;
  const auto p = params(0.004, 0.02, 0.5, 0.8);
  double max_step = 0.0, last = 0.0;
  int stuck_after_start = 0;
  for (int k = 0; k < 4000; ++k) {
    const double v_cmd = 20.0 * std::cos(2.0 * M_PI * k * kT / 4.0);  // one reversal at 1 s
    d.step(v_cmd, kT, p);
    max_step = std::max(max_step, std::abs(d.position() - last));
    last = d.position();
    if (k > 200 && d.stuck()) ++stuck_after_start;
  }
  EXPECT_EQ(d.breakaways(), 3u) << "start, reversal at 1 s and at 3 s";
  EXPECT_GT(stuck_after_start, 2);
  EXPECT_LT(max_step, 25.0 * kT);
}

TEST(CircdriveKernel, DisabledDriveCoastsAndForgetsItsIntegral) {
  drive::Drive d;
  for (int k = 0; k < 500; ++k) d.step(5.0, kT, params(0.004, 0.02, 0.5, 0.8));
  auto off = params(0.004, 0.02, 0.5, 0.8);
  off.enable = false;
  for (int k = 0; k < 500; ++k) d.step(5.0, kT, off);
  EXPECT_EQ(d.effort(), 0.0);
  EXPECT_TRUE(d.stuck()) << "friction stops a coasting motor";
}

// Nonsense parameters are replaced by safe ones and reported, never propagated as NaN.
TEST(CircdriveKernel, RejectsNonsenseWithoutNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  drive::Drive d;
  d.step(1.0, kT, params(nan));
  EXPECT_EQ(d.rejected(), drive::kRejectTau);
  EXPECT_NEAR(d.velocity(), 1.0, 1e-12) << "tau of one period: the command at once";
  d.step(1.0, kT, params(0.004, 0.0, -0.5, 0.8));
  EXPECT_EQ(d.rejected(), drive::kRejectFriction);
  d.step(1.0, kT, params(0.004, nan));
  EXPECT_EQ(d.rejected(), drive::kRejectIntegral);
  d.step(std::numeric_limits<double>::infinity(), kT, params(0.004));
  EXPECT_EQ(d.rejected(), drive::kRejectCommand);
  const double before = d.position();
  d.step(1.0, 0.0, params(0.004));
  EXPECT_EQ(d.rejected(), drive::kRejectPeriod);
  EXPECT_EQ(d.position(), before);
  EXPECT_TRUE(std::isfinite(d.position()));
  EXPECT_TRUE(std::isfinite(d.velocity()));
}

// A motor that a position loop brings to its target with the integral action holding the
// friction does not creep on forever at a vanishing velocity: below kRestVelocity, with the
// effort within the breakaway, it is at rest, and then exactly still.
TEST(CircdriveKernel, ComesToRestAfterAMove) {
  drive::Drive d;
  const auto p = params(0.004, 0.02, 0.5, 0.8);
  // A P-only position loop (30 1/s) moving the motor to 1 mm, as the pid does.
  for (int k = 0; k < 3000; ++k) d.step(30.0 * (1.0 - d.position()), kT, p);
  EXPECT_TRUE(d.stuck()) << "velocity " << d.velocity();
  const double at_rest = d.position();
  for (int k = 0; k < 1000; ++k) d.step(30.0 * (1.0 - d.position()), kT, p);
  EXPECT_EQ(d.position(), at_rest);
}
