#include "circtest/analysis/segmentation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <numbers>

#include "angle_constants.hpp"
#include "circtest/analysis/circle_fit.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/parallel.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "radial_profile.hpp"
#include "rows_context.hpp"

namespace circtest {

namespace {

using evaluation_detail::kRadToDeg;

std::size_t find_column(const Trace& trace, const std::string& name) {
  const auto i = trace.column_index(name);
  if (!i) {
    throw ParseError(trace.source, trace.header_line,
                     fmt::format("missing column '{}': expected it in the header (found: {})", name,
                                 join(trace.columns)));
  }
  return *i;
}

struct Span {
  std::size_t begin, end;
};

// Signed swept angle (rad) of rows [begin, end) about a centre: the turn angles of successive
// samples (detail::turn_angle, block by block), summed in row order.
double swept_angle(const double* a, const double* b, std::size_t begin, std::size_t end, double ca,
                   double cb) {
  double total = 0.0;
  double turn[detail::kTurnBlock];
  for (std::size_t i = begin; i + 1 < end; i += detail::kTurnBlock) {
    const std::size_t count = std::min(detail::kTurnBlock, end - 1 - i);
    detail::turn_angles(a + i, b + i, ca, cb, count, turn);
    for (std::size_t k = 0; k < count; ++k) total += turn[k];
  }
  return total;
}

Circle centre_of(const double* a, const double* b, Span s, const SegmentationOptions& o) {
  if (o.centre) {
    return {o.centre->a_mm, o.centre->b_mm, o.radius_mm.value_or(0.0)};
  }
  return fit_lsc_algebraic(std::span<const double>(a + s.begin, s.end - s.begin),
                           std::span<const double>(b + s.begin, s.end - s.begin));
}

Run make_run(const double* a, const double* b, Span s, const Circle& c) {
  Run r;
  r.begin = s.begin;
  r.end = s.end;
  const double sweep = swept_angle(a, b, s.begin, s.end, c.centre_a_mm, c.centre_b_mm);
  r.direction = sweep >= 0 ? Direction::CCW : Direction::CW;
  r.sweep_deg = std::abs(sweep) * kRadToDeg;
  r.start_deg = std::atan2(b[s.begin] - c.centre_b_mm, a[s.begin] - c.centre_a_mm) * kRadToDeg;
  return r;
}

// Splits a marked span where the rotation about its centre turns back by more than
// kReversalDeg, at the turning row (the extremum of the accumulated angle).
std::vector<Span> split_at_reversals(const double* a, const double* b, Span s, const Circle& c,
                                     std::size_t min_points) {
  std::vector<Span> out;
  const double hysteresis = kReversalDeg / kRadToDeg;
  double theta = 0.0;  // accumulated angle from the span's first row
  double extreme = 0.0;
  std::size_t extreme_row = s.begin;
  int dir = 0;
  std::size_t begin = s.begin;
  double turn[detail::kTurnBlock];
  for (std::size_t i = s.begin + 1; i < s.end; ++i) {
    const std::size_t k = (i - s.begin - 1) % detail::kTurnBlock;
    if (k == 0) {
      detail::turn_angles(a + i - 1, b + i - 1, c.centre_a_mm, c.centre_b_mm,
                          std::min(detail::kTurnBlock, s.end - i), turn);
    }
    theta += turn[k];
    if (dir == 0) {
      if (std::abs(theta) > hysteresis) dir = theta > 0 ? 1 : -1;
      extreme = theta;
      extreme_row = i;
      continue;
    }
    if ((theta - extreme) * dir > 0) {
      extreme = theta;
      extreme_row = i;
    } else if ((extreme - theta) * dir > hysteresis) {
      out.push_back({begin, extreme_row + 1});
      begin = extreme_row + 1;  // the turning row ends the first run
      dir = -dir;
      extreme = theta;
      extreme_row = i;
    }
  }
  out.push_back({begin, s.end});
  // A part of a few rows is a glitch (one sample far off the circle turns the angle back and
  // forth), not a run: the span stays whole and the outlier check names that row.
  for (const Span& part : out) {
    if (part.end - part.begin < min_points) return {s};
  }
  return out;
}

// Finds the arcs at constant radius inside [lo, hi): moving samples near the circle,
// split where the rotation changes sign; stretches under min_sweep are dropped (lead arcs,
// feed-in moves), overtravel beyond 360 deg is trimmed evenly.
std::vector<Run> automatic_runs(const Trace& trace, const double* a, const double* b, Span range,
                                const SegmentationOptions& o) {
  const auto fit = [&](const std::vector<double>& fa, const std::vector<double>& fb) {
    return detail::with_rows_context(trace, range.begin, range.end, "the moving samples",
                                     [&] { return fit_lsc_algebraic(fa, fb); });
  };
  std::vector<Run> out;
  const std::size_t n = range.end - range.begin;
  if (n < o.min_points) return out;
  constexpr std::size_t w = 5;
  std::vector<double> chord(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i0 = range.begin + (k >= w ? k - w : 0);
    const std::size_t i1 = range.begin + std::min(n - 1, k + w);
    chord[k] = std::hypot(a[i1] - a[i0], b[i1] - b[i0]);
  }
  std::vector<double> moving_chords;
  moving_chords.reserve(n);
  for (double c : chord) {
    if (c > 1e-4) moving_chords.push_back(c);
  }
  if (moving_chords.empty()) return out;
  auto mid = moving_chords.begin() + static_cast<std::ptrdiff_t>(moving_chords.size() / 2);
  std::nth_element(moving_chords.begin(), mid, moving_chords.end());
  const double moving_threshold = 0.3 * *mid;

  std::vector<char> keep(n, 0);
  std::vector<double> sa, sb;
  for (std::size_t k = 0; k < n; ++k) {
    if (chord[k] > moving_threshold) {
      keep[k] = 1;
      sa.push_back(a[range.begin + k]);
      sb.push_back(b[range.begin + k]);
    }
  }
  if (sa.size() < o.min_points) return out;

  Circle c;
  if (o.centre && o.radius_mm) {
    c = {o.centre->a_mm, o.centre->b_mm, *o.radius_mm};
  } else {
    // Refit on the samples near the first estimate: feed-in lines and lead arcs of another
    // radius pull the first algebraic fit away from the test circle.
    c = fit(sa, sb);
    for (int pass = 0; pass < 3; ++pass) {
      const double tol = std::max(0.05 * c.radius_mm, 0.2);
      std::vector<double> ta, tb;
      for (std::size_t i = 0; i < sa.size(); ++i) {
        if (std::abs(std::hypot(sa[i] - c.centre_a_mm, sb[i] - c.centre_b_mm) - c.radius_mm) <
            tol) {
          ta.push_back(sa[i]);
          tb.push_back(sb[i]);
        }
      }
      if (ta.size() < o.min_points) break;
      c = fit(ta, tb);
    }
  }
  const double tol = std::max(0.01 * c.radius_mm, 0.2);
  for (std::size_t k = 0; k < n; ++k) {
    if (!keep[k]) continue;
    const std::size_t i = range.begin + k;
    if (std::abs(std::hypot(a[i] - c.centre_a_mm, b[i] - c.centre_b_mm) - c.radius_mm) > tol) {
      keep[k] = 0;
    }
  }

  auto close_stretch = [&](std::size_t s, std::size_t e) {
    if (e - s < o.min_points) return;
    const double sweep = swept_angle(a, b, s, e, c.centre_a_mm, c.centre_b_mm);
    if (std::abs(sweep) * kRadToDeg < o.min_sweep_deg) return;
    Span sp{s, e};
    const double over = std::abs(sweep) * kRadToDeg - 360.0;
    if (over > 0.5) {
      // Trim evenly: walk in from both ends until each has lost half the overtravel.
      const double half = over / 2.0 / kRadToDeg;
      double acc = 0.0;
      while (sp.begin + 1 < sp.end && acc < half) {
        acc += std::abs(swept_angle(a, b, sp.begin, sp.begin + 2, c.centre_a_mm, c.centre_b_mm));
        ++sp.begin;
      }
      acc = 0.0;
      while (sp.end > sp.begin + 1 && acc < half) {
        acc += std::abs(swept_angle(a, b, sp.end - 2, sp.end, c.centre_a_mm, c.centre_b_mm));
        --sp.end;
      }
    }
    // Trimming a stretch of few samples can leave fewer than a run needs.
    if (sp.end - sp.begin < o.min_points) return;
    out.push_back(make_run(a, b, sp, c));
  };

  // Split kept stretches where the rotation reverses; a short window smooths jitter.
  std::size_t start = 0;
  bool open = false;
  int dir = 0;
  for (std::size_t k = 0; k <= n; ++k) {
    const bool kept = k < n && keep[k];
    if (!kept) {
      if (open) close_stretch(range.begin + start, range.begin + k);
      open = false;
      dir = 0;
      continue;
    }
    const std::size_t i = range.begin + k;
    int d = 0;
    if (k + w < n && keep[k + w]) {
      const double s = swept_angle(a, b, i, i + w + 1, c.centre_a_mm, c.centre_b_mm);
      d = s > 0 ? 1 : (s < 0 ? -1 : 0);
    }
    if (!open) {
      open = true;
      start = k;
      dir = d;
    } else if (d != 0 && dir != 0 && d != dir) {
      close_stretch(range.begin + start, i);
      start = k;
      dir = d;
    } else if (dir == 0) {
      dir = d;
    }
  }
  return out;
}

// A run id is a whole number from 0 (idle) that an int holds (circgen writes 1, 2, ...), and
// a marker 0 or 1 (a HAL bit); anything else (-1, 1.5, a glitch of 1e300) is refused at its
// line instead of becoming an arbitrary run or a half-marked row.
void check_run_columns(const Trace& trace, const std::vector<double>* marker,
                       const std::vector<double>* segment) {
  const auto line = [&](std::size_t row) { return trace.line_of_row[row]; };
  const std::size_t n = trace.rows();
  if (segment) {
    for (std::size_t row = 0; row < n; ++row) {
      const double v = (*segment)[row];
      if (!(v >= 0.0 && v <= 2147483647.0 && std::floor(v) == v)) {
        throw DataError(trace.source, line(row),
                        fmt::format("segment: expected a run id, a whole number 0..2147483647 "
                                    "(0 = idle), got {}",
                                    v));
      }
    }
  }
  if (marker) {
    for (std::size_t row = 0; row < n; ++row) {
      const double v = (*marker)[row];
      if (v != 0.0 && v != 1.0) {
        throw DataError(trace.source, line(row), fmt::format("marker: expected 0 or 1, got {}", v));
      }
    }
  }
}

}  // namespace

const char* segmentation_method_name(SegmentationMethod method) noexcept {
  switch (method) {
    case SegmentationMethod::marker:
      return "marker";
    case SegmentationMethod::segment:
      return "segment";
    case SegmentationMethod::automatic:
      return "automatic";
  }
  return "automatic";
}

std::optional<SegmentationMethod> parse_segmentation_method(std::string_view name) {
  for (auto m :
       {SegmentationMethod::marker, SegmentationMethod::segment, SegmentationMethod::automatic}) {
    if (name == segmentation_method_name(m)) return m;
  }
  return std::nullopt;
}

PlaneColumns plane_columns(const Trace& trace, Plane plane, const std::string& a_name,
                           const std::string& b_name) {
  const PlaneAxes axes = plane_axes(plane);
  PlaneColumns c;
  c.a = find_column(trace, a_name.empty() ? column_name::actual(axes.first) : a_name);
  c.b = find_column(trace, b_name.empty() ? column_name::actual(axes.second) : b_name);
  return c;
}

Segmentation segment_trace(const Trace& trace, PlaneColumns columns,
                           const SegmentationOptions& options) {
  Segmentation result;
  const std::size_t n = trace.rows();
  const double* a = trace.values[columns.a].data();
  const double* b = trace.values[columns.b].data();
  const std::vector<double>* marker = trace.column(column_name::marker);
  const std::vector<double>* segment = trace.column(column_name::segment);
  auto line = [&](std::size_t row) -> std::size_t {
    return row < trace.line_of_row.size() ? trace.line_of_row[row] : 0;
  };
  if (n < 3) {
    throw DataError(trace.source, n == 0 ? trace.header_line : line(n - 1),
                    fmt::format("too few points: {} rows, expected at least 3 per run", n));
  }
  check_run_columns(trace, marker, segment);
  auto seg_id = [&](std::size_t row) -> long { return segment ? std::lround((*segment)[row]) : 0; };
  // Whether `row` carries run `id`, the id of row `first`: the same value as that row's needs
  // no check or rounding again (nearly every row of a run).
  auto in_run = [&](std::size_t row, std::size_t first, long id) {
    return !segment || (*segment)[row] == (*segment)[first] || seg_id(row) == id;
  };

  std::vector<Span> spans;
  if (marker) {
    result.method = SegmentationMethod::marker;
    std::size_t i = 0;
    while (i < n) {
      if ((*marker)[i] < 0.5) {
        ++i;
        continue;
      }
      std::size_t j = i + 1;
      const long id = seg_id(i);
      while (j < n && (*marker)[j] >= 0.5 && in_run(j, i, id)) ++j;
      spans.push_back({i, j});
      i = j;
    }
  } else if (segment) {
    result.method = SegmentationMethod::segment;
    std::size_t i = 0;
    while (i < n) {
      if (seg_id(i) == 0) {
        ++i;
        continue;
      }
      std::size_t j = i + 1;
      const long id = seg_id(i);
      while (j < n && in_run(j, i, id)) ++j;
      spans.push_back({i, j});
      i = j;
    }
  } else {
    result.method = SegmentationMethod::automatic;
    spans.push_back({0, n});
  }

  // Each marked span's parts and runs depend on no other span's: worked out side by side, then
  // checked in span order below, so that the first problem in file order is the one reported.
  struct SpanRuns {
    std::vector<Span> parts;
    std::vector<Run> runs;
    std::exception_ptr error;
  };
  std::vector<SpanRuns> worked(result.method == SegmentationMethod::marker ? spans.size() : 0);
  if (!worked.empty()) {
    const unsigned threads = thread_count(
        ThreadCountRequest{.asked = options.threads, .work = n, .min_work = std::size_t{1} << 16});
    run_tasks(spans.size(), threads, [&](std::size_t k) {
      const Span& s = spans[k];
      if (s.end - s.begin < options.min_points) return;  // refused below
      try {
        const Circle centre = detail::with_rows_context(
            trace, s.begin, s.end, "marked span", [&] { return centre_of(a, b, s, options); });
        worked[k].parts = split_at_reversals(a, b, s, centre, options.min_points);
        for (const Span& part : worked[k].parts)
          worked[k].runs.push_back(make_run(a, b, part, centre));
      } catch (...) {
        worked[k].error = std::current_exception();
      }
    });
  }

  for (std::size_t k = 0; k < spans.size(); ++k) {
    const Span& s = spans[k];
    if (result.method == SegmentationMethod::marker) {
      const std::size_t number = result.runs.size() + 1;
      if (s.end - s.begin < options.min_points) {
        throw DataError(
            trace.source, line(s.begin),
            fmt::format("run {} (lines {}-{}): too few points ({}), expected at least {}", number,
                        line(s.begin), line(s.end - 1), s.end - s.begin, options.min_points));
      }
      if (worked[k].error) std::rethrow_exception(worked[k].error);
      const std::vector<Span>& parts = worked[k].parts;
      std::vector<Run> runs;
      for (std::size_t p = 0; p < parts.size(); ++p) {
        const Span& part = parts[p];
        const std::size_t no = result.runs.size() + runs.size() + 1;
        Run r = worked[k].runs[p];
        r.segment_id = seg_id(s.begin);
        if (r.sweep_deg < options.min_sweep_deg || part.end - part.begin < options.min_points) {
          throw DataError(
              trace.source, line(part.begin),
              fmt::format("run {} (lines {}-{}) sweeps {:.1f} deg{}: expected an arc of at "
                          "least {:.0f} deg (ISO 230-4 clause 3.1)",
                          no, line(part.begin), line(part.end - 1), r.sweep_deg,
                          parts.size() > 1 ? fmt::format(" (its marked span, lines {}-{}, "
                                                         "reverses there)",
                                                         line(s.begin), line(s.end - 1))
                                           : std::string(),
                          options.min_sweep_deg));
        }
        runs.push_back(r);
      }
      if (runs.size() > 1) {
        std::string turns;
        for (std::size_t t = 1; t < parts.size(); ++t) {
          turns += fmt::format("{}{}", t > 1 ? ", " : "", line(parts[t - 1].end - 1));
        }
        std::string sweeps;
        for (const Run& r : runs) {
          sweeps += fmt::format("{}{} {:.1f} deg", sweeps.empty() ? "" : ", ",
                                direction_name(r.direction), r.sweep_deg);
        }
        result.notes.push_back(
            fmt::format("marked span lines {}-{} holds both directions: split where the "
                        "rotation reverses (at line {}) into {} runs: {}",
                        line(s.begin), line(s.end - 1), turns, runs.size(), sweeps));
      }
      result.runs.insert(result.runs.end(), runs.begin(), runs.end());
    } else {
      for (Run r : automatic_runs(trace, a, b, s, options)) {
        r.segment_id = seg_id(r.begin);
        result.runs.push_back(r);
      }
    }
  }
  if (result.runs.empty()) {
    throw DataError(trace.source, 0,
                    fmt::format("no run found ({} segmentation): expected a circular arc of at "
                                "least {:.0f} deg with at least {} points",
                                segmentation_method_name(result.method), options.min_sweep_deg,
                                options.min_points));
  }
  return result;
}

}  // namespace circtest
