#pragma once
// Checks that the inputs of an evaluation agree with each other before a number is reported
// (never a confident wrong number): the trace's units, the plane, the nominal
// radius against the measured circle, each run against the arc the program said, and single
// samples far off the circle. Each either passes, refuses (DataError naming the file and
// line, exit 5), or with InputCheckOptions::warn_only gives a note for the report instead.
// docs/input-checks.md has the rules, the tolerances and why.
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "circtest/analysis/circle_fit.hpp"
#include "circtest/analysis/remedy.hpp"
#include "circtest/analysis/segmentation.hpp"
#include "circtest/core/plane.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

enum class PositionUnits { mm, inch };

struct InputCheckOptions {
  // A nominal radius far from the measured one, or a run shorter than the program's arc,
  // gives a note instead of a refusal (circana: --warn-inconsistent).
  bool warn_only = false;
  // How far the least-squares radius may be from the nominal one; default max(1 % of the
  // nominal radius, 0.05 mm) (circana: --radius-tolerance).
  std::optional<double> radius_tolerance_mm;
  // The unit of the trace's position columns, when `units: inch` leaves it open (circana:
  // --units).
  std::optional<PositionUnits> position_units;
  // How the refusals and notes of the evaluation name what the user can give (circana names
  // its options); the library's own words by default.
  RemedyWords remedy_words = library_remedy_words;
};

// A trace whose metadata says `units: inch` ran an inch program; its positions are in inch
// only if the machine's own units are (LinuxCNC logs machine units). The positions' circle
// decides: a least-squares radius within 10 % of radius_mm (or diameter_mm / 2, or
// `nominal_radius_mm`) means mm; within 10 % of it / 25.4 means inch, and every position
// column is converted to mm (all but t, period, marker, segment). Anything else, or no
// nominal radius, is refused unless `options.position_units` says it. Returns the note for
// the report (nullopt for a trace in mm).
std::optional<std::string> resolve_units(Trace& trace, std::optional<Plane> plane,
                                         std::optional<double> nominal_radius_mm,
                                         const InputCheckOptions& options);

// The plane's two columns must both move: a circle in that plane moves both by about its
// diameter. Refuses (DataError) when the smaller range is below max(1 um, 2 % of the larger)
// over the measured rows (marker rows, else all), naming the plane and the ranges of every
// position column.
// With a nominal radius, the larger range must also be at least a tenth of it: an arc of 90
// deg or more moves one axis by at least 0.7 R, so less is noise about a point while the
// circle ran in another plane (or a radius ten times too large, which the radius check would
// refuse later).
void check_plane_motion(const Trace& trace, Plane plane, const PlaneColumns& columns,
                        RemedyWords words = library_remedy_words,
                        std::optional<double> nominal_radius_mm = std::nullopt);

// The axis normal to the plane (z for XY) must stand still during a run: a run over which its
// actual column moves more than max(0.05 mm, 10 % of the larger range of the plane's columns)
// did not run in that plane. Refused, or a note with options.warn_only.
std::optional<std::string> check_off_plane(const Trace& trace, Plane plane,
                                           const PlaneColumns& columns, std::size_t run_number,
                                           const Run& run, const InputCheckOptions& options);

// The time column over the runs: its values within +-1e10 s, its median step between samples
// from 1e-7 s to 10 s (a servo period; sample_period_s is checked to the same range), else
// refused (a time column scaled or not in seconds). Against sample_period_s metadata: a median
// step outside half to twice it is refused, or a note with options.warn_only.
std::optional<std::string> check_time_column(const Trace& trace, const std::vector<Run>& runs,
                                             const InputCheckOptions& options);

// The runs the program announced (circgen's `segments: 1:CCW:F300,2:CW:F300`, else
// `directions` times the feeds of `feeds_mm_per_min`) against the runs found: fewer runs found
// is a recording stopped early. Refused, or a note with options.warn_only.
std::optional<std::string> check_announced_runs(const Trace& trace, const std::vector<Run>& runs,
                                                const InputCheckOptions& options);

// Each run's feed as the program announced it (mm/min): by run id from `segments`
// ("1:CCW:F300"), else in order from `directions` times `feeds_mm_per_min` when the runs found
// are the runs announced in their directions; none where the trace does not say.
std::vector<std::optional<double>> announced_run_feeds(const Trace& trace,
                                                       const std::vector<Run>& runs);

// The run's least-squares radius (`fitted_mm`, at 20 deg C) against the nominal radius.
std::optional<std::string> check_nominal_radius(const Trace& trace, std::size_t run_number,
                                                const Run& run, double fitted_mm, double nominal_mm,
                                                const std::string& nominal_source,
                                                const InputCheckOptions& options);

// The run's sweep against the metadata's arc_deg (the measured arc the program ran): shorter
// than arc_deg - max(1 deg, 3 %) is a run cut off (a recording stopped early). Without
// arc_deg, the longest run of the trace (`longest_sweep_deg`: evaluate() gives it for two runs
// or more marked by `marker` or `segment`) stands for it: the runs of one program sweep the
// same arc.
std::optional<std::string> check_run_arc(const Trace& trace, std::size_t run_number, const Run& run,
                                         const InputCheckOptions& options,
                                         std::optional<double> longest_sweep_deg = std::nullopt);

// A sample whose distance from the run's least-squares circle differs from the median one
// by more than max(50 x the robust spread (1.4826 MAD), 1 % of the radius, 0.05 mm) is an
// outlier: the MZC zone (G) would be set by that one row. Refused, naming its line.
void check_outliers(const Trace& trace, std::size_t run_number, const Run& run,
                    std::span<const double> a, std::span<const double> b, const Circle& lsc);

}  // namespace circtest
