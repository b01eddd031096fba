#include "circfric_kernel.hpp"

#include <cmath>

namespace circtest::fric {

namespace {

constexpr double kStrokeCap = 1e12;

// NaN fails every comparison, so each test below rejects it.
bool non_negative(double v) {
  return v >= 0.0 && std::isfinite(v);
}

bool amplitude_ok(double v) {
  return v >= 0.0 && v <= kMaxAmplitude;
}

bool rise_ok(double rise_ms, double decay_ms) {
  if (rise_ms == 0.0) return true;
  return rise_ms >= kMinDecayMs && rise_ms <= kMaxRiseShareOfDecay * decay_ms;
}

}  // namespace

std::uint32_t check(const Params& p, double vel_cmd, double period_s) noexcept {
  std::uint32_t r = kRejectNone;
  if (!amplitude_ok(p.amplitude)) r |= kRejectAmplitude;
  if (!amplitude_ok(p.amplitude_max)) r |= kRejectAmplitudeMax;
  if (!(p.decay_ms >= kMinDecayMs && p.decay_ms <= kMaxDecayMs)) r |= kRejectDecay;
  if (!rise_ok(p.rise_ms, p.decay_ms)) r |= kRejectRise;
  if (!non_negative(p.vel_threshold)) r |= kRejectThreshold;
  if (!non_negative(p.min_travel)) r |= kRejectMinTravel;
  if (!std::isfinite(vel_cmd)) r |= kRejectVelocity;
  if (!(period_s >= kMinPeriodS && period_s <= kMaxPeriodS)) r |= kRejectPeriod;
  return r;
}

bool Compensator::detect(double vel_cmd, double period_s, const Params& p) noexcept {
  int now = direction_;
  if (vel_cmd > p.vel_threshold) {
    now = 1;
  } else if (vel_cmd < -p.vel_threshold) {
    now = -1;
  }
  bool reversal = false;
  if (now != direction_) {
    // From 0 (start-up) there is no stroke to reverse.
    reversal = direction_ != 0 && direction_ * stroke_ >= p.min_travel;
    direction_ = now;
    stroke_ = 0.0;
  }
  // Saturated so that an absurd (finite) velocity cannot make the stroke infinite and then NaN;
  // only its comparison with min_travel matters.
  stroke_ += vel_cmd * period_s;
  if (stroke_ > kStrokeCap) stroke_ = kStrokeCap;
  if (stroke_ < -kStrokeCap) stroke_ = -kStrokeCap;
  return reversal;
}

double Compensator::pulse_value(const Params& p) noexcept {
  if (!pulse_active_) return 0.0;
  if (pulse_elapsed_s_ >= kPulseEndTimeConstants * pulse_tau_s_) {
    pulse_active_ = false;
    return 0.0;
  }
  double shape = std::exp(-pulse_elapsed_s_ / pulse_tau_s_);
  if (pulse_rise_s_ > 0.0) {
    shape = (shape - std::exp(-pulse_elapsed_s_ / pulse_rise_s_)) * pulse_scale_;
  }
  const double v = pulse_amplitude_ * shape;
  // amplitude_max may have been lowered since the pulse started.
  const double bounded = v < p.amplitude_max ? v : p.amplitude_max;
  return pulse_direction_ * bounded;
}

double Compensator::step(double vel_cmd, double period_s, const Params& p) noexcept {
  rejected_ = check(p, vel_cmd, period_s);
  if (rejected_ != kRejectNone) {
    pulse_active_ = false;
    offset_ = 0.0;
    return offset_;
  }
  if (pulse_active_) pulse_elapsed_s_ += period_s;
  if (detect(vel_cmd, period_s, p)) {
    ++reversals_;
    if (p.enable) {
      pulse_active_ = true;
      pulse_direction_ = direction_;
      pulse_amplitude_ = p.amplitude < p.amplitude_max ? p.amplitude : p.amplitude_max;
      pulse_tau_s_ = p.decay_ms * 1e-3;
      pulse_rise_s_ = p.rise_ms * 1e-3;
      pulse_scale_ = 1.0;
      if (pulse_rise_s_ > 0.0) {
        // check() keeps rise at most 0.95 decay, where the peak is still 0.019 of the scale.
        const double tp = pulse_peak_time(pulse_tau_s_, pulse_rise_s_);
        pulse_scale_ = 1.0 / (std::exp(-tp / pulse_tau_s_) - std::exp(-tp / pulse_rise_s_));
      }
      pulse_elapsed_s_ = 0.0;
    }
  }
  if (!p.enable) pulse_active_ = false;
  offset_ = pulse_value(p);
  return offset_;
}

}  // namespace circtest::fric
