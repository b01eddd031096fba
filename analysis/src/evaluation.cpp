#include "circtest/analysis/evaluation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"

namespace circtest {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kRadToDeg = 180.0 / kPi;

std::span<const double> slice(const std::vector<double>& v, const Run& r) {
  return {v.data() + r.begin, r.size()};
}

// "x,y,z" metadata -> the plane's two coordinates.
std::optional<PlanePoint> metadata_centre(const Trace& trace, Plane plane) {
  const std::string* v = trace.metadata.find("centre_mm");
  if (!v) return std::nullopt;
  std::vector<double> xyz;
  std::size_t pos = 0;
  while (pos <= v->size()) {
    const std::size_t comma = std::min(v->find(',', pos), v->size());
    const auto number = parse_finite(std::string_view(*v).substr(pos, comma - pos));
    if (!number) break;
    xyz.push_back(*number);
    pos = comma + 1;
  }
  if (xyz.size() != 3 || pos <= v->size()) {
    throw ParseError(
        trace.source, trace.metadata.line_of("centre_mm"),
        fmt::format("metadata 'centre_mm': expected three numbers x,y,z, got '{}'", *v));
  }
  const PlaneAxes axes = plane_axes(plane);
  return PlanePoint{xyz[static_cast<std::size_t>(axes.first - 'x')],
                    xyz[static_cast<std::size_t>(axes.second - 'x')]};
}

struct AngleRadius {
  std::vector<double> angle;  // increasing, unwrapped, starting in [-pi, pi)
  std::vector<double> radius;
};

AngleRadius polar(std::span<const double> a, std::span<const double> b, double ca, double cb) {
  AngleRadius p;
  const std::size_t n = a.size();
  p.angle.resize(n);
  p.radius.resize(n);
  double prev = 0.0;
  double offset = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double da = a[i] - ca, db = b[i] - cb;
    double ang = std::atan2(db, da);
    if (i > 0) {
      // Unwrap along the path: successive samples are far less than pi apart.
      double step = ang + offset - prev;
      while (step > kPi) {
        offset -= 2 * kPi;
        step -= 2 * kPi;
      }
      while (step < -kPi) {
        offset += 2 * kPi;
        step += 2 * kPi;
      }
    }
    p.angle[i] = ang + offset;
    p.radius[i] = std::hypot(da, db);
    prev = p.angle[i];
  }
  if (n > 1 && p.angle.back() < p.angle.front()) {
    std::reverse(p.angle.begin(), p.angle.end());
    std::reverse(p.radius.begin(), p.radius.end());
  }
  if (!std::is_sorted(p.angle.begin(), p.angle.end())) {
    // A path that backs up locally (noise at a reversal): order by angle.
    std::vector<std::size_t> idx(n);
    std::iota(idx.begin(), idx.end(), 0);
    std::stable_sort(idx.begin(), idx.end(),
                     [&](std::size_t i, std::size_t j) { return p.angle[i] < p.angle[j]; });
    AngleRadius q;
    q.angle.resize(n);
    q.radius.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      q.angle[i] = p.angle[idx[i]];
      q.radius[i] = p.radius[idx[i]];
    }
    p = std::move(q);
  }
  return p;
}

struct OneWay {
  double max = -1.0;
  double at = 0.0;
  double lo = 0.0, hi = 0.0;
  bool any = false;
};

// Samples of `from` against the interpolated radius of `ref` at the same angle.
OneWay compare(const AngleRadius& ref, const AngleRadius& from) {
  OneWay w;
  if (ref.angle.size() < 2) return w;
  const double a0 = ref.angle.front();
  const double a1 = ref.angle.back();
  for (std::size_t i = 0; i < from.angle.size(); ++i) {
    double phi = from.angle[i];
    phi = a0 + std::fmod(std::fmod(phi - a0, 2 * kPi) + 2 * kPi, 2 * kPi);
    if (phi > a1) continue;  // outside the reference arc
    auto it = std::upper_bound(ref.angle.begin(), ref.angle.end(), phi);
    std::size_t j = static_cast<std::size_t>(it - ref.angle.begin());
    if (j == 0) j = 1;
    if (j >= ref.angle.size()) j = ref.angle.size() - 1;
    const double x0 = ref.angle[j - 1], x1 = ref.angle[j];
    const double t = x1 > x0 ? (phi - x0) / (x1 - x0) : 0.0;
    const double r = ref.radius[j - 1] + t * (ref.radius[j] - ref.radius[j - 1]);
    const double d = std::abs(from.radius[i] - r);
    if (!w.any) {
      w.lo = w.hi = phi;
      w.any = true;
    }
    w.lo = std::min(w.lo, phi);
    w.hi = std::max(w.hi, phi);
    if (d > w.max) {
      w.max = d;
      w.at = phi;
    }
  }
  return w;
}

double wrap_deg(double rad) {
  double d = std::fmod(rad * kRadToDeg, 360.0);
  if (d < 0) d += 360.0;
  return d;
}

}  // namespace

double Temperatures::radius_factor() const {
  double f = 1.0;
  if (instrument_C) f += instrument_expansion_per_K * (*instrument_C - 20.0);
  if (machine_C) f -= machine_expansion_per_K * (*machine_C - 20.0);
  return f;
}

RadialDifference max_radial_difference(std::span<const double> a1, std::span<const double> b1,
                                       std::span<const double> a2, std::span<const double> b2,
                                       double centre_a_mm, double centre_b_mm) {
  const AngleRadius p1 = polar(a1, b1, centre_a_mm, centre_b_mm);
  const AngleRadius p2 = polar(a2, b2, centre_a_mm, centre_b_mm);
  const OneWay w12 = compare(p1, p2);
  const OneWay w21 = compare(p2, p1);
  RadialDifference out;
  if (!w12.any && !w21.any) return out;
  const OneWay& best = w12.max >= w21.max ? w12 : w21;
  out.max_mm = std::max(0.0, best.max);
  out.at_angle_deg = wrap_deg(best.at);
  const double o12 = w12.any ? w12.hi - w12.lo : 0.0;
  const double o21 = w21.any ? w21.hi - w21.lo : 0.0;
  out.overlap_deg = std::max(o12, o21) * kRadToDeg;
  return out;
}

Evaluation evaluate(const Trace& trace, EvaluationOptions options) {
  Evaluation ev;
  ev.source = trace.source;
  ev.conditions = trace.metadata;
  for (const auto& [key, value] : options.conditions) ev.conditions.set(key, value);
  ev.g_method = options.g_method;

  // Plane: the option, else metadata, else XY.
  if (options.plane) {
    ev.plane = *options.plane;
  } else if (const std::string* p = trace.metadata.find("plane")) {
    const auto parsed = parse_plane(*p);
    if (!parsed) {
      throw ParseError(trace.source, trace.metadata.line_of("plane"),
                       fmt::format("metadata 'plane': expected XY, YZ or ZX, got '{}'", *p));
    }
    ev.plane = *parsed;
  }

  const PlaneColumns cols = plane_columns(trace, ev.plane, options.column_a, options.column_b);
  ev.columns = cols;
  ev.channel_a = trace.columns[static_cast<std::size_t>(cols.a)];
  ev.channel_b = trace.columns[static_cast<std::size_t>(cols.b)];
  const auto& col_a = trace.values[static_cast<std::size_t>(cols.a)];
  const auto& col_b = trace.values[static_cast<std::size_t>(cols.b)];

  // Nominal radius and centre: options, then metadata, then the commanded path.
  if (options.nominal_radius_mm) {
    ev.nominal_radius_mm = options.nominal_radius_mm;
    ev.nominal_radius_source = "option";
  } else if (auto r = trace.metadata.number("radius_mm", trace.source)) {
    ev.nominal_radius_mm = r;
    ev.nominal_radius_source = "metadata";
  } else if (auto d = trace.metadata.number("diameter_mm", trace.source)) {
    ev.nominal_radius_mm = *d / 2.0;
    ev.nominal_radius_source = "metadata";
  }
  if (options.centre) {
    ev.centre = options.centre;
    ev.centre_source = "option";
  } else if (auto c = metadata_centre(trace, ev.plane)) {
    ev.centre = c;
    ev.centre_source = "metadata";
  }
  if (ev.nominal_radius_mm && *ev.nominal_radius_mm <= 0.0) {
    throw UsageError(fmt::format("nominal radius must be positive, got {}", *ev.nominal_radius_mm));
  }

  ev.temperatures = options.temperatures;
  auto meta_temp = [&](const char* key, std::optional<double>& dst) {
    if (!dst) dst = trace.metadata.number(key, trace.source);
  };
  meta_temp("temperature_machine_C", ev.temperatures.machine_C);
  meta_temp("temperature_instrument_C", ev.temperatures.instrument_C);
  if (auto v = trace.metadata.number("expansion_machine_per_K", trace.source)) {
    ev.temperatures.machine_expansion_per_K = *v;
  }
  if (auto v = trace.metadata.number("expansion_instrument_per_K", trace.source)) {
    ev.temperatures.instrument_expansion_per_K = *v;
  }
  ev.temperature_factor = ev.temperatures.radius_factor();

  SegmentationOptions so;
  so.centre = ev.centre;
  so.radius_mm = ev.nominal_radius_mm;
  so.min_sweep_deg = options.min_arc_deg;
  const Segmentation seg = segment_trace(trace, cols, so);
  ev.segmentation = seg.method;

  // Commanded columns give the nominal circle when nothing else did.
  const std::vector<double>* cmd_a =
      trace.column(fmt::format("{}_cmd", plane_axes(ev.plane).first));
  const std::vector<double>* cmd_b =
      trace.column(fmt::format("{}_cmd", plane_axes(ev.plane).second));
  if ((!ev.nominal_radius_mm || !ev.centre) && cmd_a && cmd_b) {
    const Run& r0 = seg.runs.front();
    if (r0.size() >= 3) {
      const Circle c = fit_lsc(slice(*cmd_a, r0), slice(*cmd_b, r0));
      if (!ev.nominal_radius_mm) {
        ev.nominal_radius_mm = c.radius_mm;
        ev.nominal_radius_source = "commanded";
      }
      if (!ev.centre) {
        ev.centre = PlanePoint{c.centre_a_mm, c.centre_b_mm};
        ev.centre_source = "commanded";
      }
    }
  }
  if (!ev.nominal_radius_mm) {
    ev.notes.push_back(
        "F not computed: no nominal radius (give --radius, a radius_mm metadata line, or "
        "commanded columns)");
  }

  const std::vector<double>* t = trace.column("t");
  for (const Run& run : seg.runs) {
    RunResult rr;
    rr.run = run;
    rr.label = direction_label(ev.plane, run.direction);
    rr.first_line = trace.line_of_row[run.begin];
    rr.last_line = trace.line_of_row[run.end - 1];
    const auto a = slice(col_a, run);
    const auto b = slice(col_b, run);
    rr.lsc = fit_lsc(a, b);
    rr.mzc = fit_mzc(a, b);
    rr.g_mzc_mm = rr.mzc.zone_width_mm;
    const RadialRange about_lsc = radial_range(a, b, rr.lsc.centre_a_mm, rr.lsc.centre_b_mm);
    rr.g_lsc_mm = about_lsc.width_mm();
    if (t && run.size() > 1) {
      const double dt = (*t)[run.end - 1] - (*t)[run.begin];
      if (dt > 0) rr.feed_mm_per_min = run.sweep_deg / kRadToDeg * rr.lsc.radius_mm / dt * 60.0;
    }

    const bool full = run.sweep_deg >= 359.0;
    bool use_lsc = false;
    switch (options.f_centre) {
      case FCentre::automatic:
        use_lsc = full || !ev.centre;
        break;
      case FCentre::lsc:
        use_lsc = true;
        break;
      case FCentre::nominal:
        if (!ev.centre) {
          throw UsageError(
              "--f-centre nominal needs the set-up centre: give --centre A,B or a centre_mm "
              "metadata line");
        }
        break;
    }
    if (use_lsc && !full) {
      ev.notes.push_back(fmt::format(
          "run {} sweeps {:.1f} deg: F about the LSC centre of a partial arc is not an ISO "
          "230-4 method (3.5 b needs a full circle); give the set-up centre with --centre",
          ev.runs.size() + 1, run.sweep_deg));
    }
    rr.f_centre_method = use_lsc ? "lsc" : "nominal";
    rr.f_centre = use_lsc ? PlanePoint{rr.lsc.centre_a_mm, rr.lsc.centre_b_mm} : *ev.centre;
    if (ev.nominal_radius_mm) {
      // About the LSC centre the range is the one G_lsc already took.
      const RadialRange rng =
          use_lsc ? about_lsc : radial_range(a, b, rr.f_centre.a_mm, rr.f_centre.b_mm);
      rr.f_max_mm = rng.max_mm * ev.temperature_factor - *ev.nominal_radius_mm;
      rr.f_min_mm = rng.min_mm * ev.temperature_factor - *ev.nominal_radius_mm;
    }
    ev.runs.push_back(std::move(rr));
  }

  // H: adjacent runs of opposite direction, measured one right after the other (clause 5).
  for (std::size_t i = 0; i + 1 < ev.runs.size();) {
    const RunResult& r1 = ev.runs[i];
    const RunResult& r2 = ev.runs[i + 1];
    if (r1.run.direction == r2.run.direction) {
      ++i;
      continue;
    }
    HysteresisResult h;
    h.run_ccw = r1.run.direction == Direction::CCW ? i : i + 1;
    h.run_cw = r1.run.direction == Direction::CCW ? i + 1 : i;
    std::vector<double> ja, jb;
    ja.reserve(r1.run.size() + r2.run.size());
    jb.reserve(ja.capacity());
    for (const RunResult* r : {&r1, &r2}) {
      const auto a = slice(col_a, r->run);
      const auto b = slice(col_b, r->run);
      ja.insert(ja.end(), a.begin(), a.end());
      jb.insert(jb.end(), b.begin(), b.end());
    }
    h.common_lsc = fit_lsc(ja, jb);
    const RadialDifference d = max_radial_difference(
        slice(col_a, r1.run), slice(col_b, r1.run), slice(col_a, r2.run), slice(col_b, r2.run),
        h.common_lsc.centre_a_mm, h.common_lsc.centre_b_mm);
    h.h_mm = d.max_mm;
    h.at_angle_deg = d.at_angle_deg;
    h.overlap_deg = d.overlap_deg;
    ev.hysteresis.push_back(h);
    i += 2;
  }
  if (ev.hysteresis.empty()) {
    ev.notes.push_back("H not computed: no CCW run followed by a CW run (or the reverse)");
  }
  return ev;
}

}  // namespace circtest
