#pragma once
// The HAL-free heart of circfric, the friction (quadrant-glitch) compensator: per joint it
// watches the commanded velocity, detects a reversal with hysteresis and answers it with a
// position offset in the new direction of motion that decays exponentially. Nothing here
// allocates, throws, locks or calls the OS, and a period is a fixed handful of arithmetic
// and one exp(), so the same code runs inside the realtime module and in the unit tests.
//
// Detection is a Schmitt trigger on the velocity: the direction becomes +1 when the velocity
// rises above +vel_threshold and -1 when it falls below -vel_threshold, and holds in between,
// so noise inside the band and a standstill never change it. A change of direction is a
// reversal only if the joint travelled at least min_travel in the old direction since the
// previous change: noise that leaves the band (or a dithering jog) makes no pulses, because
// its strokes integrate to almost nothing. The first direction after start-up is not a
// reversal (there was no motion before to reverse).
//
// The pulse: offset(t) = direction * A * exp(-t / tau), t = 0 in the period the reversal is
// detected, A = min(amplitude, amplitude_max) and tau = decay_ms read at that reversal, and
// ended (exactly 0) after kPulseEndTimeConstants tau. A new reversal replaces a running
// pulse. amplitude_max and enable act in every period: |offset| never exceeds amplitude_max,
// and enable false gives 0 in the same period and cancels the pulse.
//
// With rise_ms > 0 the pulse rises before it decays: offset(t) = direction * A *
// (exp(-t / tau) - exp(-t / rise)) / peak, the difference of two exponentials scaled so that
// its peak, at t_peak = ln(tau / rise) tau rise / (tau - rise), is exactly A. A loop with
// feed-forward passes a position pulse to the table at once, while the table of a drive with
// friction sticks at the reversal for tens of ms: a pulse that starts at 0 and peaks later
// pushes the stuck drive free without a jump in the command (whose derivative FF1 would pass
// on as a velocity kick). rise_ms = 0 keeps the plain decaying pulse.
#include <cstdint>

#include "circtest/core/circfric_limits.hpp"

namespace circtest::fric {

inline constexpr int kMaxInstances = 8;
// exp(-20) = 2e-9: below any machine's resolution, so the pulse is ended there.
inline constexpr double kPulseEndTimeConstants = 20.0;
// Servo periods the kernel accepts (LinuxCNC's servo thread runs at 0.1..10 ms).
inline constexpr double kMinPeriodS = 1e-6;
inline constexpr double kMaxPeriodS = 0.1;

// One period's parameters (HAL pins in the module). Lengths in machine units.
struct Params {
  bool enable = false;
  double amplitude = 0.0;       // pulse height at the reversal, 0..kMaxAmplitude
  double amplitude_max = 0.0;   // bound of |offset|, 0..kMaxAmplitude
  double decay_ms = 10.0;       // time constant, kMinDecayMs..kMaxDecayMs
  double rise_ms = 0.0;         // rise time constant, 0 or kMinDecayMs..0.95 decay_ms
  double vel_threshold = 0.01;  // half-width of the velocity band, units/s, >= 0
  double min_travel = 0.001;    // stroke before a direction change counts, >= 0
};

// Why a period was rejected (0 when it was not); bits, several may be set.
enum Reject : std::uint32_t {
  kRejectNone = 0,
  kRejectAmplitude = 1u << 0,     // NaN, negative or beyond kMaxAmplitude
  kRejectAmplitudeMax = 1u << 1,  // NaN, negative or beyond kMaxAmplitude
  kRejectDecay = 1u << 2,         // NaN or outside kMinDecayMs..kMaxDecayMs
  kRejectThreshold = 1u << 3,     // NaN, infinite or negative
  kRejectMinTravel = 1u << 4,     // NaN, infinite or negative
  kRejectVelocity = 1u << 5,      // the velocity input is NaN or infinite
  kRejectPeriod = 1u << 6,        // period outside kMinPeriodS..kMaxPeriodS
  kRejectRise = 1u << 7,          // NaN, negative, below kMinDecayMs or not below the decay
};

// The reasons P (and the inputs) are not usable, as Reject bits.
std::uint32_t check(const Params& p, double vel_cmd, double period_s) noexcept;

class Compensator {
 public:
  // One servo period: returns the offset to add to the position command. A rejected period
  // (check() not 0) outputs 0, cancels a running pulse and leaves the detection as it was.
  double step(double vel_cmd, double period_s, const Params& p) noexcept;

  double offset() const noexcept { return offset_; }
  bool active() const noexcept { return pulse_active_; }
  // +1 or -1 after the first move beyond the band, 0 before.
  int direction() const noexcept { return direction_; }
  // Reversals detected since start-up (also while enable is false, so that detection can be
  // checked before the output is switched on); wraps at 2^32.
  std::uint32_t reversals() const noexcept { return reversals_; }
  // The Reject bits of the last period.
  std::uint32_t rejected() const noexcept { return rejected_; }

 private:
  // Updates the direction; returns true on a reversal that counts.
  bool detect(double vel_cmd, double period_s, const Params& p) noexcept;
  double pulse_value(const Params& p) noexcept;

  int direction_ = 0;
  double stroke_ = 0.0;  // signed travel since the last change of direction
  std::uint32_t reversals_ = 0;
  std::uint32_t rejected_ = 0;
  bool pulse_active_ = false;
  int pulse_direction_ = 0;
  double pulse_amplitude_ = 0.0;
  double pulse_tau_s_ = 0.0;
  double pulse_rise_s_ = 0.0;  // 0: no rise
  double pulse_scale_ = 1.0;   // 1 / the difference of exponentials at its peak
  double pulse_elapsed_s_ = 0.0;
  double offset_ = 0.0;
};

}  // namespace circtest::fric
