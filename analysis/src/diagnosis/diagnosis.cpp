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
  return std::move(diagnosis_detail::run_stages({trace, ev, options}).D);
}

namespace diagnosis_detail {

PlaneFit run_stages(const Inputs& in) {
  Diagnosis D;
  const TraceDescription td = describe_trace(in, D);
  SampleSet ss = set_up_samples(in, td, D);
  auto [terms, model] = choose_terms(in, td, ss, D);
  fit(ss.S, model);
  CyclicErrors cyclic = find_cyclic(in, td, ss, model, D);
  SpikeHints hints{0.0, 0.0};
  search_spikes(in, ss, model, hints);
  // With the spikes in the model, a pitch found by the periodogram is refined once more, and
  // the spikes are searched again with that pitch.
  if (refine_cyclic(in, ss, model, cyclic)) search_spikes(in, ss, model, hints);
  const SpikeMeasures spikes = fit_spike_profiles(in, td, ss, model, D);
  report_estimates(in, td, ss, terms, model, cyclic, spikes, D);
  const FollowingLag lag = measure_following_lag(in, td, ss, model, D);
  MeanScale mean_scale = split_radius_change(in, td, ss, lag, D);
  scale_from_instrument(in, td, ss, mean_scale, D);
  measure_axis_lags(in, td, ss, lag, D);
  residual_and_contributions(in, ss, model, D);
  check_finite(in, ss, D);
  return {std::move(ss), std::move(model), lag, mean_scale, std::move(D)};
}

}  // namespace diagnosis_detail

}  // namespace circtest
