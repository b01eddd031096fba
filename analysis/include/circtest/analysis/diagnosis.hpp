#pragma once
// Diagnosis: which machine errors (ISO 230-4 Annex B) make up H, G and F. A least-squares
// fit of a first-order error model to the radial deviation of all runs of a trace together.
// Model and sign conventions: docs/diagnosis.md (the same as configs/sim-mill [SIM] and the
// test simulator tests/support/machine_sim).
#include <array>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

struct DiagnosisOptions {
  EvaluationOptions evaluation;
  // Cyclic-error pitch per axis (lowercase letter -> mm), e.g. the screw lead; axes without
  // one are searched by a periodogram of the residual over axis position.
  std::map<char, double> pitch_mm;
  // A periodogram peak is reported only when its power is this many times the median power.
  double cyclic_detection_factor = 25.0;
  // ... and only when its amplitude is at least this and five standard errors.
  double min_cyclic_amplitude_mm = 0.1e-3;
  // A reversal spike is kept only when its height exceeds this many standard errors.
  double spike_detection_t = 5.0;
  double min_spike_mm = 0.1e-3;  // ... and only when it is at least this high
  // The normal equations are summed over at most this many samples (evenly strided); the
  // residual is evaluated on all of them.
  std::size_t max_fit_samples = 250000;
  // A parameter whose column is this well explained by the others (variance inflation
  // factor) is not identifiable from the trace and is reported as null.
  double max_variance_inflation = 1000.0;
  // False for an instrument without an absolute length along the axes (a ball bar): only the
  // scale mismatch is reported. True also needs the trace's `instrument` metadata not to name
  // a ball bar.
  bool absolute_channels = true;
};

// A fitted value with its standard error; both absent when the trace cannot separate it.
struct Estimate {
  std::optional<double> value;
  std::optional<double> standard_error;
};

struct CyclicEstimate {
  double amplitude_mm = 0.0;
  double pitch_mm = 0.0;
  double phase_rad = 0.0;  // d_axis = amplitude sin(2 pi pos / pitch + phase)
  double amplitude_se_mm = 0.0;
  std::string pitch_source;                    // "option" or "periodogram"
  std::optional<double> peak_to_median_power;  // periodogram: how far it stands out
};

struct FeedRadius {
  double feed_mm_per_min = 0.0;
  Estimate dr_mm;  // mean radius minus the nominal radius at this feed
};

struct Contribution {
  std::string source;     // "backlash X", "squareness", ...
  double g_mm = 0.0;      // range of this model term alone over a run (the largest over runs)
  double share_mm = 0.0;  // its part of the modelled G: term(max point) - term(min point)
  double percent = 0.0;   // share_mm / modelled G * 100
};

// The following lag of one axis: following error over velocity at constant feed.
struct AxisLag {
  Estimate lag_ms;
  std::optional<double> kv_per_s;  // effective position gain, 1000 / lag_ms
  // "feedback" (commanded minus motor feedback), "instrument" (commanded minus the measured
  // position, geometry fitted out) or "feeds" (mean lag from the radius change over a feed
  // sweep, split by the fitted mismatch); empty when not measurable.
  std::string source;
};

// What the lag mismatch makes of the circle at one feed.
struct ServoShare {
  double feed_mm_per_min = 0.0;
  double g_mm = 0.0;                    // G of the mismatch ellipse alone: v |lag_A - lag_B|
  std::optional<double> measured_g_mm;  // the largest G of the runs at this feed
  std::optional<double> percent;        // g_mm / measured_g_mm * 100
};

struct Diagnosis {
  std::string source;
  Plane plane = Plane::XY;
  std::array<char, 2> axes{'X', 'Y'};  // uppercase letters of A and B
  std::vector<double> feeds_mm_per_min;
  std::size_t runs = 0;
  std::size_t samples = 0;
  double radius_mm = 0.0;  // the nominal radius the deviations are taken from
  bool absolute_channels = true;

  std::array<Estimate, 2> backlash_mm;
  // Backlash step at the reversal at the + end and at the - end of each axis, when both are
  // covered (a local estimate from the steps in the residual plus the fitted backlash).
  std::array<std::optional<std::array<double, 2>>, 2> backlash_reversals_mm;
  std::array<Estimate, 2> spike_mm;
  std::array<Estimate, 2> spike_ms;
  // Time from the reversal to the spike's peak when the table sticks (the profile rises after
  // the reversal); no value when the spike is the decaying step that peaks at it.
  std::array<Estimate, 2> spike_peak_ms;
  std::array<Estimate, 2> scale_ppm;
  Estimate scale_mismatch_ppm;  // s_A - s_B
  Estimate squareness_urad;     // a_actual = a + alpha b
  Estimate servo_mismatch_ms;   // lag time of A minus lag time of B
  std::vector<FeedRadius> radius_change;
  Estimate kv_per_s;
  std::string kv_source;  // "feeds", "lag" or empty
  Estimate lag_ms;        // mean following lag of the axes (commanded columns)

  // The servo per axis (diagnosis/servo_axes.cpp): lag and gain, A minus B, per feed.
  std::array<AxisLag, 2> axis_lag;
  Estimate axis_lag_mismatch_ms;
  std::vector<ServoShare> servo_share;

  std::array<std::optional<CyclicEstimate>, 2> cyclic;
  std::array<Estimate, 2> centre_offset_mm;  // from the nominal centre (set-up, nuisance)

  std::vector<Contribution> contributions;  // ranked by g_mm
  double model_g_mm = 0.0;                  // G of the model without centring and radius
  double residual_rms_mm = 0.0;
  double residual_g_mm = 0.0;
  std::optional<std::string> ini_sha256;  // from the trace's metadata, when recorded
  // The terms this trace cannot tell apart, by where their values would be in the document
  // ("backlash_mm.X", "servo_mismatch_ms"): their values are not reported.
  std::vector<std::string> unseparable;
  std::vector<std::string> notes;
};

// Evaluates the trace (segmentation, nominal circle) and fits the model.
Diagnosis diagnose(const Trace& trace, const DiagnosisOptions& options = {});
// The same on an evaluation already made from this trace.
Diagnosis diagnose(const Trace& trace, const Evaluation& evaluation,
                   const DiagnosisOptions& options = {});

nlohmann::ordered_json to_json(const Diagnosis& diagnosis);
std::string text_report(const Diagnosis& diagnosis);
// A few lines for the end of the analyze report.
std::string short_text_report(const Diagnosis& diagnosis);

}  // namespace circtest
