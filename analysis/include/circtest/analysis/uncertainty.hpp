#pragma once
// The uncertainty of H, G and F of a test in the manner of ISO/TR 230-9 (GUM): each
// contribution's standard uncertainty and how it enters each quantity (its sensitivity), the
// combined standard uncertainty as their root sum of squares, expanded with k = 2; and the
// decision rule of ISO 14253-1 for a value against a limit (docs/uncertainty.md).
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace circtest {

struct Evaluation;

// What measured the path: a ball bar (the length channel r), a grid encoder (x, y of a
// cross-grid plate), or the machine's own scales (feedback, no external instrument).
enum class InstrumentProfile { automatic, ballbar, grid_encoder, scales };
std::string_view instrument_profile_name(InstrumentProfile profile) noexcept;
std::optional<InstrumentProfile> parse_instrument_profile(std::string_view name);

// The stated inputs of the budget; each unset value is the profile's default or, for the
// repeatability, measured from repeated runs (docs/uncertainty.md lists the defaults).
struct UncertaintyOptions {
  InstrumentProfile profile = InstrumentProfile::automatic;
  std::optional<double> calibration_mm;           // standard uncertainty of the radius reading
  std::optional<double> resolution_mm;            // the reading's digit step
  std::optional<double> centring_mm;              // standard uncertainty of the set-up centre
  std::optional<double> unseen_mm;                // scales only: half-width of what they cannot see
  double thermometer_K = 0.2;                     // standard uncertainty of a recorded temperature
  double assumed_temperature_half_width_K = 2.0;  // without recorded temperatures: 20 +- this
  double expansion_relative = 0.1;  // relative standard uncertainty of the coefficients
  // Without temperatures recorded over the test: the change of the temperature assumed during
  // it (a workshop without climate control), K per hour.
  double assumed_drift_K_per_h = 1.0;
  // Repeatability: standard deviations of a single run's G and F and of a pair's H; unset:
  // measured from repeated runs of one direction, else the stated default (not measured).
  std::optional<double> repeatability_g_mm;
  std::optional<double> repeatability_f_mm;
  std::optional<double> repeatability_h_mm;
  bool operator==(const UncertaintyOptions&) const = default;
};

// What the budget measures in the trace beyond H, G and F (evaluate() fills it): how the
// recorded temperatures changed during the test, how long it ran, and the readings' noise.
struct BudgetMeasurements {
  // How the temperatures were recorded over the test: "columns" (a temperature per sample),
  // "start and end" (the metadata key given twice, at the start and at the end: taken as
  // changing linearly in time), or "" (once or not at all: the drift is not measured).
  std::string drift_source;
  // The change of the machine's and the instrument's temperature (K, a straight line fitted
  // to the recorded values): the largest within one run, over one CCW/CW pair (the first
  // run's start to the second's end), and the largest departure over the measured runs from
  // the temperature F is corrected at.
  double machine_run_K = 0.0, machine_pair_K = 0.0, machine_from_corrected_K = 0.0;
  double instrument_run_K = 0.0, instrument_pair_K = 0.0, instrument_from_corrected_K = 0.0;
  // Durations from the time column, s: the longest run, the longest pair, the measured runs
  // from the first's start to the last's end; empty without a time column.
  std::optional<double> run_s, pair_s, test_s;
  // The readings' noise: its standard deviation from sample to sample (mm, from second
  // differences of the radius, a median so that a reversal's spike does not count), and how
  // much it widens the largest run's zone (G), moves F_max or F_min and H (mm): the expected
  // largest of the noise over the samples near each extreme.
  double noise_mm = 0.0, noise_g_mm = 0.0, noise_f_mm = 0.0, noise_h_mm = 0.0;
  std::size_t noise_samples_top = 0, noise_samples_bottom = 0;  // near the extremes
  bool operator==(const BudgetMeasurements&) const = default;
};

// The default the budget takes for an unmeasured repeatability (a run's G and F).
inline constexpr double kDefaultRepeatabilityMm = 0.0005;

// normal: a standard uncertainty; rectangular: a half-width a (u = a / sqrt 3); bias: a
// one-sided effect of at most the stated size that is not corrected (the noise's widening of
// the zone, a measured drift): c x value is added to U as is, after k u (GUM F.2.4.5).
enum class Distribution { normal, rectangular, bias };
std::string_view distribution_name(Distribution d) noexcept;

struct UncertaintyContribution {
  std::string name;       // "instrument calibration", "temperature", ...
  double value_mm = 0.0;  // as stated: a standard uncertainty (normal) or a half-width
  Distribution distribution = Distribution::normal;
  std::string source;  // "measured", "profile default", "stated assumption", "option"
  std::string note;    // how it was found and how it enters
  // Sensitivity coefficients: how much of the standard uncertainty enters G, H and F.
  double c_g = 0.0;
  double c_h = 0.0;
  double c_f = 0.0;
  double standard_mm() const;  // value / sqrt(3) for a rectangular half-width; a bias as is
};

struct UncertaintyBudget {
  InstrumentProfile profile = InstrumentProfile::scales;
  std::string profile_note;  // why this profile
  std::vector<UncertaintyContribution> contributions;
  double k = 2.0;
  // Expanded uncertainties (k = 2) of a run's G and F and of a pair's H, mm.
  double u_g_mm = 0.0;
  double u_h_mm = 0.0;
  double u_f_mm = 0.0;
};

// The budget of an evaluation: its profile (automatic: the trace's instrument metadata and
// channels), temperatures, runs and their feeds, and the stated options.
UncertaintyBudget uncertainty_budget(const Evaluation& evaluation,
                                     const UncertaintyOptions& options);
// The expanded uncertainty of the budget with one contribution left out (by name), for
// showing what a contribution is worth; U_G, U_H, U_F in the budget's fields.
UncertaintyBudget without_contribution(const UncertaintyBudget& budget, std::string_view name);

// ISO 14253-1 for a value against an upper limit with expanded uncertainty U.
enum class Decision { pass, fail, not_decided };
Decision decide(double value_mm, double u_mm, double limit_mm) noexcept;
std::string_view decision_words(Decision d) noexcept;  // "pass", "fail", "not decided: ..."
inline constexpr const char* kDecisionRule =
    "ISO 14253-1: pass when value + U <= limit, fail when value - U > limit, otherwise not "
    "decided (U expanded, k = 2)";

// Limits on H, G and F (mm) and each judged by the rule: the largest H of the pairs, G of the
// runs and |F| of the runs, each with its U. A limit whose quantity was not measured decides
// nothing (decision empty) and does not pass.
struct ResultLimits {
  std::optional<double> h_mm, g_mm, f_mm;
  bool empty() const { return !h_mm && !g_mm && !f_mm; }
};
struct LimitDecision {
  const char* quantity;  // "H", "G", "F"
  std::optional<double> value_mm;
  double u_mm = 0.0;
  double limit_mm = 0.0;
  std::optional<Decision> decision;  // none: not measured
};
std::vector<LimitDecision> decide_limits(const Evaluation& evaluation,
                                         const UncertaintyBudget& budget,
                                         const ResultLimits& limits);
// True when every limit passes (nothing failed, undecided or unmeasured).
bool all_pass(const std::vector<LimitDecision>& decisions) noexcept;

}  // namespace circtest
