#pragma once
// The results of ISO 230-4 clause 3 for a trace: H, G and F per direction.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/analysis/circle_fit.hpp"
#include "circtest/analysis/input_checks.hpp"
#include "circtest/analysis/segmentation.hpp"
#include "circtest/analysis/uncertainty.hpp"
#include "circtest/core/plane.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

enum class GMethod { min_zone, least_squares };
enum class FCentre { automatic, nominal, lsc };

// Where a set-up value came from. JSON and the report spell it "option", "metadata",
// "commanded", or "" for none.
enum class ValueSource { none, option, metadata, commanded };
std::string_view value_source_name(ValueSource source) noexcept;
std::optional<ValueSource> parse_value_source(std::string_view name);

// The centre a run's F was taken about ("nominal" or "lsc").
enum class FCentreMethod { nominal, lsc };
std::string_view f_centre_method_name(FCentreMethod method) noexcept;
std::optional<FCentreMethod> parse_f_centre_method(std::string_view name);

// Clause 4.1: F is reported at 20 deg C. The instrument's reading is scaled by its own
// expansion and the machine's: r_20 = r * (1 + a_i (T_i - 20) - a_m (T_m - 20)).
struct Temperatures {
  std::optional<double> machine_C;
  std::optional<double> instrument_C;
  double machine_expansion_per_K = 11.5e-6;  // steel scales / ball screws
  double instrument_expansion_per_K = 0.0;   // e.g. a glass-ceramic grid encoder
  bool available() const { return machine_C.has_value() || instrument_C.has_value(); }
  double radius_factor() const;  // 1 + a_i (T_i - 20) - a_m (T_m - 20)
};

struct EvaluationOptions {
  std::optional<Plane> plane;  // default: the trace's `plane` metadata, else XY
  std::string column_a;        // explicit position columns (default: the plane's axis letters)
  std::string column_b;
  std::optional<double> nominal_radius_mm;
  std::optional<PlanePoint> centre;  // nominal / set-up centre
  GMethod g_method = GMethod::min_zone;
  FCentre f_centre = FCentre::automatic;
  Temperatures temperatures;
  double min_arc_deg = 90.0;
  // Test conditions stated on the command line (--machine, --operator, ...: metadata key
  // and value); they override the trace's metadata in the report.
  std::vector<std::pair<std::string, std::string>> conditions;
  // Refusals of inconsistent inputs and their overrides (docs/input-checks.md).
  InputCheckOptions input_checks;
  // The stated inputs of the uncertainty budget (uncertainty.hpp).
  UncertaintyOptions uncertainty;
  // Threads for the runs of a large trace (each run, each H pair's profiles): 0 one per
  // core, 1 the calling thread only. The results are the same either way.
  unsigned threads = 0;
};

struct RunResult {
  Run run;
  std::string label;  // clause 3.7, e.g. "XY" for CCW in the XY plane
  std::size_t first_line = 0;
  std::size_t last_line = 0;
  Circle lsc;             // least-squares circle of this run
  MinimumZone mzc;        // minimum-zone circles of this run
  double g_mzc_mm = 0.0;  // G by minimum zone
  double g_lsc_mm = 0.0;  // G about the LSC centre (max - min radius)
  // F against the nominal radius (corrected to 20 deg C when temperatures are known).
  std::optional<double> f_max_mm;
  std::optional<double> f_min_mm;
  FCentreMethod f_centre_method = FCentreMethod::nominal;
  PlanePoint f_centre;
  std::optional<double> feed_mm_per_min;  // from the time column, when present
  double g_mm(GMethod m) const { return m == GMethod::min_zone ? g_mzc_mm : g_lsc_mm; }
};

// H for one CCW/CW pair: both runs about the LSC centre of the two together.
struct HysteresisResult {
  std::size_t run_ccw = 0;  // indices into Evaluation::runs
  std::size_t run_cw = 0;
  double h_mm = 0.0;
  double at_angle_deg = 0.0;  // where the largest difference occurs
  Circle common_lsc;
  double overlap_deg = 0.0;  // angular range both runs cover
};

struct Evaluation {
  std::string source;
  Plane plane = Plane::XY;
  PlaneColumns columns;   // the position columns evaluated, indices into the trace
  std::string channel_a;  // their names, e.g. "x", "y" (instrument) or "x_fb", "y_fb"
  std::string channel_b;
  SegmentationMethod segmentation = SegmentationMethod::automatic;
  GMethod g_method = GMethod::min_zone;
  std::optional<double> nominal_radius_mm;
  ValueSource nominal_radius_source = ValueSource::none;
  std::optional<PlanePoint> centre;  // nominal / set-up centre
  ValueSource centre_source = ValueSource::none;
  Temperatures temperatures;
  double temperature_factor = 1.0;
  std::vector<RunResult> runs;
  std::vector<HysteresisResult> hysteresis;  // one per adjacent CCW/CW pair
  std::vector<std::string> notes;            // warnings worth showing the user
  TraceMetadata conditions;                  // the trace's metadata: clause 4.4 conditions
  UncertaintyOptions uncertainty_options;    // as given; uncertainty_budget(*this, them)
  BudgetMeasurements budget_inputs;          // the drift and noise the budget takes
};

// Runs the whole evaluation. Options left empty are taken from the trace's metadata
// (plane, radius_mm / diameter_mm, centre_mm, temperatures) or commanded columns.
Evaluation evaluate(const Trace& trace, const EvaluationOptions& options);

// The trace's `centre_mm` metadata ("x,y,z") as the plane's two coordinates; ParseError
// naming the line when it is not three numbers.
std::optional<PlanePoint> metadata_centre(const Trace& trace, Plane plane);

// Largest |r1(theta) - r2(theta)| over the angles both paths cover, about a centre,
// with each path's radius linearly interpolated in angle at the other's samples.
struct RadialDifference {
  double max_mm = 0.0;
  double at_angle_deg = 0.0;
  double overlap_deg = 0.0;
};
RadialDifference max_radial_difference(std::span<const double> a1, std::span<const double> b1,
                                       std::span<const double> a2, std::span<const double> b2,
                                       double centre_a_mm, double centre_b_mm);

}  // namespace circtest
