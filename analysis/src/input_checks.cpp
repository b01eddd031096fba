#include "circtest/analysis/input_checks.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/trace_keys.hpp"
#include "median.hpp"
#include "rows_context.hpp"

namespace circtest {
namespace {

constexpr double kMmPerInch = 25.4;

std::size_t line_of(const Trace& trace, std::size_t row) {
  return row < trace.line_of_row.size() ? trace.line_of_row[row] : 0;
}

// The rows a test measured: the marker rows when the trace has them, else every row.
// Calls f(i) for each row the test measured (marker >= 0.5), or for every row when none is
// marked (segmentation reports that; the checks here look at every row then). A visit, not an
// index list: the list cost 8 MB and 5 % of an analysis at 1e6 rows.
template <class F>
void for_each_measured_row(const Trace& trace, F&& f) {
  const std::vector<double>* marker = trace.column(column_name::marker);
  bool any = false;
  if (marker) {
    for (std::size_t i = 0; i < trace.rows(); ++i) {
      if ((*marker)[i] >= 0.5) {
        any = true;
        f(i);
      }
    }
  }
  if (!any) {
    for (std::size_t i = 0; i < trace.rows(); ++i) f(i);
  }
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  double width() const { return hi >= lo ? hi - lo : 0.0; }
};

double default_radius_tolerance(double nominal_mm) {
  return std::max(0.01 * nominal_mm, 0.05);
}

// A refusal, or with warn_only the same text as a note.
std::optional<std::string> refuse_or_note(const Trace& trace, std::size_t line,
                                          const std::string& message,
                                          const InputCheckOptions& options) {
  if (!options.warn_only) {
    throw DataError(trace.source, line,
                    fmt::format("{} ({} to evaluate anyway)", message,
                                options.remedy_words(Remedy::evaluate_anyway)));
  }
  return "warning: " + message;
}

}  // namespace

std::optional<std::string> resolve_units(Trace& trace, std::optional<Plane> plane,
                                         std::optional<double> nominal_radius_mm,
                                         const InputCheckOptions& options) {
  const std::string* units = trace.metadata.find(meta_key::units);
  if (!units || *units == "mm") {
    if (options.position_units == PositionUnits::inch) {
      // The option overrides: a hand-made trace in inch without the key.
    } else {
      return std::nullopt;
    }
  }
  const std::size_t units_line = trace.metadata.line_of(meta_key::units);
  const std::string give_units =
      fmt::format("give {} or {}", options.remedy_words(Remedy::units_inch),
                  options.remedy_words(Remedy::units_mm));
  bool inch = false;
  std::string why;
  if (options.position_units) {
    inch = *options.position_units == PositionUnits::inch;
    why = options.remedy_words(inch ? Remedy::units_inch : Remedy::units_mm);
  } else {
    if (!nominal_radius_mm) {
      if (auto r = trace.metadata.number(meta_key::radius_mm, trace.source)) {
        nominal_radius_mm = r;
      } else if (auto d = trace.metadata.number(meta_key::diameter_mm, trace.source)) {
        nominal_radius_mm = *d / 2.0;
      }
    }
    if (!nominal_radius_mm) {
      throw DataError(trace.source, units_line,
                      fmt::format("metadata 'units: inch': the program ran in inch, but the "
                                  "positions may be in inch or in mm (LinuxCNC logs the machine's "
                                  "units) and there is no radius_mm to tell which: {}",
                                  give_units));
    }
    // The plane's columns, else its commanded ones (a ball bar's trace).
    const Plane p = plane.value_or(Plane::XY);
    const PlaneAxes axes = plane_axes(p);
    const std::vector<double>* a = trace.column(column_name::actual(axes.first));
    const std::vector<double>* b = trace.column(column_name::actual(axes.second));
    if (!a || !b) {
      a = trace.column(column_name::commanded(axes.first));
      b = trace.column(column_name::commanded(axes.second));
    }
    if (!a || !b) {
      throw DataError(trace.source, units_line,
                      fmt::format("metadata 'units: inch': no {} position columns to tell whether "
                                  "the positions are in inch or mm: {}",
                                  plane_name(p), give_units));
    }
    std::vector<double> va, vb;
    for_each_measured_row(trace, [&](std::size_t i) {
      va.push_back((*a)[i]);
      vb.push_back((*b)[i]);
    });
    const double r = va.size() >= 3 ? detail::with_rows_context(trace, 0, trace.rows(),
                                                                "the measured rows' circle",
                                                                [&] { return fit_lsc(va, vb); })
                                          .radius_mm
                                    : 0.0;
    const double nominal = *nominal_radius_mm;
    const bool as_mm = std::abs(r - nominal) <= 0.1 * nominal;
    const bool as_inch = std::abs(r * kMmPerInch - nominal) <= 0.1 * nominal;
    if (as_mm == as_inch) {
      throw DataError(
          trace.source, units_line,
          fmt::format("metadata 'units: inch': the positions' circle (radius {:.4f}) is "
                      "within 10 % of neither the nominal radius {:.4f} mm nor {:.4f} in: {}",
                      r, nominal, nominal / kMmPerInch, give_units));
    }
    inch = as_inch;
    why = fmt::format("their circle (radius {:.4f}) matches the nominal radius {:.4f} {}", r,
                      inch ? nominal / kMmPerInch : nominal, inch ? "in" : "mm");
  }
  if (!inch) {
    return fmt::format(
        "units: the program ran in inch; the positions are in mm (the machine's units): {}", why);
  }
  for (std::size_t c = 0; c < trace.columns.size(); ++c) {
    const std::string& name = trace.columns[c];
    if (name == column_name::t || column_name::is_integer(name)) continue;
    for (double& v : trace.values[c]) v *= kMmPerInch;
  }
  return fmt::format("units: the positions are in inch ({}); converted to mm (x 25.4)", why);
}

void check_plane_motion(const Trace& trace, Plane plane, const PlaneColumns& columns,
                        RemedyWords words) {
  if (trace.rows() < 3) return;  // segmentation says "too few points"
  const std::vector<double>& a = trace.values[columns.a];
  const std::vector<double>& b = trace.values[columns.b];
  Range ra, rb;
  std::size_t first = trace.rows(), last = 0;
  for_each_measured_row(trace, [&](std::size_t i) {
    ra.add(a[i]);
    rb.add(b[i]);
    first = std::min(first, i);
    last = i;
  });
  const double wa = ra.width();
  const double wb = rb.width();
  const double small = std::min(wa, wb);
  const double large = std::max(wa, wb);
  if (small >= std::max(0.001, 0.02 * large)) return;
  std::string others;
  for (const char axis : {'x', 'y', 'z'}) {
    const std::vector<double>* v = trace.column(column_name::actual(axis));
    if (!v) continue;
    Range r;
    for_each_measured_row(trace, [&](std::size_t i) { r.add((*v)[i]); });
    others += fmt::format("{}{} {:.3f} mm", others.empty() ? "" : ", ", axis, r.width());
  }
  const std::string& na = trace.columns[columns.a];
  const std::string& nb = trace.columns[columns.b];
  throw DataError(
      trace.source, 0,
      fmt::format("plane {}: {} moves {:.3f} mm and {} {:.3f} mm over lines {}-{}: no circle in "
                  "that plane (position ranges: {}); give the plane of the test with {}",
                  plane_name(plane), na, wa, nb, wb, line_of(trace, first), line_of(trace, last),
                  others.empty() ? "none" : others, words(Remedy::give_plane)));
}

std::optional<std::string> check_nominal_radius(const Trace& trace, std::size_t run_number,
                                                const Run& run, double fitted_mm, double nominal_mm,
                                                const std::string& nominal_source,
                                                const InputCheckOptions& options) {
  // Values beyond any machine are refused by the result checks, which name them.
  if (!std::isfinite(fitted_mm) || !(std::abs(nominal_mm) <= 1e9)) return std::nullopt;
  const double tol = options.radius_tolerance_mm.value_or(default_radius_tolerance(nominal_mm));
  const double diff = fitted_mm - nominal_mm;
  if (std::abs(diff) <= tol) return std::nullopt;
  return refuse_or_note(
      trace, line_of(trace, run.begin),
      fmt::format("run {} (lines {}-{}): its least-squares radius {:.4f} mm differs from the "
                  "nominal radius {:.4f} mm ({}) by {:+.4f} mm, more than the tolerance {:.4f} "
                  "mm ({}): F would measure that difference",
                  run_number, line_of(trace, run.begin), line_of(trace, run.end - 1), fitted_mm,
                  nominal_mm, nominal_source, diff, tol,
                  options.remedy_words(Remedy::radius_tolerance)),
      options);
}

std::optional<std::string> check_run_arc(const Trace& trace, std::size_t run_number, const Run& run,
                                         const InputCheckOptions& options) {
  const std::optional<double> arc = trace.metadata.number(meta_key::arc_deg, trace.source);
  if (!arc) return std::nullopt;
  const double shortest = *arc - std::max(1.0, 0.03 * *arc);
  if (run.sweep_deg >= shortest) return std::nullopt;
  return refuse_or_note(
      trace, line_of(trace, run.begin),
      fmt::format("run {} (lines {}-{}) sweeps {:.1f} deg of the {:.1f} deg the program ran "
                  "(arc_deg, line {}): the run is cut off",
                  run_number, line_of(trace, run.begin), line_of(trace, run.end - 1), run.sweep_deg,
                  *arc, trace.metadata.line_of(meta_key::arc_deg)),
      options);
}

void check_outliers(const Trace& trace, std::size_t run_number, const Run& run,
                    std::span<const double> a, std::span<const double> b, const Circle& lsc) {
  const std::size_t n = a.size();
  if (n < 8) return;
  // The distances are worked out again for each pass (sqrt, not hypot: mm about a centre near
  // the data neither overflow nor underflow) instead of being kept.
  const auto dist = [&](std::size_t i) {
    const double da = a[i] - lsc.centre_a_mm, db = b[i] - lsc.centre_b_mm;
    return std::sqrt(da * da + db * db);
  };
  const double med = detail::median_of(n, dist);
  const double spread =
      1.4826 * detail::median_of(n, [&](std::size_t i) { return std::abs(dist(i) - med); });
  const double limit = std::max({50.0 * spread, 0.01 * lsc.radius_mm, 0.05});
  std::size_t worst = n;
  std::size_t count = 0;
  double worst_dev = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dev = std::abs(dist(i) - med);
    if (!(dev > limit)) continue;
    ++count;
    if (worst == n || dev > worst_dev) worst = i, worst_dev = dev;
  }
  if (worst == n) return;
  const std::size_t row = run.begin + worst;
  throw DataError(
      trace.source, line_of(trace, row),
      fmt::format("run {}: an outlier: this sample lies {:.4f} mm from the run's centre, the "
                  "others {:.4f} mm (spread {:.4f} mm); {} such sample{} (beyond {:.4f} mm), "
                  "which would set G (the MZC zone): correct or remove the row",
                  run_number, dist(worst), med, spread, count, count == 1 ? "" : "s", limit));
}

}  // namespace circtest
