#include "circdrive_kernel.hpp"

#include <cmath>

namespace circtest::drive {

namespace {

bool finite(double v) {
  return std::isfinite(v);
}

double sign(double v) {
  return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
}

}  // namespace

void Drive::reset(double position) {
  position_ = finite(position) ? position : 0.0;
  velocity_ = 0.0;
  integral_ = 0.0;
  friction_ = 0.0;
  effort_ = 0.0;
}

double Drive::step(double vel_cmd, double period_s, const Params& p) {
  rejected_ = kRejectNone;
  if (!(period_s >= kMinPeriodS && period_s <= kMaxPeriodS)) {
    rejected_ = kRejectPeriod;
    return position_;
  }
  const double t = period_s;
  double tau = p.tau_s;
  if (!(tau > 0.0)) {
    rejected_ |= kRejectTau;
    tau = t;
  }
  tau = tau < t ? t : tau;  // explicit integration needs T / tau <= 1
  double coulomb = p.coulomb, breakaway = p.breakaway;
  if (!(coulomb >= 0.0 && finite(coulomb) && breakaway >= 0.0 && finite(breakaway))) {
    rejected_ |= kRejectFriction;
    coulomb = breakaway = 0.0;
  }
  breakaway = breakaway < coulomb ? coulomb : breakaway;
  double ti = p.ti_s;
  if (!finite(ti)) {
    rejected_ |= kRejectIntegral;
    ti = 0.0;
  }
  if (!finite(vel_cmd)) {
    rejected_ |= kRejectCommand;
    vel_cmd = 0.0;
  }

  const double err = vel_cmd - velocity_;
  if (p.enable && ti > 0.0) {
    integral_ += err * t / (tau * ti);
  } else {
    integral_ = 0.0;
  }
  effort_ = p.enable ? err / tau + integral_ : 0.0;
  const double sliding = coulomb / tau, sticking = breakaway / tau;

  if (velocity_ == 0.0) {
    if (std::abs(effort_) <= sticking) {
      friction_ = effort_;  // static friction holds the motor exactly
      return position_;
    }
    ++breakaways_;
    friction_ = sliding * sign(effort_);
    velocity_ = (effort_ - friction_) * t;
  } else {
    friction_ = sliding * sign(velocity_);
    const double v = velocity_ + (effort_ - friction_) * t;
    // Friction cannot push the motor backwards: a sign change within the period is a stop.
    const bool reversed = v * velocity_ <= 0.0;
    const bool settled = std::abs(v) < kRestVelocity && std::abs(effort_) <= sticking;
    velocity_ = (sliding > 0.0 && (reversed || settled)) ? 0.0 : v;
  }
  position_ += velocity_ * t;
  return position_;
}

}  // namespace circtest::drive
