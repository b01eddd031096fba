// Reversal spikes, first as a decaying step of each axis after its reversal: the decay is
// profiled over a log grid, then refined. The step's height and decay are where the measured
// profile (spike_profile.cpp) starts from.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "profile.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

// Reversal spikes: the decay is profiled over a log grid, then refined. The decays found
// are the next search's starting points.
void search_spikes(const Inputs& in, const SampleSet& ss, Model& m, SpikeHints& hints) {
  const DiagnosisOptions& options = in.options;
  const Samples& S = ss.S;
  std::vector<Column>& cols = m.cols;
  State& st = m.st;
  Solution& sol = m.sol;
  const bool speed_known = ss.speed_known, reversal_a = ss.reversal_a, reversal_b = ss.reversal_b;
  auto fit = [&] { diagnosis_detail::fit(S, m); };
  if (!speed_known || !(reversal_a || reversal_b)) return;
  for (Kind k : {Kind::spike_a, Kind::spike_b}) {
    if (auto j = find(cols, k)) cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*j));
  }
  st.tau_a = st.tau_b = 0.0;
  st.spike_shape = {};
  fit();
  const std::size_t sstride = std::max<std::size_t>(1, (S.size() + 59999) / 60000);
  const double tau_lo = 0.5e-3, tau_hi = 1.0;
  std::array<bool, 2> on = {reversal_a && find(cols, Kind::backlash_a).has_value(),
                            reversal_b && find(cols, Kind::backlash_b).has_value()};
  State trial = st;
  trial.tau_a = trial.tau_b = 0.0;
  const Profile prof = make_profile(S, st, cols, sol, sstride);
  for (int round = 0; round < 2; ++round) {
    for (int ax = 0; ax < 2; ++ax) {
      if (!on[static_cast<std::size_t>(ax)]) continue;
      std::vector<Column> extra;
      if (on[0]) extra.push_back({Kind::spike_a});
      if (on[1]) extra.push_back({Kind::spike_b});
      auto rss_at = [&](double log_tau) {
        State s2 = trial;
        (ax == 0 ? s2.tau_a : s2.tau_b) = std::exp(log_tau);
        // The other axis's spike: its current decay, or out of the fit while still unknown.
        std::vector<Column> ex;
        for (const Column& c : extra) {
          const bool mine = (c.kind == Kind::spike_a) == (ax == 0);
          if (mine || (c.kind == Kind::spike_a ? s2.tau_a : s2.tau_b) > 0) ex.push_back(c);
        }
        return spike_profile_rss(prof, s2, ex);
      };
      // A 29-point log grid, or 7 points around a decay already found (its second pass, or the
      // search again after the pitch refinement), widened to the whole grid when the best
      // point is at the edge of the short one.
      const int n = 28;
      const double l0 = std::log(tau_lo), l1 = std::log(tau_hi);
      const double step = (l1 - l0) / n;
      auto grid_best = [&](int k0, int k1) {
        // The grid's points side by side, then the first lowest in grid order.
        std::vector<double> rss(static_cast<std::size_t>(k1 - k0 + 1));
        for_each_task(rss.size(), [&](std::size_t t) {
          rss[t] = rss_at(l0 + step * (k0 + static_cast<int>(t)));
        });
        double best = std::numeric_limits<double>::infinity();
        int kbest = k0;
        for (int k = k0; k <= k1; ++k) {
          const double r = rss[static_cast<std::size_t>(k - k0)];
          if (r < best) {
            best = r;
            kbest = k;
          }
        }
        return kbest;
      };
      const double hint =
          round == 0 ? hints[static_cast<std::size_t>(ax)] : (ax == 0 ? trial.tau_a : trial.tau_b);
      int kbest = -1;
      if (hint > 0) {
        const int kc =
            std::clamp(static_cast<int>(std::lround((std::log(hint) - l0) / step)), 0, n);
        const int k0 = std::max(0, kc - 3), k1 = std::min(n, kc + 3);
        kbest = grid_best(k0, k1);
        if ((kbest == k0 && k0 > 0) || (kbest == k1 && k1 < n)) kbest = -1;
      }
      if (kbest < 0) kbest = grid_best(0, n);
      // Golden steps until the bracket (2 grid steps) is below 1 % in tau.
      const int steps = static_cast<int>(
          std::ceil(std::log(0.01 / (2 * step)) / std::log((std::sqrt(5.0) - 1.0) / 2.0)));
      const double lt =
          golden(rss_at, l0 + step * kbest - step, l0 + step * kbest + step, std::max(1, steps));
      (ax == 0 ? trial.tau_a : trial.tau_b) = std::exp(lt);
    }
  }
  // The fit without spikes (decays zero), taken back unchanged when every spike found is
  // dropped below.
  const State st_without = st;
  const Solution sol_without = sol;
  hints = {trial.tau_a, trial.tau_b};
  st.tau_a = trial.tau_a;
  st.tau_b = trial.tau_b;
  std::vector<Column> with = cols;
  if (on[0]) with.push_back({Kind::spike_a});
  if (on[1]) with.push_back({Kind::spike_b});
  std::swap(cols, with);
  fit();
  // Keep a spike only when it stands out; else it is noise fitted by the free decay.
  std::vector<Kind> drop;
  for (Kind k : {Kind::spike_a, Kind::spike_b}) {
    const auto j = find(cols, k);
    if (!j) continue;
    const auto ji = static_cast<Eigen::Index>(*j);
    const double h = sol.x[ji];
    const double se = std::sqrt(std::max(0.0, sol.sigma2 * sol.inv(ji, ji)));
    const bool at_edge = (k == Kind::spike_a ? st.tau_a : st.tau_b) > 0.9 * tau_hi;
    if (!(std::abs(h) > options.spike_detection_t * se) || at_edge || h < options.min_spike_mm) {
      drop.push_back(k);
    }
  }
  for (Kind k : drop) {
    cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, k)));
    (k == Kind::spike_a ? st.tau_a : st.tau_b) = 0.0;
  }
  if (drop.size() == static_cast<std::size_t>(on[0]) + static_cast<std::size_t>(on[1])) {
    st = st_without;
    sol = sol_without;
  } else if (!drop.empty()) {
    fit();
  }
}

}  // namespace circtest::diagnosis_detail
