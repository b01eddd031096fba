// The diagnosis fit as a pipeline of stages (diagnosis/stages.hpp; docs/diagnosis.md states the
// model and its signs, docs/architecture.md where a new stage goes).
#include "circtest/analysis/diagnosis.hpp"

#include "stages.hpp"

namespace circtest {

Diagnosis diagnose(const Trace& trace, const DiagnosisOptions& options) {
  const Evaluation ev = evaluate(trace, options.evaluation);
  return diagnose(trace, ev, options);
}

Diagnosis diagnose(const Trace& trace, const Evaluation& ev, const DiagnosisOptions& options) {
  diagnosis_detail::DiagnosisState ds(trace, ev, options);
  diagnosis_detail::run_stages(ds);
  return std::move(ds.D);
}

namespace diagnosis_detail {

void run_stages(DiagnosisState& ds) {
  describe_trace(ds);
  set_up_samples(ds);
  choose_terms(ds);
  fit(ds);
  find_cyclic(ds);
  search_spikes(ds);
  // With the spikes in the model, a pitch found by the periodogram is refined once more, and
  // the spikes are searched again with that pitch.
  if (refine_cyclic(ds)) search_spikes(ds);
  fit_spike_profiles(ds);
  report_estimates(ds);
  measure_following_lag(ds);
  split_radius_change(ds);
  measure_axis_lags(ds);
  residual_and_contributions(ds);
  check_finite(ds);
}

}  // namespace diagnosis_detail

}  // namespace circtest
