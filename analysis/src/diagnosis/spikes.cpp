// Reversal spikes: a decaying step of each axis after its reversal (stick-slip, a servo's
// reversal overshoot); the decay is profiled over a log grid, then refined.
#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include "profile.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

// Reversal spikes: the decay is profiled over a log grid, then refined. The decays found
// are the next search's starting points.
void search_spikes(DiagnosisState& ds) {
  const DiagnosisOptions& options = ds.options;
  const Samples& S = ds.S;
  std::vector<Column>& cols = ds.cols;
  State& st = ds.st;
  Solution& sol = ds.sol;
  std::array<double, 2>& hints = ds.spike_hints;
  const bool speed_known = ds.speed_known, reversal_a = ds.reversal_a, reversal_b = ds.reversal_b;
  auto fit = [&] { diagnosis_detail::fit(ds); };
  if (!speed_known || !(reversal_a || reversal_b)) return;
  for (Kind k : {Kind::spike_a, Kind::spike_b}) {
    if (auto j = find(cols, k)) cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*j));
  }
  st.tau_a = st.tau_b = 0.0;
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

namespace circtest::diagnosis_detail {

namespace {

// The mean profile of one axis' spike over all its reversals: the deviation along the axis
// (outwards positive) against the time since the reversal, in bins of one sample period.
struct SpikeProfile {
  double bin_s = 0.0;
  std::vector<double> sum, sum2, sum_t;
  std::vector<std::size_t> n;
  double base = 0.0;  // the level the deviation settles at, taken off every bin's mean
  bool valid(std::size_t k) const { return n[k] >= 2; }
  double mean(std::size_t k) const { return sum[k] / static_cast<double>(n[k]) - base; }
  double time(std::size_t k) const { return sum_t[k] / static_cast<double>(n[k]); }
  // The scatter of the reversals about their mean, pooled over all bins: a bin's own few
  // samples would make its standard error as noisy as its mean, and the largest of a thousand
  // noisy means over their own noisy errors stands out by chance.
  double sd = 0.0;
  void pool() {
    double ss = 0.0, dof = 0.0;
    for (std::size_t k = 0; k < n.size(); ++k) {
      if (!valid(k)) continue;
      const double nk = static_cast<double>(n[k]), m = sum[k] / nk;
      ss += std::max(0.0, sum2[k] - nk * m * m);
      dof += nk - 1.0;
    }
    sd = dof > 0 ? std::sqrt(ss / dof) : 0.0;
  }
  double standard_error(std::size_t k) const { return sd / std::sqrt(static_cast<double>(n[k])); }
};

// The profile looks this far past a reversal: as far as the decay search (1 s), and no
// further than 60 deg of the circle, where the axis still carries at least half of the radial
// deviation (cos 60 deg) and the other axis' reversal (at 90 deg) is not yet near.
constexpr double kProfileWindowS = 1.0;
constexpr double kProfileWindowRad = kPi / 3.0;
constexpr double kMaxProfileBins = 20000.0;

// The sample period: eps_rad is 1.5 periods of travel (runs.cpp).
double sample_period_s(const Samples& S) {
  double period = std::numeric_limits<double>::infinity();
  for (const RunInfo& r : S.runs) {
    if (r.eps_rad > 0 && r.speed_mm_s > 0) {
      period = std::min(period, r.eps_rad * S.radius / (1.5 * r.speed_mm_s));
    }
  }
  return std::isfinite(period) && period > 0 ? period : 0.0;
}

// The residual plus the fitted spike of axis ax, divided by the spike's direction factor
// (-dir cos for A, -dir sin for B): the axis' deviation after each reversal, averaged.
SpikeProfile spike_profile(const DiagnosisState& ds, int ax, const std::vector<double>& resid,
                           const std::vector<ReversalEvent>& events, int only_dir = 0) {
  const Samples& S = ds.S;
  SpikeProfile p;
  const double period_s = sample_period_s(S);
  if (!(period_s > 0)) return p;
  // At most kMaxProfileBins bins, whatever the sample rate a trace claims.
  p.bin_s = std::max(period_s, kProfileWindowS / kMaxProfileBins);
  const auto nbins = static_cast<std::size_t>(std::ceil(kProfileWindowS / p.bin_s)) + 1;
  p.sum.assign(nbins, 0.0);
  p.sum2.assign(nbins, 0.0);
  p.sum_t.assign(nbins, 0.0);
  p.n.assign(nbins, 0);
  const auto j = find(ds.cols, ax == 0 ? Kind::spike_a : Kind::spike_b);
  const double h = j ? ds.sol.x[static_cast<Eigen::Index>(*j)] : 0.0;
  const double tau = ax == 0 ? ds.st.tau_a : ds.st.tau_b;
  const Reversals rev(S, ds.st.servo_mismatch_s);
  for (const ReversalEvent& ev : events) {
    if (only_dir != 0 && ev.dir != only_dir) continue;
    const RunInfo& r = S.runs[S.run[ev.sample]];
    if (!(r.speed_mm_s > 0)) continue;
    double last = -1.0;
    for (std::size_t i = ev.sample; i < r.end; ++i) {
      const Reversal rv = rev.at(i);
      const double since = ax == 0 ? rv.since_a : rv.since_b;
      if (since < last || since > kProfileWindowRad) break;  // the next reversal, or too far
      last = since;
      const double dt = since * S.radius / r.speed_mm_s;
      if (since < r.eps_rad) continue;  // left out of the fit too
      const auto k = static_cast<std::size_t>(dt / p.bin_s);
      if (k >= nbins) break;
      const double factor = -static_cast<double>(ev.dir) * (ax == 0 ? S.c[i] : S.s[i]);
      if (std::abs(factor) < 0.5) continue;
      const double fitted = tau > 0 && dt < kSpikeCut * tau ? h * std::exp(-dt / tau) : 0.0;
      const double y = resid[i] / factor + fitted;
      p.sum[k] += y;
      p.sum2[k] += y * y;
      p.sum_t[k] += dt;
      ++p.n[k];
    }
  }
  p.pool();
  return p;
}

// The time after the peak k where the profile has fallen to 1/e of it (linear between the
// bins around the crossing), with its standard error from the slope there; none when it does
// not fall that far inside the window.
std::optional<std::pair<double, double>> fall_time(const SpikeProfile& p, std::size_t kp) {
  const double peak = p.mean(kp), level = peak / std::exp(1.0);
  std::size_t prev = kp;
  for (std::size_t k = kp + 1; k < p.n.size(); ++k) {
    if (!p.valid(k)) continue;
    const double m = p.mean(k);
    if (std::abs(m) <= std::abs(level) || m * peak < 0) {
      const double m0 = p.mean(prev), t0 = p.time(prev), t1 = p.time(k);
      const double slope = (m - m0) / (t1 - t0);
      const double t = slope != 0 ? t0 + (level - m0) / slope : t1;
      const double se = slope != 0 ? p.standard_error(k) / std::abs(slope) : t1 - t0;
      return std::pair{t - p.time(kp), std::max(se, 0.5 * p.bin_s)};
    }
    prev = k;
  }
  return std::nullopt;
}

// The mean of the bins from time `from_s` on into `level`, when at least ten are there.
bool settled_level(const SpikeProfile& p, double from_s, double& level) {
  double sum = 0.0;
  std::size_t bins = 0;
  for (std::size_t k = 0; k < p.n.size(); ++k) {
    if (!p.valid(k) || p.time(k) < from_s) continue;
    sum += p.sum[k] / static_cast<double>(p.n[k]);
    ++bins;
  }
  if (bins < 10) return false;
  level = sum / static_cast<double>(bins);
  return true;
}

}  // namespace

// A friction spike on a servo does not jump at the reversal: the table sticks while the
// command moves on, the deviation grows until the drive breaks free, then falls with the
// loop's dynamics. The decaying step of the fit puts its height at the reversal, where the
// true spike is still small, and its decay over rise and fall together. So the spike is
// measured again on the reversals' mean profile (the residual plus the fitted spike): when
// its peak lies clearly after the reversal, the peak is the height and the time from the
// peak to 1/e of it the decay; a profile that peaks at the reversal is the decaying step, and
// the fit's values stand.
void measure_spikes(const DiagnosisState& ds, const std::vector<double>& resid,
                    const std::array<std::vector<ReversalEvent>, 2>& events, Diagnosis& D) {
  if (!ds.speed_known) return;
  for (int ax = 0; ax < 2; ++ax) {
    const auto axs = static_cast<std::size_t>(ax);
    if (!D.spike_mm[axs].value) continue;  // no spike term for this axis (no reversal ...)
    SpikeProfile p = spike_profile(ds, ax, resid, events[axs]);
    if (p.n.empty()) continue;
    auto peak_bin = [&] {
      std::optional<std::size_t> kp;
      for (std::size_t k = 0; k < p.n.size(); ++k) {
        if (p.valid(k) && (!kp || std::abs(p.mean(k)) > std::abs(p.mean(*kp)))) kp = k;
      }
      return kp;
    };
    auto kp = peak_bin();
    if (!kp) continue;
    auto fall = fall_time(p, *kp);
    if (!fall) continue;
    // The other terms of the fit (backlash above all) take up part of a spike whose shape the
    // fit's term does not have, and shift the level after the reversal: the spike is measured
    // from where the deviation settles, five fall times past the peak.
    if (settled_level(p, p.time(*kp) + 5.0 * fall->first, p.base)) {
      kp = peak_bin();
      fall = kp ? fall_time(p, *kp) : std::nullopt;
      if (!fall) continue;
    }
    const double height = p.mean(*kp), se = p.standard_error(*kp);
    // A peak in the first bins, or before a quarter of the fall, is the decaying step.
    const double t_peak = p.time(*kp);
    if (*kp < 3 || t_peak < 0.25 * fall->first) continue;
    const std::string& axis = ax == 0 ? ds.A : ds.B;
    // A peak that does not stand out of the reversals' scatter leaves the fit's result.
    if (!(std::abs(height) > ds.options.spike_detection_t * se &&
          std::abs(height) >= ds.options.min_spike_mm)) {
      continue;
    }
    // Each direction of reversal on its own, at the same time after the reversal (circfric
    // has one amplitude per joint; a large difference says the friction is not symmetric).
    std::string per_direction;
    for (const int dir : {1, -1}) {
      SpikeProfile q = spike_profile(ds, ax, resid, events[axs], dir);
      if (q.n.empty() || !q.valid(*kp)) continue;
      settled_level(q, t_peak + 5.0 * fall->first, q.base);
      per_direction +=
          fmt::format("{}{:.2f} um at the reversals to {}{}", per_direction.empty() ? "; " : ", ",
                      q.mean(*kp) * 1e3, dir > 0 ? "+" : "-", axis);
    }
    D.notes.push_back(fmt::format(
        "reversal spike {} rises after the reversal (the table sticks): its mean profile over "
        "the reversals peaks at {:.2f} um {:.0f} ms after them and falls to 1/e in {:.0f} ms{}; "
        "height and decay are taken from it (the decaying step fitted {:.2f} um, {:.0f} ms)",
        axis, height * 1e3, t_peak * 1e3, fall->first * 1e3, per_direction,
        D.spike_mm[axs].value.value_or(0.0) * 1e3, D.spike_ms[axs].value.value_or(0.0)));
    D.spike_mm[axs] = {height, se};
    D.spike_ms[axs] = {fall->first * 1e3, fall->second * 1e3};
    D.spike_peak_ms[axs] = {t_peak * 1e3, std::nullopt};
  }
}

}  // namespace circtest::diagnosis_detail
