#pragma once
// The diagnosis as a pipeline: diagnose() (diagnosis.cpp) runs these stages in order, each
// taking what the stages before it handed on (so a stage cannot run before them) and adding
// its part. docs/architecture.md says where a new stage goes.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "circtest/analysis/diagnosis.hpp"
#include "normal_equations.hpp"

namespace circtest::diagnosis_detail {

// A reversal of one axis inside a run: the first sample past it (not the first of its run),
// the angle since the reversal there and the axis direction after it.
struct ReversalEvent {
  std::size_t sample;
  double since;
  std::int8_t dir;
};

// What an axis' measured spike profile shows beyond its height (spike_profile.cpp).
struct SpikeMeasure {
  bool rises = false;                    // it peaks after the reversal (the table sticks)
  double peak_s = 0.0;                   // the peak's time after the reversal
  double fall_s = 0.0, fall_se_s = 0.0;  // from the peak to 1/e of it
};

// What every stage may read of the call: the trace, its evaluation and the options.
struct Inputs {
  const Trace& trace;
  const Evaluation& ev;
  const DiagnosisOptions& options;
};

// describe_trace (runs.cpp): the plane's axes and the instrument. Only a trace with runs gets
// one.
struct TraceDescription {
  // The plane's axes: lowercase letters (column names) and uppercase (report).
  char la = 'x', lb = 'y';
  std::string A, B;
  // The plane's measured columns (the evaluation's).
  const std::vector<double>& col_a;
  const std::vector<double>& col_b;
  // The positions are a radial instrument's: its commanded columns give the angle of each
  // length reading (synthesised by an import), never a command to measure a lag against.
  bool radial = false;
  // The positions are the axes' motor feedback (x_fb...): the loop drives them to the command,
  // so they show the servo's response and no scale of the machine.
  bool feedback = false;
};

// set_up_samples (runs.cpp): the runs turned into samples. The linearisation point:
// deviations are taken from the circle of centre (ca, cb) and radius R.
struct SampleSet {
  double ca = 0.0, cb = 0.0, R = 0.0;
  Samples S;
  std::vector<double> group_feed;  // mm/min per feed group (0 when the feed is unknown)
  bool speed_known = true;
  bool have_ccw = false, have_cw = false;
  bool reversal_a = false, reversal_b = false;  // an axis reverses inside a measured arc
  double min_sweep = 360.0;                     // deg, the shortest run
};

// choose_terms (terms.cpp): what the trace cannot tell apart.
struct TermSet {
  bool squareness_servo_confounded = false;
  // The reported terms that cannot be told apart (their values are not reported).
  std::vector<Kind> unseparable;
};

// The model being fitted: choose_terms (terms.cpp) starts it with the identifiable columns;
// fit (fit.cpp), the cyclic (cyclic.cpp) and spike stages (spikes.cpp, spike_profile.cpp)
// refine it.
struct Model {
  std::vector<Column> cols;
  std::size_t stride = 1;  // the normal equations are summed over every stride-th sample
  State st;                // the nonlinear state
  NormalMemo memo;         // the normal equations built so far
  Solution sol;
};

struct ChosenTerms {
  TermSet terms;
  Model model;
};

// find_cyclic, refine_cyclic (cyclic.cpp): each axis' cyclic error, when it has one.
using CyclicErrors = std::array<std::optional<CyclicEstimate>, 2>;
// search_spikes (spikes.cpp): the spike decays found last, the next search's starting points.
using SpikeHints = std::array<double, 2>;
// fit_spike_profiles (spike_profile.cpp): the spikes' measured profiles, per axis whose spike
// is one.
using SpikeMeasures = std::array<std::optional<SpikeMeasure>, 2>;

// measure_following_lag (servo.cpp): the mean following lag from the commanded columns and the
// sample period; the servo's cos 2theta part of the scale mismatch column per second of lag
// mismatch, w^2 lag (s_A - s_B = column + this * (lag_A - lag_B)).
struct FollowingLag {
  std::optional<double> lag_s;
  double period = 0.0;
  double scale_servo_per_s = 0.0;
};

// split_radius_change (radius_loss.cpp): the mean scale of the two axes from the radius change,
// and its standard error.
struct MeanScale {
  std::optional<double> value;
  double se = 0.0;
  // scale_from_instrument: the standard deviation a loop beyond first order may add to each
  // axis' scale from the circle (relative; 0 when none), which no joint fit averages down.
  double loop_se = 0.0;
};

// run_stages: a plane's diagnosis and the parts of its fit a test set's joint fit
// (test_set_fit.cpp) reads.
struct PlaneFit {
  SampleSet samples;
  Model model;
  FollowingLag lag;
  MeanScale mean_scale;
  Diagnosis D;
};

// diagnosis.cpp: every stage below in order.
PlaneFit run_stages(const Inputs& in);

// Each stage takes what it reads (const) and returns what it hands on; those that add to the
// diagnosis take it as D and say which part they fill.

// runs.cpp: the trace's plane, axes, instrument; refuses a trace without runs. D: source,
// plane, axes, ini_sha256, absolute_channels.
TraceDescription describe_trace(const Inputs& in, Diagnosis& D);
// runs.cpp: the linearisation point, the runs' bookkeeping and feed groups, the samples, the
// axes' reversals. D: radius_mm, runs, samples, feeds_mm_per_min; the notes on what the runs
// cannot show.
SampleSet set_up_samples(const Inputs& in, const TraceDescription& td, Diagnosis& D);
// terms.cpp: the candidate columns, the refusal of too few samples, the identifiable ones.
// D: unseparable; the notes on the terms not reported.
ChosenTerms choose_terms(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                         Diagnosis& D);
// fit.cpp: a few Gauss-Newton steps on the play and the lag mismatch at the current columns.
void fit(const Samples& S, Model& m);
// cyclic.cpp: a cyclic error per axis at a given pitch or a periodogram's peak. D: notes.
CyclicErrors find_cyclic(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                         Model& m, Diagnosis& D);
// cyclic.cpp: the amplitude, phase and standard error of axis ax's cyclic error from its
// columns in the current fit.
void take_cyclic_fit(const Model& m, int ax, CyclicEstimate& ce);
// cyclic.cpp: the periodogram's pitches refined with the spikes in the model; true when one was.
bool refine_cyclic(const Inputs& in, const SampleSet& ss, Model& m, CyclicErrors& cyclic);
// spikes.cpp: the reversal spikes' decays searched and their heights fitted.
void search_spikes(const Inputs& in, const SampleSet& ss, Model& m, SpikeHints& hints);
// spike_profile.cpp: each spike's mean profile over its reversals measured on the residual
// and put into the fit in place of the decaying step (its amplitude fitted), until the profile
// holds still. D: the notes on spikes that rise after the reversal.
SpikeMeasures fit_spike_profiles(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                                 Model& m, Diagnosis& D);
// estimates.cpp: the fitted parameters and their standard errors. D: cyclic, centre_offset_mm,
// backlash_mm, spike_mm, spike_ms, spike_peak_ms, scale_mismatch_ppm, squareness_urad,
// servo_mismatch_ms, radius_change; notes.
void report_estimates(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                      const TermSet& terms, Model& m, const CyclicErrors& cyclic,
                      const SpikeMeasures& spikes, Diagnosis& D);
// servo.cpp: the mean following lag from the commanded columns, and its part of the scale
// mismatch (read from D, after report_estimates). D: lag_ms, scale_mismatch_ppm; unseparable,
// notes.
FollowingLag measure_following_lag(const Inputs& in, const TraceDescription& td,
                                   const SampleSet& ss, const Model& m, Diagnosis& D);
// radius_loss.cpp: the radius change split into absolute scale and servo loss (Kv). D:
// kv_per_s, kv_source, scale_ppm; unseparable, notes.
MeanScale split_radius_change(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                              const FollowingLag& lag, Diagnosis& D);
// instrument_scale.cpp: the circle's scale and scale mismatch bounded by the amplitude response
// a loop beyond first order may add at the test's angular speed (standard errors widened, or
// not reported and MEAN_SCALE reset); with the motor feedback columns (x_fb...) beside the
// instrument's, each axis' scale from instrument minus feedback (the screws, independent of the
// servo, before any comp table in effect) in a note. D: scale_ppm, scale_mismatch_ppm;
// unseparable, notes.
void scale_from_instrument(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                           MeanScale& mean_scale, Diagnosis& D);
// servo_axes.cpp: each axis' following lag and position gain (commanded against feedback or
// instrument columns, else a feed sweep's radius change: D's Kv, after split_radius_change),
// the lag mismatch, and the mismatch ellipse's part of G at each feed. D: axis_lag,
// axis_lag_mismatch_ms, servo_share; notes.
void measure_axis_lags(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                       const FollowingLag& lag, Diagnosis& D);
// contributions.cpp: the residual over every sample, the modelled G and each term's share. D:
// residual_rms_mm, residual_g_mm, model_g_mm, contributions, measured_g_mm,
// backlash_reversals_mm.
void residual_and_contributions(const Inputs& in, const SampleSet& ss, const Model& m,
                                Diagnosis& D);
// reversals.cpp: the backlash at each end of an axis' travel from the residual's steps.
void reversal_steps(const Samples& S, const std::vector<double>& resid,
                    const std::array<std::vector<ReversalEvent>, 2>& events, Diagnosis& D);
// plausibility.cpp: refuses a diagnosis with a number that is not finite.
void check_finite(const Inputs& in, const SampleSet& ss, const Diagnosis& D);

}  // namespace circtest::diagnosis_detail
