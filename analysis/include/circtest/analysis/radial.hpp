#pragma once
// Radial (ball bar) traces: one length channel `r` beside the commanded columns. The angle
// of each sample comes from the commanded position about the set-up centre (the bar's
// pivot), its radius from the bar: a bar sees only the distance to the pivot, never the
// tangential error. docs/trace-format.md "Radial traces".
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/plane.hpp"
#include "circtest/core/trace.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest {

inline constexpr std::string_view kRadialColumn = column_name::r;
inline constexpr std::string_view kBarLengthKey = meta_key::bar_length_mm;

struct RadialOptions {
  std::optional<Plane> plane;  // default: the trace's `plane` metadata, else XY
  // The pivot; default: centre_mm metadata, else the LSC of the commanded points of the
  // measured arcs.
  std::optional<PlanePoint> centre;
  std::optional<double> radius_mm;  // nominal radius, for the plausibility check of r
};

// A trace to evaluate from its radial channel: it has `r` but not the plane's own position
// columns (x, y for XY, ...).
bool is_radial_trace(const Trace& trace, Plane plane);

// The plane of a trace: the option, else its `plane` metadata, else XY.
Plane trace_plane(const Trace& trace, const std::optional<Plane>& option);

struct RadialPositions {
  Trace trace;           // the input with two columns added: column_a, column_b
  std::string column_a;  // "<a>_r", "<b>_r": pivot + bar length along the commanded angle
  std::string column_b;
  double centre_a_mm = 0.0;
  double centre_b_mm = 0.0;
  ValueSource centre_source = ValueSource::none;
  std::string note;  // what was evaluated, for the report
};

// Throws ParseError naming the file when `r` or the commanded columns are missing, or
// bar_length_mm is no number; DataError when r looks like a length change without
// bar_length_mm (or a commanded point sits on the pivot).
RadialPositions radial_positions(const Trace& trace, const RadialOptions& options);

// One point of a polar export: angle (deg, from the plane's first axis toward its second)
// and radial deviation from the nominal radius (um).
struct PolarPoint {
  double angle_deg = 0.0;
  double deviation_um = 0.0;
  std::size_t line = 0;
};

// Plain two-column text (angle deg, radial deviation um), separated by blanks, tabs, a
// comma or a semicolon; '#' and ';' comment lines, blank lines and one header line of
// non-numbers before the data are skipped. ParseError "file:line: ..." otherwise, also for an
// angle beyond +-kMaxPolarAngleDeg or a deviation beyond +-kMaxPolarDeviationUm.
inline constexpr double kMaxPolarAngleDeg = 3600.0;
inline constexpr double kMaxPolarDeviationUm = 10'000.0;
std::vector<PolarPoint> parse_polar_text(std::string_view text, const std::string& source);

// The points as a radial trace: <a>_cmd, <b>_cmd on the nominal circle about `centre`,
// r = deviation in mm (length change, bar_length_mm = radius), marker 1 and segment 1, 2, ...
// split where the angle turns back (a CCW and a CW run in one file).
Trace polar_to_trace(const std::vector<PolarPoint>& points, Plane plane, double radius_mm,
                     const std::string& source);

}  // namespace circtest
