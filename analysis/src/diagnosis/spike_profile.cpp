// Reversal spikes as their measured mean profile: the axis' deviation after its reversals,
// averaged over them, enters the fit as the spike's column (its amplitude, the height, fitted),
// in place of the decaying step the decay search (spikes.cpp) starts from.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "stages.hpp"

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
// The profile is measured again and refitted until it moves by less than this part of its
// height, at most kMaxRounds times.
constexpr double kShapeTolerance = 1e-3;
constexpr int kMaxRounds = 8;

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

// The angle of run r that the profile covers after a reversal.
double window_rad(const RunInfo& r, double radius) {
  if (!(r.speed_mm_s > 0)) return 0.0;
  return std::min(kProfileWindowRad, kProfileWindowS * r.speed_mm_s / radius);
}

// The residual of the current fit at the samples inside the profile's window after a reversal
// of either axis (NaN elsewhere, where the profile does not look), and each axis' reversals
// inside the runs: the first sample past each.
struct WindowResidual {
  std::vector<double> resid;
  std::array<std::vector<ReversalEvent>, 2> events;
};

WindowResidual window_residual(const Samples& S, const Model& m) {
  const std::vector<Column>& cols = m.cols;
  const State& st = m.st;
  const Reversals rev(S, st.servo_mismatch_s);
  std::vector<double> xs(cols.size());
  for (std::size_t j = 0; j < cols.size(); ++j) xs[j] = m.sol.x[static_cast<Eigen::Index>(j)];
  WindowResidual out;
  out.resid.assign(S.size(), std::numeric_limits<double>::quiet_NaN());
  const std::size_t nblocks = (S.size() + kBlockSamples - 1) / kBlockSamples;
  std::vector<std::array<std::vector<ReversalEvent>, 2>> events(nblocks);
  for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t block) {
    Reversal prev{};
    if (lo > 0) prev = rev.at(lo - 1);
    for (std::size_t i = lo; i < hi; ++i) {
      const Reversal rv = rev.at(i);
      if (i > 0 && S.run[i - 1] == S.run[i]) {
        if (rv.since_a < prev.since_a) events[block][0].push_back({i, rv.since_a, rv.dir_a});
        if (rv.since_b < prev.since_b) events[block][1].push_back({i, rv.since_b, rv.dir_b});
      }
      prev = rv;
      const double win = window_rad(S.runs[S.run[i]], S.radius);
      if (rv.since_a > win && rv.since_b > win) continue;
      double model = offset(S, st, cols, i, rv);
      for (std::size_t j = 0; j < cols.size(); ++j) model += value(S, st, cols[j], i, rv) * xs[j];
      out.resid[i] = S.dr[i] - model;
    }
  });
  for (const auto& e : events) {
    for (std::size_t ax = 0; ax < 2; ++ax)
      out.events[ax].insert(out.events[ax].end(), e[ax].begin(), e[ax].end());
  }
  return out;
}

// The residual plus the fitted spike of axis ax, divided by the spike's direction factor
// (-dir cos for A, -dir sin for B): the axis' deviation after each reversal, averaged (only
// the reversals to +axis or -axis with only_dir).
SpikeProfile spike_profile(const Samples& S, const Model& m, int ax, const WindowResidual& w,
                           int only_dir = 0) {
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
  const auto j = find(m.cols, ax == 0 ? Kind::spike_a : Kind::spike_b);
  const double h = j ? m.sol.x[static_cast<Eigen::Index>(*j)] : 0.0;
  const Reversals rev(S, m.st.servo_mismatch_s);
  for (const ReversalEvent& ev : w.events[static_cast<std::size_t>(ax)]) {
    if (only_dir != 0 && ev.dir != only_dir) continue;
    const RunInfo& r = S.runs[S.run[ev.sample]];
    if (!(r.speed_mm_s > 0)) continue;
    double last = -1.0;
    for (std::size_t i = ev.sample; i < r.end; ++i) {
      const Reversal rv = rev.at(i);
      const double since = ax == 0 ? rv.since_a : rv.since_b;
      if (since < last || since > window_rad(r, S.radius)) break;  // the next reversal, or too far
      last = since;
      const double dt = since * S.radius / r.speed_mm_s;
      if (since < r.eps_rad) continue;  // left out of the fit too
      const auto k = static_cast<std::size_t>(dt / p.bin_s);
      if (k >= nbins) break;
      const double factor = -static_cast<double>(ev.dir) * (ax == 0 ? S.c[i] : S.s[i]);
      if (std::abs(factor) < 0.5) continue;
      const double y = w.resid[i] / factor + h * spike_unit(m.st, ax, dt);
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

std::optional<std::size_t> peak_bin(const SpikeProfile& p) {
  std::optional<std::size_t> kp;
  for (std::size_t k = 0; k < p.n.size(); ++k) {
    if (p.valid(k) && (!kp || std::abs(p.mean(k)) > std::abs(p.mean(*kp)))) kp = k;
  }
  return kp;
}

// The mean of the first three bins with samples before bin `before` (the deviation just past
// the reversal), and its standard error.
std::pair<double, double> first_bins(const SpikeProfile& p, std::size_t before) {
  double sum = 0.0;
  std::size_t n = 0;
  int bins = 0;
  for (std::size_t k = 0; k < before && bins < 3; ++k) {
    if (!p.valid(k)) continue;
    sum += p.sum[k];
    n += p.n[k];
    ++bins;
  }
  if (n == 0) return {0.0, std::numeric_limits<double>::infinity()};
  const double nn = static_cast<double>(n);
  return {sum / nn - p.base, p.sd / std::sqrt(nn)};
}

// The profile's bins up to end_s on the shape's grid (one point per bin, at its middle),
// linear between the bins with samples, the first one's value before it. Not yet divided by
// the height.
std::vector<double> on_grid(const SpikeProfile& p, double end_s) {
  std::vector<std::pair<double, double>> pts;  // (time, mean) of the bins with samples
  for (std::size_t k = 0; k < p.n.size(); ++k) {
    if (p.valid(k) && p.time(k) <= end_s) pts.emplace_back(p.time(k), p.mean(k));
  }
  std::vector<double> v;
  if (pts.empty()) return v;
  const auto size = static_cast<std::size_t>(std::ceil(end_s / p.bin_s));
  std::size_t q = 0;
  for (std::size_t k = 0; k < size; ++k) {
    const double t = (static_cast<double>(k) + 0.5) * p.bin_s;
    while (q + 1 < pts.size() && pts[q + 1].first <= t) ++q;
    if (t <= pts[q].first || q + 1 == pts.size()) {
      v.push_back(pts[q].second);
    } else {
      const auto& [t0, m0] = pts[q];
      const auto& [t1, m1] = pts[q + 1];
      v.push_back(m0 + (t - t0) / (t1 - t0) * (m1 - m0));
    }
  }
  return v;
}

// One axis' measured profile: the shape for the fit (divided by the spike's height) and what
// the report says of it.
struct Measured {
  std::shared_ptr<const SpikeShape> shape;
  SpikeMeasure measure;
  double peak_mm = 0.0, peak_se_mm = 0.0;  // the profile's own peak
  double settle_s = 0.0;                   // the level is taken from this time on
};

// None when the profile does not fall to 1/e of its peak inside the window (nothing to take
// its shape from), or the height comes out zero.
std::optional<Measured> measure_axis(const DiagnosisOptions& options, const Samples& S,
                                     const Model& m, int ax, const WindowResidual& w) {
  SpikeProfile p = spike_profile(S, m, ax, w);
  if (p.n.empty()) return std::nullopt;
  auto kp = peak_bin(p);
  if (!kp) return std::nullopt;
  auto fall = fall_time(p, *kp);
  if (!fall) return std::nullopt;
  // The other terms of the fit (backlash above all) shift the level after the reversal: the
  // spike is measured from where the deviation settles, five fall times past the peak and in
  // the last quarter of the window (a spike that swings back settles later than its fall).
  double last_s = 0.0;  // the last bin with samples
  for (std::size_t k = 0; k < p.n.size(); ++k) {
    if (p.valid(k)) last_s = std::max(last_s, p.time(k));
  }
  const double settle_s = std::max(p.time(*kp) + 5.0 * fall->first, 0.75 * last_s);
  if (settled_level(p, settle_s, p.base)) {
    kp = peak_bin(p);
    fall = kp ? fall_time(p, *kp) : std::nullopt;
    if (!fall) return std::nullopt;
  }
  Measured out;
  const double t_peak = p.time(*kp);
  out.peak_mm = p.mean(*kp);
  out.peak_se_mm = p.standard_error(*kp);
  out.measure.peak_s = t_peak;
  out.measure.fall_s = fall->first;
  out.measure.fall_se_s = fall->second;
  // A peak in the first bins, or before a quarter of the fall, is the decaying step; a peak
  // after that rises after the reversal when it stands out of the reversals' scatter, and
  // above the first bins past the reversal (on a noisy decaying step a later bin can top them
  // by chance).
  const double t = options.spike_detection_t;
  bool rises = *kp >= 3 && t_peak >= 0.25 * fall->first &&
               std::abs(out.peak_mm) > t * out.peak_se_mm &&
               std::abs(out.peak_mm) >= options.min_spike_mm;
  if (rises) {
    const auto [early_mm, early_se_mm] = first_bins(p, *kp);
    rises = (out.peak_mm - early_mm) * (out.peak_mm > 0 ? 1.0 : -1.0) >
            t * std::hypot(out.peak_se_mm, early_se_mm);
  }
  out.measure.rises = rises;
  out.settle_s = settle_s;
  // The shape: five fall times past the peak, or further up to the last bin that stands apart
  // from the level by 1 % of the peak and by the spike's detection threshold in standard
  // errors (a spike that swings back).
  double end_s = std::min(t_peak + 5.0 * fall->first, last_s + p.bin_s);
  for (std::size_t k = 0; k < p.n.size(); ++k) {
    if (p.valid(k) &&
        std::abs(p.mean(k)) > std::max(0.01 * std::abs(out.peak_mm), t * p.standard_error(k)))
      end_s = std::max(end_s, p.time(k) + p.bin_s);
  }
  std::vector<double> v = on_grid(p, end_s);
  if (v.empty()) return std::nullopt;
  // Its height: the peak where the spike rises after the reversal; else the height at the
  // reversal of the decaying step exp(-t / tau) closest to the profile (least squares over the
  // grid), so that the height means what the decaying step's does.
  double height = out.peak_mm;
  if (!out.measure.rises) {
    // The decay search's decay; where it found no spike, the profile's fall.
    double tau = ax == 0 ? m.st.tau_a : m.st.tau_b;
    if (!(tau > 0)) tau = fall->first;
    double se = 0.0, ee = 0.0;
    for (std::size_t k = 0; k < v.size(); ++k) {
      const double e = std::exp(-(static_cast<double>(k) + 0.5) * p.bin_s / tau);
      se += v[k] * e;
      ee += e * e;
    }
    height = ee > 0 ? se / ee : 0.0;
  }
  if (!(std::abs(height) > 0) || !std::isfinite(height)) return std::nullopt;
  auto shape = std::make_shared<SpikeShape>();
  shape->bin_s = p.bin_s;
  shape->v = std::move(v);
  for (double& x : shape->v) x /= height;
  out.shape = std::move(shape);
  return out;
}

// The largest difference of two shapes on their grids (zero past a grid's end).
double shape_change(const SpikeShape* a, const SpikeShape& b) {
  if (!a || a->bin_s != b.bin_s) return std::numeric_limits<double>::infinity();
  double change = 0.0;
  for (std::size_t k = 0; k < std::max(a->v.size(), b.v.size()); ++k) {
    const double x = k < a->v.size() ? a->v[k] : 0.0, y = k < b.v.size() ? b.v[k] : 0.0;
    change = std::max(change, std::abs(x - y));
  }
  return change;
}

// The note on a spike that rises after the reversal: its profile, each direction of reversal
// on its own at the peak's time (circfric has one amplitude per joint; a large difference says
// the friction is not symmetric), and what the decaying step made of it.
std::string rising_note(const std::string& axis, const Samples& S, const Model& model, int ax,
                        const WindowResidual& w, const Measured& m,
                        const std::optional<std::pair<double, double>>& step) {
  const SpikeMeasure& sm = m.measure;
  std::string per_direction;
  for (const int dir : {1, -1}) {
    SpikeProfile q = spike_profile(S, model, ax, w, dir);
    if (q.n.empty()) continue;
    const auto k = static_cast<std::size_t>(sm.peak_s / q.bin_s);
    if (k >= q.n.size() || !q.valid(k)) continue;
    settled_level(q, m.settle_s, q.base);
    per_direction +=
        fmt::format("{}{:.2f} um at the reversals to {}{}", per_direction.empty() ? "; " : ", ",
                    q.mean(k) * 1e3, dir > 0 ? "+" : "-", axis);
  }
  return fmt::format(
      "reversal spike {} rises after the reversal (the table sticks): its mean profile over "
      "the reversals peaks at {:.2f} um {:.0f} ms after them and falls to 1/e in {:.0f} ms{}; "
      "the fit takes the spike as this profile ({})",
      axis, m.peak_mm * 1e3, sm.peak_s * 1e3, sm.fall_s * 1e3, per_direction,
      step ? fmt::format("a decaying step fitted {:.2f} um, {:.0f} ms", step->first * 1e3,
                         step->second * 1e3)
           : std::string("a decaying step did not stand out of the noise"));
}

}  // namespace

// A friction spike on a servo does not jump at the reversal: the table sticks while the
// command moves on, the deviation grows until the drive breaks free, then falls with the
// loop's dynamics; a friction compensation's pulse leaves a spike of yet another shape. A
// decaying step put such a spike's height at the reversal, where it is still small, and left
// most of it in the residual. So each spike enters the fit as its measured mean profile (the
// residual plus the fitted spike, averaged over the reversals, from the level it settles at),
// its amplitude fitted; the profile is measured again on the new residual until it holds still
// (the other terms, backlash above all, move with it). An axis whose decaying step did not
// stand out gets a spike when its profile's peak does.
SpikeMeasures fit_spike_profiles(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                                 Model& m, Diagnosis& D) {
  SpikeMeasures measures;
  if (!ss.speed_known) return measures;
  const Samples& S = ss.S;
  const DiagnosisOptions& options = in.options;
  const std::array<Kind, 2> kinds{Kind::spike_a, Kind::spike_b};
  std::array<bool, 2> on{};
  // The decaying step's height and decay, for the note; none where it did not stand out.
  std::array<std::optional<std::pair<double, double>>, 2> step;
  for (int ax = 0; ax < 2; ++ax) {
    const auto axs = static_cast<std::size_t>(ax);
    const auto j = find(m.cols, kinds[axs]);
    on[axs] = (ax == 0 ? ss.reversal_a : ss.reversal_b) &&
              find(m.cols, ax == 0 ? Kind::backlash_a : Kind::backlash_b).has_value();
    if (j) {
      step[axs] = {m.sol.x[static_cast<Eigen::Index>(*j)], ax == 0 ? m.st.tau_a : m.st.tau_b};
    }
  }
  const double t = options.spike_detection_t;
  for (int round = 0;; ++round) {
    const WindowResidual w = window_residual(S, m);
    std::array<std::optional<Measured>, 2> got;
    double change = 0.0;
    for (int ax = 0; ax < 2; ++ax) {
      const auto axs = static_cast<std::size_t>(ax);
      if (!on[axs]) continue;
      got[axs] = measure_axis(options, S, m, ax, w);
      if (!got[axs]) continue;
      // A spike not in the fit yet: when its profile's peak stands out of the reversals'
      // scatter.
      if (!find(m.cols, kinds[axs]) && !(std::abs(got[axs]->peak_mm) > t * got[axs]->peak_se_mm &&
                                         std::abs(got[axs]->peak_mm) >= options.min_spike_mm)) {
        got[axs].reset();
        continue;
      }
      change = std::max(change, shape_change(m.st.spike_shape[axs].get(), *got[axs]->shape));
    }
    if (round == kMaxRounds || change < kShapeTolerance) {
      // The profiles the fit holds: what they show goes into the report.
      for (int ax = 0; ax < 2; ++ax) {
        const auto axs = static_cast<std::size_t>(ax);
        if (!got[axs] || !m.st.spike_shape[axs]) continue;
        measures[axs] = got[axs]->measure;
        if (got[axs]->measure.rises)
          D.notes.push_back(rising_note(ax == 0 ? td.A : td.B, S, m, ax, w, *got[axs], step[axs]));
      }
      return measures;
    }
    for (std::size_t axs = 0; axs < 2; ++axs) {
      if (!got[axs]) continue;
      m.st.spike_shape[axs] = got[axs]->shape;
      if (!find(m.cols, kinds[axs])) m.cols.push_back({kinds[axs]});
    }
    fit(S, m);
  }
}

}  // namespace circtest::diagnosis_detail
