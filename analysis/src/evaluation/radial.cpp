#include "circtest/analysis/radial.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "circtest/analysis/circle_fit.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/trace_keys.hpp"
#include "rows_context.hpp"
#include "user_units.hpp"

namespace circtest {

namespace {
// "12.5 mm" as the value prints in full; on an inch trace "0.492126 in (12.5 mm)".
std::string radial_length(double mm, const Trace& trace) {
  if (!detail::trace_in_inch(trace)) return fmt::format("{} mm", mm);
  return fmt::format("{:g} in ({} mm)", mm / detail::kUserMmPerInch, mm);
}
}  // namespace

Plane trace_plane(const Trace& trace, const std::optional<Plane>& option) {
  if (option) return *option;
  if (const std::string* p = trace.metadata.find(meta_key::plane)) {
    const auto parsed = parse_plane(*p);
    if (!parsed) {
      throw ParseError(trace.source, trace.metadata.line_of(meta_key::plane),
                       fmt::format("metadata 'plane': expected XY, YZ or ZX, got '{}'", *p));
    }
    return *parsed;
  }
  return Plane::XY;
}

bool is_radial_trace(const Trace& trace, Plane plane) {
  const PlaneAxes axes = plane_axes(plane);
  return trace.column(kRadialColumn) && !trace.column(column_name::actual(axes.first)) &&
         !trace.column(column_name::actual(axes.second));
}

RadialPositions radial_positions(const Trace& trace, const RadialOptions& options) {
  const Plane plane = trace_plane(trace, options.plane);
  const PlaneAxes axes = plane_axes(plane);
  const std::vector<double>* r = trace.column(kRadialColumn);
  const std::string name_a = column_name::commanded(axes.first);
  const std::string name_b = column_name::commanded(axes.second);
  const std::vector<double>* cmd_a = trace.column(name_a);
  const std::vector<double>* cmd_b = trace.column(name_b);
  if (!r) {
    throw ParseError(trace.source, trace.header_line, "no radial column 'r' to evaluate");
  }
  if (!cmd_a || !cmd_b) {
    throw ParseError(trace.source, trace.header_line,
                     fmt::format("a radial trace needs the commanded columns {},{} for the angle "
                                 "of each sample",
                                 name_a, name_b));
  }
  const std::optional<double> bar_length = trace.metadata.number(kBarLengthKey, trace.source);

  RadialPositions out;
  if (options.centre) {
    out.centre_a_mm = options.centre->a_mm;
    out.centre_b_mm = options.centre->b_mm;
    out.centre_source = ValueSource::option;
  } else if (const auto c = metadata_centre(trace, plane)) {
    out.centre_a_mm = c->a_mm;
    out.centre_b_mm = c->b_mm;
    out.centre_source = ValueSource::metadata;
  } else {
    // The commanded circle of the measured arcs (marker rows, else all): feed-in moves and
    // approaches would pull a fit over every row.
    const std::vector<double>* marker = trace.column(column_name::marker);
    std::vector<double> a, b;
    for (std::size_t i = 0; i < trace.rows(); ++i) {
      if (marker && (*marker)[i] == 0.0) continue;
      a.push_back((*cmd_a)[i]);
      b.push_back((*cmd_b)[i]);
    }
    if (a.size() < 3) {
      throw DataError(trace.source, trace.header_line,
                      "a radial trace without centre_mm metadata needs at least 3 commanded "
                      "points on the measured arcs to find the pivot");
    }
    const Circle fit = detail::with_rows_context(trace, 0, trace.rows(),
                                                 "the commanded points of the measured arcs",
                                                 [&] { return fit_lsc(a, b); });
    out.centre_a_mm = fit.centre_a_mm;
    out.centre_b_mm = fit.centre_b_mm;
    out.centre_source = ValueSource::commanded;
  }

  // A bar length near 0 is a length change: without bar_length_mm it would be read as a
  // radius of a few micrometres, a confident wrong F.
  if (!bar_length && trace.rows() > 0) {
    std::vector<double> sorted(r->begin(), r->end());
    const auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
    std::nth_element(sorted.begin(), mid, sorted.end());
    double commanded = options.radius_mm.value_or(0.0);
    if (commanded <= 0.0) {
      const std::size_t i = trace.rows() / 2;
      commanded = std::hypot((*cmd_a)[i] - out.centre_a_mm, (*cmd_b)[i] - out.centre_b_mm);
    }
    if (*mid < 0.5 * commanded) {
      throw DataError(
          trace.source, trace.header_line,
          fmt::format("column 'r' (median {}) is far below the radius {}: "
                      "a length change needs a '# {}: L' metadata line",
                      radial_length(*mid, trace), radial_length(commanded, trace), kBarLengthKey));
    }
  }

  out.trace = trace;
  out.column_a = column_name::from_radial(axes.first);
  out.column_b = column_name::from_radial(axes.second);
  if (trace.column(out.column_a) || trace.column(out.column_b)) {
    throw ParseError(trace.source, trace.header_line,
                     fmt::format("columns {} and {} are reserved for the positions computed "
                                 "from the radial channel",
                                 out.column_a, out.column_b));
  }
  std::vector<double> pa(trace.rows()), pb(trace.rows());
  const double offset = bar_length.value_or(0.0);
  for (std::size_t i = 0; i < trace.rows(); ++i) {
    const double da = (*cmd_a)[i] - out.centre_a_mm;
    const double db = (*cmd_b)[i] - out.centre_b_mm;
    const double d = std::hypot(da, db);
    if (d <= 0.0) {
      throw DataError(trace.source, trace.line_of_row[i],
                      "the commanded position is on the pivot: no angle for the bar reading");
    }
    const double length = (*r)[i] + offset;
    pa[i] = out.centre_a_mm + length * da / d;
    pb[i] = out.centre_b_mm + length * db / d;
  }
  out.trace.columns.push_back(out.column_a);
  out.trace.values.push_back(std::move(pa));
  out.trace.columns.push_back(out.column_b);
  out.trace.values.push_back(std::move(pb));
  out.note = fmt::format(
      "radial trace: radius from the length channel r{}, angle from {},{} about the pivot "
      "{},{} ({}); a length channel sees radial deviations only (no tangential error), and F "
      "rests on the bar's calibrated length",
      bar_length ? fmt::format(" + bar_length_mm {}", *bar_length) : std::string(), name_a, name_b,
      out.centre_a_mm, out.centre_b_mm, value_source_name(out.centre_source));
  return out;
}

}  // namespace circtest
