// The backlash at each end of an axis' travel from the residual's steps at its reversals.
#include <algorithm>
#include <cmath>

#include "stages.hpp"

namespace circtest::diagnosis_detail {

// The backlash at each end of an axis' travel on its own: at every reversal the model's step
// is b in the radius (at both ends, both directions); what the residual still steps there,
// from a straight line on each side extrapolated to the reversal, is added to it. The ends
// are averaged over the runs. Both ends must be covered.

void reversal_steps(const Samples& S, const std::vector<double>& resid,
                    const std::array<std::vector<ReversalEvent>, 2>& events, Diagnosis& D) {
  constexpr double kWindowRad = 4.0 * kPi / 180.0;
  constexpr std::size_t kMinSide = 5;
  for (int ax = 0; ax < 2; ++ax) {
    const auto axs = static_cast<std::size_t>(ax);
    if (!D.backlash_mm[axs].value) continue;
    const double b = *D.backlash_mm[axs].value;
    // The angle in which the motor takes up the play (travelled R (1 - cos) = b), twice.
    const double takeup_rad = 2.0 * std::acos(std::max(-1.0, 1.0 - std::abs(b) / S.radius));
    std::array<double, 2> sum{0.0, 0.0};  // [0]: + end, [1]: - end
    std::array<int, 2> count{0, 0};
    for (const ReversalEvent& ev : events[axs]) {
      const std::size_t i = ev.sample;
      const RunInfo& r = S.runs[S.run[i]];
      const double u_rev = S.u[i] - r.dir * ev.since;
      // Least-squares line of the residual against the signed angle on one side, at 0.
      auto intercept = [&](bool after, std::size_t& n) {
        double s0 = 0, s1 = 0, s2 = 0, t0 = 0, t1 = 0;
        n = 0;
        // After the reversal, past twice the take-up of the play: where the true play differs
        // from the fitted one, the residual has a bump there.
        const double from = after ? std::max(r.eps_rad, takeup_rad) : r.eps_rad;
        auto take = [&](std::size_t j) {
          const double d = r.dir * (S.u[j] - u_rev);
          if (std::abs(d) > from + kWindowRad) return false;
          if (std::abs(d) > from) {
            s0 += 1;
            s1 += d;
            s2 += d * d;
            t0 += resid[j];
            t1 += resid[j] * d;
            ++n;
          }
          return true;
        };
        if (after) {
          for (std::size_t j = i; j < r.end && take(j); ++j) {
          }
        } else {
          for (std::size_t j = i; j-- > r.begin && take(j);) {
          }
        }
        const double det = s0 * s2 - s1 * s1;
        return det > 0 ? (s2 * t0 - s1 * t1) / det : 0.0;
      };
      std::size_t na = 0, nb = 0;
      const double after = intercept(true, na), before = intercept(false, nb);
      if (na < kMinSide || nb < kMinSide) continue;
      const std::size_t end = ev.dir < 0 ? 0 : 1;  // moving - after it: the + end
      sum[end] += b + (after - before);
      ++count[end];
    }
    if (count[0] > 0 && count[1] > 0) {
      D.backlash_reversals_mm[axs] = std::array<double, 2>{sum[0] / count[0], sum[1] / count[1]};
    }
  }
}

}  // namespace circtest::diagnosis_detail
