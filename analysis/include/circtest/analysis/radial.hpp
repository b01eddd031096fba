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

}  // namespace circtest
