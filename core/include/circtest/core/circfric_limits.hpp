#pragma once
// What circfric (the friction compensator's realtime kernel, circfric(9)) accepts and the
// shape of its rising pulse, in one place for the kernel and for circcomp, which tunes it.
// Freestanding (only <cmath>): the realtime module compiles it with its own flags.
#include <cmath>

namespace circtest::fric {

// Friction spikes are micrometres high; an amplitude beyond one machine unit (1 mm or 1 in)
// is a typing error, not a tuning.
inline constexpr double kMaxAmplitude = 1.0;
// Time constants below a microsecond are shorter than any servo period (and 0 would divide
// by zero); beyond a second they are a slow position shift, not friction compensation.
inline constexpr double kMinDecayMs = 1e-3;
inline constexpr double kMaxDecayMs = 1000.0;
// A rise time is 0 (none) or at least kMinDecayMs and below the decay: at rise = decay the
// difference of exponentials vanishes, and near it the peak scale divides two small numbers.
inline constexpr double kMaxRiseShareOfDecay = 0.95;

// The time at which the rising pulse exp(-t / decay) - exp(-t / rise) peaks, in the unit of
// its arguments: ln(decay / rise) decay rise / (decay - rise); 0 without a rise.
inline double pulse_peak_time(double decay, double rise) noexcept {
  if (!(rise > 0.0) || !(decay > rise)) return 0.0;
  return std::log(decay / rise) * decay * rise / (decay - rise);
}

}  // namespace circtest::fric
