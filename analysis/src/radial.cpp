#include "circtest/analysis/radial.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "circtest/analysis/circle_fit.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/trace_keys.hpp"
#include "rows_context.hpp"

namespace circtest {

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

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
      throw DataError(trace.source, trace.header_line,
                      fmt::format("column 'r' (median {} mm) is far below the radius {} mm: "
                                  "a length change needs a '# {}: L' metadata line",
                                  *mid, commanded, kBarLengthKey));
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

std::vector<PolarPoint> parse_polar_text(std::string_view text, const std::string& source) {
  std::vector<PolarPoint> points;
  std::size_t line_no = 0, begin = 0;
  bool header_allowed = true;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    std::string_view view = text.substr(begin, end - begin);
    begin = end + 1;
    ++line_no;
    if (line_no == 1 && view.starts_with("\xEF\xBB\xBF")) view.remove_prefix(3);
    std::string original(view);
    if (!original.empty() && original.back() == '\r') original.pop_back();
    const auto lead = original.find_first_not_of(" \t");
    if (lead == std::string::npos) continue;
    if (original[lead] == '#' || original[lead] == ';') continue;
    std::string line = original;
    for (char& c : line) {
      if (c == ',' || c == ';' || c == '\t') c = ' ';
    }
    const auto first = line.find_first_not_of(' ');
    std::vector<std::string> fields;
    for (std::size_t pos = first; pos < line.size();) {
      const auto stop = std::min(line.find(' ', pos), line.size());
      fields.push_back(line.substr(pos, stop - pos));
      pos = line.find_first_not_of(' ', stop);
      if (pos == std::string::npos) break;
    }
    const auto angle = fields.size() == 2 ? parse_finite(fields[0]) : std::nullopt;
    const auto dev = fields.size() == 2 ? parse_finite(fields[1]) : std::nullopt;
    if (angle && dev) {
      // The bounds of a trace's start_deg (+-3600 deg); a ball bar's range is a few mm, so a
      // deviation of 10 mm is no reading: either would size the trace's numbers, not a test.
      if (std::abs(*angle) > kMaxPolarAngleDeg || std::abs(*dev) > kMaxPolarDeviationUm) {
        throw ParseError(source, line_no,
                         fmt::format("expected an angle within +-{:g} deg and a radial deviation "
                                     "within +-{:g} um, got '{}'",
                                     kMaxPolarAngleDeg, kMaxPolarDeviationUm, original));
      }
      points.push_back({*angle, *dev, line_no});
      header_allowed = false;
      continue;
    }
    const bool numeric = std::any_of(fields.begin(), fields.end(), [](const std::string& f) {
      return parse_finite(f).has_value();
    });
    if (header_allowed && !numeric) {
      header_allowed = false;  // one column-title line
      continue;
    }
    throw ParseError(source, line_no,
                     fmt::format("expected two numbers: angle in deg and radial deviation in "
                                 "um, got '{}'",
                                 original));
  }
  if (points.size() < 3) {
    throw ParseError(source, line_no,
                     fmt::format("{} points: a polar export needs at least 3", points.size()));
  }
  return points;
}

Trace polar_to_trace(const std::vector<PolarPoint>& points, Plane plane, double radius_mm,
                     const std::string& source) {
  const PlaneAxes axes = plane_axes(plane);
  Trace trace;
  trace.source = source;
  trace.metadata.set(meta_key::plane, std::string(plane_name(plane)));
  trace.metadata.set(meta_key::radius_mm, fmt::format("{}", radius_mm));
  trace.metadata.set(meta_key::centre_mm, "0,0,0");
  trace.metadata.set(std::string(kBarLengthKey), fmt::format("{}", radius_mm));
  trace.metadata.set(meta_key::imported_from, source);
  trace.columns = {column_name::commanded(axes.first), column_name::commanded(axes.second),
                   std::string(kRadialColumn), column_name::marker, column_name::segment};
  trace.values.assign(trace.columns.size(), {});
  int segment = 1;
  int sense = 0;               // +1 rising angles, -1 falling, 0 not known yet
  std::size_t last_moved = 0;  // the point that ended the last step of non-zero angle
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (i > 0) {
      const double step = points[i].angle_deg - points[i - 1].angle_deg;
      const int s = step > 0 ? 1 : (step < 0 ? -1 : 0);
      if (s != 0 && sense != 0 && s != sense) {
        // The angle turned back: the next run starts at the turning point (a point repeated
        // there belongs to the new run, like its first sample).
        ++segment;
        sense = 0;
        for (std::size_t j = last_moved + 1; j < i; ++j) trace.values[4][j] = segment;
      }
      if (s != 0 && sense == 0) sense = s;
      if (s != 0) last_moved = i;
    }
    const double t = points[i].angle_deg * kDegToRad;
    trace.values[0].push_back(radius_mm * std::cos(t));
    trace.values[1].push_back(radius_mm * std::sin(t));
    trace.values[2].push_back(points[i].deviation_um * 1e-3);
    trace.values[3].push_back(1.0);
    trace.values[4].push_back(segment);
    trace.line_of_row.push_back(static_cast<std::uint32_t>(points[i].line));
  }
  return trace;
}

}  // namespace circtest
