#include "circtest/analysis/input_checks.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "median.hpp"
#include "rows_context.hpp"
#include "user_units.hpp"

namespace circtest {
namespace {

constexpr double kMmPerInch = detail::kUserMmPerInch;
using detail::user_length;

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
  // A trace without the key that the option says is in inch: the refusals and notes after
  // this say their lengths in inch too (user_units.hpp), and its F words are in/min.
  if (!units) trace.metadata.set(meta_key::units, "inch");
  return fmt::format("units: the positions are in inch ({}); converted to mm (x 25.4)", why);
}

void check_plane_motion(const Trace& trace, Plane plane, const PlaneColumns& columns,
                        RemedyWords words, std::optional<double> nominal_radius_mm) {
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
  const bool flat = small < std::max(0.001, 0.02 * large);
  // A radius beyond any machine is the result checks' to name (they refuse what it gives).
  const bool plausible = nominal_radius_mm && *nominal_radius_mm <= 100'000.0;
  const bool inch = detail::trace_in_inch(trace);
  const double least_mm = plausible ? 0.1 * *nominal_radius_mm : 0.0;
  if (!flat && large >= least_mm) return;
  std::string others;
  for (const char axis : {'x', 'y', 'z'}) {
    const std::vector<double>* v = trace.column(column_name::actual(axis));
    if (!v) continue;
    Range r;
    for_each_measured_row(trace, [&](std::size_t i) { r.add((*v)[i]); });
    others +=
        fmt::format("{}{} {}", others.empty() ? "" : ", ", axis, user_length(r.width(), 3, inch));
  }
  const std::string& na = trace.columns[columns.a];
  const std::string& nb = trace.columns[columns.b];
  const std::string too_little =
      flat ? std::string()
           : fmt::format(", less than a circle of radius {} moves them (at least {})",
                         user_length(*nominal_radius_mm, 3, inch), user_length(least_mm, 3, inch));
  throw DataError(
      trace.source, 0,
      fmt::format("plane {}: {} moves {} and {} {} over lines {}-{}{}: no circle in "
                  "that plane (position ranges: {}); give the plane of the test with {}",
                  plane_name(plane), na, user_length(wa, 3, inch), nb, user_length(wb, 3, inch),
                  line_of(trace, first), line_of(trace, last), too_little,
                  others.empty() ? "none" : others, words(Remedy::give_plane)));
}

std::optional<std::string> check_off_plane(const Trace& trace, Plane plane,
                                           const PlaneColumns& columns, std::size_t run_number,
                                           const Run& run, const InputCheckOptions& options) {
  const char normal = plane_axes(plane).normal;
  const std::vector<double>* n = trace.column(column_name::actual(normal));
  if (!n || run.size() == 0) return std::nullopt;
  Range ra, rb, rn;
  for (std::size_t i = run.begin; i < run.end; ++i) {
    ra.add(trace.values[columns.a][i]);
    rb.add(trace.values[columns.b][i]);
    rn.add((*n)[i]);
  }
  const double limit = std::max(0.05, 0.1 * std::max(ra.width(), rb.width()));
  if (rn.width() <= limit) return std::nullopt;
  const bool inch = detail::trace_in_inch(trace);
  return refuse_or_note(
      trace, line_of(trace, run.begin),
      fmt::format("run {} (lines {}-{}): {} moves {} while {} moves {} and {} "
                  "{}: the run is not in the plane {} ({} may move at most {}); "
                  "give the plane of the test with {}",
                  run_number, line_of(trace, run.begin), line_of(trace, run.end - 1),
                  column_name::actual(normal), user_length(rn.width(), 3, inch),
                  trace.columns[columns.a], user_length(ra.width(), 3, inch),
                  trace.columns[columns.b], user_length(rb.width(), 3, inch), plane_name(plane),
                  column_name::actual(normal), user_length(limit, 3, inch),
                  options.remedy_words(Remedy::give_plane)),
      options);
}

std::optional<std::string> check_time_column(const Trace& trace, const std::vector<Run>& runs,
                                             const InputCheckOptions& options) {
  const std::vector<double>* t = trace.column(column_name::t);
  if (!t) return std::nullopt;
  constexpr double kMaxTimeS = 1e10;  // 317 years: beyond any clock a recorder keeps
  std::size_t steps = 0;
  for (const Run& run : runs) {
    for (std::size_t i = run.begin; i < run.end; ++i) {
      if (!(std::abs((*t)[i]) <= kMaxTimeS)) {
        throw DataError(trace.source, line_of(trace, i),
                        fmt::format("t: {} s is beyond +-1e10 s: expected the time of the sample "
                                    "in seconds (is the time column scaled?)",
                                    (*t)[i]));
      }
    }
    steps += run.size() > 0 ? run.size() - 1 : 0;
  }
  if (steps == 0) return std::nullopt;
  // The k-th step between successive samples of a run, over the runs in order.
  const double step_s = detail::median_of(steps, [&](std::size_t k) {
    for (const Run& run : runs) {
      const std::size_t m = run.size() > 0 ? run.size() - 1 : 0;
      if (k < m) return (*t)[run.begin + k + 1] - (*t)[run.begin + k];
      k -= m;
    }
    return 0.0;
  });
  const std::size_t first = line_of(trace, runs.front().begin);
  if (step_s > 0.0 && (step_s < 1e-7 || step_s > 10.0)) {
    throw DataError(trace.source, first,
                    fmt::format("t: the samples of the runs are {:g} s apart (median step): "
                                "expected a sample period from 1e-7 s to 10 s (is the time "
                                "column scaled, or not in seconds?)",
                                step_s));
  }
  const std::optional<double> period =
      trace.metadata.number(meta_key::sample_period_s, trace.source);
  if (!period || !(step_s > 0.0) || (step_s >= 0.5 * *period && step_s <= 2.0 * *period)) {
    return std::nullopt;
  }
  return refuse_or_note(
      trace, first,
      fmt::format("t: the samples of the runs are {:g} s apart (median step), but "
                  "sample_period_s (line {}) says {:g} s: the time column is scaled or in other "
                  "units, and the feed and the servo terms would be wrong",
                  step_s, trace.metadata.line_of(meta_key::sample_period_s), *period),
      options);
}

namespace {

struct Announced {
  std::string key;                           // the metadata key they came from
  std::vector<long> ids;                     // run ids, when `segments` gives them
  std::vector<std::string> dirs;             // each run's direction as announced
  std::vector<std::optional<double>> feeds;  // each run's feed as announced (mm/min)
};

std::vector<std::string> split_list(std::string_view text) {
  std::vector<std::string> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    const std::string_view item = trim(text.substr(pos, comma - pos));
    if (!item.empty()) out.emplace_back(item);
    pos = comma + 1;
  }
  return out;
}

// circgen's `segments` (id:DIR:Ffeed:PLANE, ...; older programs without the plane), else
// `directions` once per feed; none when the
// trace says nothing of its runs (or says it in a form not understood).
std::optional<Announced> announced_runs(const Trace& trace) {
  Announced a;
  const bool inch_program = detail::trace_in_inch(trace);
  if (const std::string* segments = trace.metadata.find(meta_key::segments)) {
    a.key = meta_key::segments;
    for (const std::string& item : split_list(*segments)) {
      const auto colon = item.find(':');
      const auto id = parse_finite(std::string_view(item).substr(0, colon));
      if (!id || *id < 1 || *id > 2147483647.0 || std::floor(*id) != *id) return std::nullopt;
      a.ids.push_back(static_cast<long>(*id));
      const std::string_view rest = colon == std::string::npos
                                        ? std::string_view()
                                        : std::string_view(item).substr(colon + 1);
      a.dirs.emplace_back(rest.substr(0, rest.find(':')));
      // The feed after the direction, the program's F word: "F300" (mm/min), in an inch
      // program "F11.811" (in/min).
      std::optional<double> feed;
      if (const auto f = rest.find(":F"); f != std::string_view::npos) {
        const std::string_view v = rest.substr(f + 2);
        feed = parse_finite(v.substr(0, v.find(':')));
        if (feed && !(*feed > 0)) feed.reset();
        if (feed && inch_program) *feed *= kMmPerInch;
      }
      a.feeds.push_back(feed);
    }
    return a.ids.empty() ? std::nullopt : std::optional<Announced>(a);
  }
  const std::string* directions = trace.metadata.find(meta_key::directions);
  if (!directions) return std::nullopt;
  a.key = meta_key::directions;
  const std::vector<std::string> dirs = split_list(*directions);
  std::vector<std::optional<double>> feeds{std::nullopt};
  if (const std::string* f = trace.metadata.find(meta_key::feeds_mm_per_min)) {
    feeds.clear();
    for (const std::string& item : split_list(*f)) {
      std::optional<double> feed = parse_finite(item);
      if (feed && !(*feed > 0)) feed.reset();
      feeds.push_back(feed);
    }
    if (feeds.empty()) feeds.emplace_back();
    a.key += " x feeds_mm_per_min";
  }
  for (const std::optional<double>& feed : feeds) {
    a.dirs.insert(a.dirs.end(), dirs.begin(), dirs.end());
    a.feeds.insert(a.feeds.end(), dirs.size(), feed);
  }
  return a.dirs.empty() ? std::nullopt : std::optional<Announced>(a);
}

}  // namespace

std::optional<std::string> check_announced_runs(const Trace& trace, const std::vector<Run>& runs,
                                                const InputCheckOptions& options) {
  const std::optional<Announced> announced = announced_runs(trace);
  if (!announced) return std::nullopt;
  std::string missing;
  const bool by_id =
      !announced->ids.empty() && trace.column(column_name::segment) &&
      std::all_of(runs.begin(), runs.end(), [](const Run& r) { return r.segment_id != 0; });
  if (by_id) {
    for (std::size_t k = 0; k < announced->ids.size(); ++k) {
      const long id = announced->ids[k];
      if (std::any_of(runs.begin(), runs.end(), [&](const Run& r) { return r.segment_id == id; }))
        continue;
      missing += fmt::format("{}{} ({})", missing.empty() ? "" : ", ", id, announced->dirs[k]);
    }
  } else if (runs.size() < announced->dirs.size()) {
    for (std::size_t k = runs.size(); k < announced->dirs.size(); ++k) {
      missing += fmt::format("{}{} ({})", missing.empty() ? "" : ", ", k + 1, announced->dirs[k]);
    }
  }
  if (missing.empty()) return std::nullopt;
  const std::string first_key = announced->key.substr(0, announced->key.find(' '));
  return refuse_or_note(
      trace, trace.metadata.line_of(first_key),
      fmt::format("the program announced {} runs ({}, line {}), the trace holds {}: run{} {} "
                  "missing (the recording stopped early?)",
                  announced->dirs.size(), announced->key, trace.metadata.line_of(first_key),
                  runs.size(), missing.find(',') == std::string::npos ? "" : "s", missing),
      options);
}

std::vector<std::optional<double>> announced_run_feeds(const Trace& trace,
                                                       const std::vector<Run>& runs) {
  std::vector<std::optional<double>> out(runs.size());
  const std::optional<Announced> announced = announced_runs(trace);
  if (!announced) return out;
  const bool by_id =
      !announced->ids.empty() && trace.column(column_name::segment) &&
      std::all_of(runs.begin(), runs.end(), [](const Run& r) { return r.segment_id != 0; });
  if (by_id) {
    for (std::size_t k = 0; k < runs.size(); ++k) {
      const auto it = std::find(announced->ids.begin(), announced->ids.end(), runs[k].segment_id);
      if (it != announced->ids.end())
        out[k] = announced->feeds[static_cast<std::size_t>(it - announced->ids.begin())];
    }
    return out;
  }
  // In order: only when the runs found are the runs announced, each in its direction.
  if (runs.size() != announced->dirs.size()) return out;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    if (announced->dirs[k] != direction_name(runs[k].direction))
      return std::vector<std::optional<double>>(runs.size());
  }
  for (std::size_t k = 0; k < runs.size(); ++k) out[k] = announced->feeds[k];
  return out;
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
  const bool inch = detail::trace_in_inch(trace);
  return refuse_or_note(
      trace, line_of(trace, run.begin),
      fmt::format("run {} (lines {}-{}): its least-squares radius {} differs from the "
                  "nominal radius {} ({}) by {}{}, more than the tolerance {} ({}): F would "
                  "measure that difference",
                  run_number, line_of(trace, run.begin), line_of(trace, run.end - 1),
                  user_length(fitted_mm, 4, inch), user_length(nominal_mm, 4, inch), nominal_source,
                  diff < 0 ? "-" : "+", user_length(std::abs(diff), 4, inch),
                  user_length(tol, 4, inch), options.remedy_words(Remedy::radius_tolerance)),
      options);
}

std::optional<std::string> check_run_arc(const Trace& trace, std::size_t run_number, const Run& run,
                                         const InputCheckOptions& options,
                                         std::optional<double> longest_sweep_deg) {
  const std::optional<double> arc = trace.metadata.number(meta_key::arc_deg, trace.source);
  const std::optional<double> expected = arc ? arc : longest_sweep_deg;
  // A sweep that is not a number comes from coordinates the run's fit refuses by name.
  if (!expected || !std::isfinite(run.sweep_deg) || !std::isfinite(*expected)) return std::nullopt;
  const double shortest = *expected - std::max(1.0, 0.03 * *expected);
  if (run.sweep_deg >= shortest) return std::nullopt;
  const std::string against =
      arc ? fmt::format("of the {:.1f} deg the program ran (arc_deg, line {})", *arc,
                        trace.metadata.line_of(meta_key::arc_deg))
          : fmt::format(
                "against the {:.1f} deg of the longest run (no arc_deg metadata: the "
                "runs of one program sweep the same arc)",
                *expected);
  return refuse_or_note(
      trace, line_of(trace, run.begin),
      fmt::format("run {} (lines {}-{}) sweeps {:.1f} deg {}: the run is cut off", run_number,
                  line_of(trace, run.begin), line_of(trace, run.end - 1), run.sweep_deg, against),
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
  const bool inch = detail::trace_in_inch(trace);
  throw DataError(trace.source, line_of(trace, row),
                  fmt::format("run {}: an outlier: this sample lies {} from the run's centre, the "
                              "others {} (spread {}); {} such sample{} (beyond {}), "
                              "which would set G (the MZC zone): correct or remove the row",
                              run_number, user_length(dist(worst), 4, inch),
                              user_length(med, 4, inch), user_length(spread, 4, inch), count,
                              count == 1 ? "" : "s", user_length(limit, 4, inch)));
}

}  // namespace circtest
