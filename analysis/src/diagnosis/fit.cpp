// The fit of the linear parameters with the nonlinear state (play, lag mismatch) iterated.
#include <cmath>

#include "stages.hpp"

namespace circtest::diagnosis_detail {

// Backlash transitions: a few Gauss-Newton steps on the play.
void fit(const Samples& S, Model& model) {
  const std::vector<Column>& cols = model.cols;
  State& st = model.st;
  Solution& sol = model.sol;
  const std::size_t stride = model.stride;
  NormalMemo& memo = model.memo;
  for (int it = 0; it < 4; ++it) {
    sol = solve(accumulate(S, st, cols, stride, memo));
    bool changed = false;
    if (auto j = find(cols, Kind::backlash_a)) {
      const double b = sol.x[static_cast<Eigen::Index>(*j)];
      changed = changed || std::abs(b - st.backlash_a) > 1e-4 * std::abs(b) + 1e-9;
      st.backlash_a = b;
    }
    if (auto j = find(cols, Kind::backlash_b)) {
      const double b = sol.x[static_cast<Eigen::Index>(*j)];
      changed = changed || std::abs(b - st.backlash_b) > 1e-4 * std::abs(b) + 1e-9;
      st.backlash_b = b;
    }
    if (auto j = find(cols, Kind::servo)) {
      const double m = sol.x[static_cast<Eigen::Index>(*j)];
      changed = changed || std::abs(m - st.servo_mismatch_s) > 1e-4 * std::abs(m) + 1e-9;
      st.servo_mismatch_s = m;
    }
    if (!changed) break;
  }
}

}  // namespace circtest::diagnosis_detail
