#pragma once
// The HAL-free heart of circdrive, the simulated velocity-mode servo drive of the sim-servo
// configuration: per joint it turns a velocity command (a pid's output, units/s) into a motor
// velocity and position, with the drive's own PI velocity loop, the motor's first-order lag
// and friction (Coulomb while sliding, stiction at rest). Nothing here allocates, throws,
// locks or calls the OS; a period is a fixed handful of arithmetic.
//
// Model, per period T (semi-implicit Euler, velocity first):
//   err    = vel_cmd - v                       velocity error of the drive's loop
//   z     += err T / (tau ti)                  the drive's integral action (ti > 0)
//   effort = err / tau + z                     what the drive pushes with, units/s^2
//   sliding (v != 0):  a = effort - coulomb / tau * sign(v)
//   at rest (v == 0):  stays at rest while |effort| <= breakaway / tau, else
//                      a = effort - coulomb / tau * sign(effort)
//   v += a T; when v changes sign within a period the motor stops there (v = 0, at rest), and
//   so it does below kRestVelocity with the effort within the breakaway
//   pos += v T
// Without friction and integral action the motor velocity follows the command with the time
// constant tau. Friction is given as the velocity a drive without integral action would lose
// to it (coulomb, breakaway in units/s): the integral action wins it back in steady motion,
// so friction leaves no lasting following error, only a transient where the motor reverses
// and sticks: the integral winds up until the effort beats the breakaway, and the position
// loop then catches up the lost motion with its own dynamics (the quadrant spike).
#include <cstdint>

namespace circtest::drive {

inline constexpr int kMaxInstances = 8;
// Below this speed (units/s: 1 nm/s on a mm machine) a sliding motor whose effort is within
// the breakaway is at rest: without it a position loop would bring the motor to its target
// asymptotically, sliding for ever at a vanishing velocity instead of sticking.
inline constexpr double kRestVelocity = 1e-6;
// Servo periods the kernel accepts (LinuxCNC's servo thread runs at 0.1..10 ms).
inline constexpr double kMinPeriodS = 1e-6;
inline constexpr double kMaxPeriodS = 0.1;

// One period's parameters (HAL pins in the module).
struct Params {
  bool enable = false;     // false: no effort (the motor coasts against friction) and z = 0
  double tau_s = 0.005;    // velocity time constant, s; below one period it is one period
  double ti_s = 0.0;       // integral time of the drive's loop, s; 0 (or less) for none
  double coulomb = 0.0;    // sliding friction as lost velocity, units/s, >= 0
  double breakaway = 0.0;  // static friction as lost velocity, units/s, >= coulomb
};

// Why a period's parameters were replaced by safe ones (0 when they were not); bits.
enum Reject : std::uint32_t {
  kRejectNone = 0,
  kRejectTau = 1u << 0,       // NaN or not above 0: one period is used
  kRejectFriction = 1u << 1,  // NaN, infinite or negative coulomb/breakaway: no friction
  kRejectCommand = 1u << 2,   // the velocity command is NaN or infinite: 0 is used
  kRejectPeriod = 1u << 3,    // period outside kMinPeriodS..kMaxPeriodS: nothing moves
  kRejectIntegral = 1u << 4,  // NaN or infinite ti: no integral action
};

class Drive {
 public:
  // Advances one period of period_s seconds; returns the new motor position.
  double step(double vel_cmd, double period_s, const Params& p);

  // Sets the motor position (at rest, no integral) without moving through the model.
  void reset(double position);

  double position() const { return position_; }
  double velocity() const { return velocity_; }
  // The friction acting in the last period, as acceleration (units/s^2, opposing motion).
  double friction() const { return friction_; }
  double effort() const { return effort_; }
  bool stuck() const { return velocity_ == 0.0; }
  // Times the motor broke free from rest; the rejects of the last period.
  std::uint32_t breakaways() const { return breakaways_; }
  std::uint32_t rejected() const { return rejected_; }

 private:
  double position_ = 0.0;
  double velocity_ = 0.0;
  double integral_ = 0.0;
  double friction_ = 0.0;
  double effort_ = 0.0;
  std::uint32_t breakaways_ = 0;
  std::uint32_t rejected_ = kRejectNone;
};

}  // namespace circtest::drive
