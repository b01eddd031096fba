#pragma once
// The diagnosis as a pipeline: diagnose() (diagnosis.cpp) runs these stages in order on one
// DiagnosisState, each reading what the stages before it left there and adding its part.
// docs/architecture.md says where a new stage goes.
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

struct DiagnosisState {
  DiagnosisState(const Trace& t, const Evaluation& e, const DiagnosisOptions& o)
      : trace(t), ev(e), options(o) {}

  const Trace& trace;
  const Evaluation& ev;
  const DiagnosisOptions& options;
  Diagnosis D;  // the result, filled in stage by stage

  // The plane's axes: lowercase letters (column names) and uppercase (report).
  char la = 'x', lb = 'y';
  std::string A, B;
  // The positions are a radial instrument's (runs.cpp): its commanded columns give the angle
  // of each length reading (synthesised by an import), never a command to measure a lag
  // against.
  bool radial = false;

  // Runs and samples (runs.cpp). The linearisation point: deviations are taken from the
  // circle of centre (ca, cb) and radius R.
  double ca = 0.0, cb = 0.0, R = 0.0;
  Samples S;
  std::vector<double> group_feed;  // mm/min per feed group (0 when the feed is unknown)
  bool speed_known = true;
  bool have_ccw = false, have_cw = false;
  bool reversal_a = false, reversal_b = false;  // an axis reverses inside a measured arc
  double min_sweep = 360.0;                     // deg, the shortest run

  // The model (terms.cpp): the candidate columns, those the trace identifies, the others
  // with how much of them is left unexplained.
  std::vector<Column> cand, cols;
  std::vector<std::pair<Column, double>> rejected;
  std::size_t stride = 1;  // the normal equations are summed over every stride-th sample
  double vif_floor = 0.0;
  bool squareness_servo_confounded = false;
  // A rejected reported term and a kept one its effect goes into; the reported terms that
  // therefore cannot be told apart (their values are not reported).
  std::vector<std::pair<Kind, Kind>> confounded;
  std::vector<Kind> unseparable;

  // The fit (fit.cpp): the nonlinear state, the normal equations built so far, the solution.
  State st;
  NormalMemo memo;
  Solution sol;

  // The spike decays found last, the next search's starting points (spikes.cpp).
  std::array<double, 2> spike_hints{0.0, 0.0};
  // The spikes' measured profiles (spike_profile.cpp), per axis whose spike is one.
  std::array<std::optional<SpikeMeasure>, 2> spike_measure;

  // The mean following lag from the commanded columns and the sample period (servo.cpp).
  std::optional<double> lag_s;
  double period = 0.0;

  // The mean scale of the two axes from the radius change, and its standard error
  // (radius_loss.cpp); the servo's cos 2theta part of the scale mismatch column per second of
  // lag mismatch, w^2 lag (servo.cpp; s_A - s_B = column + this * (lag_A - lag_B)).
  std::optional<double> mean_scale, mean_scale_se;
  double scale_servo_per_s = 0.0;
};

// diagnosis.cpp: every stage below in order; ds.D holds the diagnosis and ds the fitted model
// (a test set's joint fit, test_set_fit.cpp, reads the planes' models from it).
void run_stages(DiagnosisState& ds);

// runs.cpp: the trace's plane, axes, instrument; refuses a trace without runs.
void describe_trace(DiagnosisState& ds);
// runs.cpp: the linearisation point, the runs' bookkeeping and feed groups, the samples, the
// axes' reversals, and the notes on what the runs cannot show.
void set_up_samples(DiagnosisState& ds);
// terms.cpp: the candidate columns, the refusal of too few samples, the identifiable ones.
void choose_terms(DiagnosisState& ds);
// fit.cpp: a few Gauss-Newton steps on the play and the lag mismatch at the current columns.
void fit(DiagnosisState& ds);
// cyclic.cpp: a cyclic error per axis at a given pitch or a periodogram's peak.
void find_cyclic(DiagnosisState& ds);
// cyclic.cpp: the amplitude, phase and standard error of axis ax's cyclic error from its
// columns in the current fit.
void take_cyclic_fit(const DiagnosisState& ds, int ax, CyclicEstimate& ce);
// cyclic.cpp: the periodogram's pitches refined with the spikes in the model; true when one was.
bool refine_cyclic(DiagnosisState& ds);
// spikes.cpp: the reversal spikes' decays searched and their heights fitted.
void search_spikes(DiagnosisState& ds);
// spike_profile.cpp: each spike's mean profile over its reversals measured on the residual
// and put into the fit in place of the decaying step (its amplitude fitted), until the profile
// holds still.
void fit_spike_profiles(DiagnosisState& ds);
// estimates.cpp: the fitted parameters and their standard errors into the diagnosis.
void report_estimates(DiagnosisState& ds);
// servo.cpp: the mean following lag from the commanded columns, and its part of the scale
// mismatch.
void measure_following_lag(DiagnosisState& ds);
// radius_loss.cpp: the radius change split into absolute scale and servo loss (Kv).
void split_radius_change(DiagnosisState& ds);
// servo_axes.cpp: each axis' following lag and position gain (commanded against feedback or
// instrument columns, else a feed sweep's radius change), the lag mismatch, and the mismatch
// ellipse's part of G at each feed.
void measure_axis_lags(DiagnosisState& ds);
// contributions.cpp: the residual over every sample, the modelled G and each term's share.
void residual_and_contributions(DiagnosisState& ds);
// reversals.cpp: the backlash at each end of an axis' travel from the residual's steps.
void reversal_steps(const Samples& S, const std::vector<double>& resid,
                    const std::array<std::vector<ReversalEvent>, 2>& events, Diagnosis& D);
// plausibility.cpp: refuses a diagnosis with a number that is not finite.
void check_finite(const DiagnosisState& ds);

}  // namespace circtest::diagnosis_detail
