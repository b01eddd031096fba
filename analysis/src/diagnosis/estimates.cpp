// The fitted parameters and their standard errors, in the diagnosis's units, with what the
// trace cannot report left out.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

// Parameters and standard errors: the column of kind k's value times `scale`.
Estimate estimate(const TermSet& terms, const Model& m, Kind k, double scale, int group = 0) {
  const std::vector<Column>& cols = m.cols;
  const Solution& sol = m.sol;
  Estimate e;
  if (std::find(terms.unseparable.begin(), terms.unseparable.end(), k) != terms.unseparable.end())
    return e;
  if (auto j = find(cols, k, group)) {
    const auto ji = static_cast<Eigen::Index>(*j);
    e.value = sol.x[ji] * scale;
    e.standard_error = std::sqrt(std::max(0.0, sol.sigma2 * sol.inv(ji, ji))) * std::abs(scale);
  }
  return e;
}

}  // namespace

void report_estimates(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                      const TermSet& terms, Model& m, const CyclicErrors& cyclic,
                      const SpikeMeasures& spikes, Diagnosis& D) {
  const Evaluation& ev = in.ev;
  const Samples& S = ss.S;
  const std::vector<Column>& cols = m.cols;
  const State& st = m.st;
  const Solution& sol = m.sol;
  const std::string &A = td.A, &B = td.B;
  const bool speed_known = ss.speed_known, reversal_a = ss.reversal_a, reversal_b = ss.reversal_b;
  auto est = [&](Kind k, double scale, int group = 0) {
    return estimate(terms, m, k, scale, group);
  };
  D.cyclic = cyclic;
  for (int ax = 0; ax < 2; ++ax) {
    auto& cy = D.cyclic[static_cast<std::size_t>(ax)];
    if (!cy) continue;
    take_cyclic_fit(m, ax, *cy);
  }
  D.centre_offset_mm = {est(Kind::centre_a, 1.0), est(Kind::centre_b, 1.0)};
  D.backlash_mm = {est(Kind::backlash_a, 1.0), est(Kind::backlash_b, 1.0)};
  for (int ax = 0; ax < 2; ++ax) {
    auto& b = D.backlash_mm[static_cast<std::size_t>(ax)];
    if ((ax == 0 ? reversal_a : reversal_b) || !b.value) continue;
    D.notes.push_back(fmt::format(
        "{} does not reverse: the runs of the two directions are {:.2f} um apart along {} (lost "
        "motion or drift; not reported as backlash)",
        ax == 0 ? A : B, *b.value * 1e3, ax == 0 ? A : B));
    b = {};
  }
  D.spike_mm = {est(Kind::spike_a, 1.0), est(Kind::spike_b, 1.0)};
  for (int ax = 0; ax < 2; ++ax) {
    const auto axs = static_cast<std::size_t>(ax);
    const bool reversal = ax == 0 ? reversal_a : reversal_b;
    const double tau = ax == 0 ? st.tau_a : st.tau_b;
    const auto& measured = spikes[axs];
    if (D.spike_mm[axs].value && measured && (measured->rises || !(tau > 0))) {
      // A spike that rises after the reversal, or that no decaying step found: its decay is
      // the fall from the measured profile's peak to 1/e of it.
      D.spike_ms[axs] = {measured->fall_s * 1e3, measured->fall_se_s * 1e3};
      if (measured->rises) D.spike_peak_ms[axs] = {measured->peak_s * 1e3, std::nullopt};
    } else if (D.spike_mm[axs].value) {
      // The decaying step's decay, with the standard error of the decaying step's model: the
      // Jacobian with its derivative column added.
      D.spike_ms[axs].value = tau * 1e3;
      State s2 = st;
      s2.spike_shape = {};
      s2.spike_h_a = D.spike_mm[0].value.value_or(0.0);
      s2.spike_h_b = D.spike_mm[1].value.value_or(0.0);
      std::vector<Column> aug = cols;
      aug.push_back({ax == 0 ? Kind::spike_tau_a : Kind::spike_tau_b});
      const Normal N = accumulate(S, s2, aug, m.stride, m.memo);
      const auto last = static_cast<Eigen::Index>(aug.size() - 1);
      const Solution a = solve(N);
      D.spike_ms[axs].standard_error =
          std::sqrt(std::max(0.0, sol.sigma2 * a.inv(last, last))) * 1e3;
    } else if (reversal && speed_known &&
               find(cols, ax == 0 ? Kind::backlash_a : Kind::backlash_b)) {
      // No spike that stands out of the noise: height zero, decay undefined.
      D.spike_mm[axs].value = 0.0;
    }
  }
  D.scale_mismatch_ppm = est(Kind::scale_mismatch, 1e6);
  if (!terms.squareness_servo_confounded) {
    D.squareness_urad = est(Kind::squareness, 1e6);
    D.servo_mismatch_ms = est(Kind::servo, 1e3);
    if (!speed_known && D.servo_mismatch_ms.value) {
      // The coefficient is the phase difference w dtau (runs.cpp): a lag needs the feed.
      D.notes.push_back(fmt::format(
          "servo mismatch ellipse fitted as a phase of {:+.4f} mrad (+- {:.4f}) between {} and "
          "{}: its lag in ms needs the feed (state feed_mm_per_min or --feed)",
          *D.servo_mismatch_ms.value, D.servo_mismatch_ms.standard_error.value_or(0.0), A, B));
      D.servo_mismatch_ms = {};
    }
  }
  for (std::size_t g = 0; g < ss.group_feed.size(); ++g) {
    FeedRadius fr;
    fr.feed_mm_per_min = ss.group_feed[g];
    fr.dr_mm = est(Kind::radius, 1.0, static_cast<int>(g));
    D.radius_change.push_back(fr);
  }
  if (!ev.nominal_radius_mm) {
    for (auto& fr : D.radius_change) fr.dr_mm = {};
  }
}

}  // namespace circtest::diagnosis_detail
