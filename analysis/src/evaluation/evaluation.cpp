#include "circtest/analysis/evaluation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <numbers>
#include <numeric>

#include "angle_constants.hpp"
#include "budget_inputs.hpp"
#include "circtest/analysis/radial.hpp"
#include "circtest/analysis/remedy.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/parallel.hpp"
#include "circtest/core/trace_keys.hpp"
#include "radial_profile.hpp"
#include "rows_context.hpp"
#include "user_units.hpp"

namespace circtest {

namespace {

using evaluation_detail::kRadToDeg;
constexpr double kMaxFeedMmPerMin = 1e6;  // as the feed_mm_per_min metadata is checked

std::span<const double> slice(const std::vector<double>& v, const Run& r) {
  return {v.data() + r.begin, r.size()};
}

}  // namespace

std::string_view value_source_name(ValueSource source) noexcept {
  switch (source) {
    case ValueSource::option:
      return "option";
    case ValueSource::metadata:
      return "metadata";
    case ValueSource::commanded:
      return "commanded";
    case ValueSource::none:
      break;
  }
  return "";
}

std::optional<ValueSource> parse_value_source(std::string_view name) {
  for (ValueSource s :
       {ValueSource::none, ValueSource::option, ValueSource::metadata, ValueSource::commanded}) {
    if (name == value_source_name(s)) return s;
  }
  return std::nullopt;
}

std::string_view f_centre_method_name(FCentreMethod method) noexcept {
  return method == FCentreMethod::lsc ? "lsc" : "nominal";
}

std::optional<FCentreMethod> parse_f_centre_method(std::string_view name) {
  if (name == "lsc") return FCentreMethod::lsc;
  if (name == "nominal") return FCentreMethod::nominal;
  return std::nullopt;
}

std::optional<PlanePoint> metadata_centre(const Trace& trace, Plane plane) {
  // Recorded positions are LinuxCNC's joint positions, in machine coordinates: the centre there
  // (centre_machine_mm, stated by circgen when it knows the work offset's origin) is the one
  // they circle about; centre_mm is in the program's work offset.
  const char* key = trace.metadata.find(meta_key::centre_machine_mm) != nullptr
                        ? meta_key::centre_machine_mm
                        : meta_key::centre_mm;
  const std::string* v = trace.metadata.find(key);
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
    throw ParseError(trace.source, trace.metadata.line_of(key),
                     fmt::format("metadata '{}': expected three numbers x,y,z, got '{}'", key, *v));
  }
  const PlaneAxes axes = plane_axes(plane);
  return PlanePoint{xyz[static_cast<std::size_t>(axes.first - 'x')],
                    xyz[static_cast<std::size_t>(axes.second - 'x')]};
}

double Temperatures::radius_factor() const {
  double f = 1.0;
  if (instrument_C) f += instrument_expansion_per_K * (*instrument_C - 20.0);
  if (machine_C) f -= machine_expansion_per_K * (*machine_C - 20.0);
  return f;
}

namespace {

// Set-up resolution: plane, columns, nominal radius and centre, temperatures. Options win,
// then the trace's metadata; the commanded path fills the rest once the runs are known.
void resolve_set_up(const Trace& trace, const EvaluationOptions& options, Evaluation& ev) {
  ev.plane = trace_plane(trace, options.plane);

  ev.columns = plane_columns(trace, ev.plane, options.column_a, options.column_b);
  ev.channel_a = trace.columns[ev.columns.a];
  ev.channel_b = trace.columns[ev.columns.b];

  if (options.nominal_radius_mm) {
    ev.nominal_radius_mm = options.nominal_radius_mm;
    ev.nominal_radius_source = ValueSource::option;
  } else if (auto r = trace.metadata.number(meta_key::radius_mm, trace.source)) {
    ev.nominal_radius_mm = r;
    ev.nominal_radius_source = ValueSource::metadata;
  } else if (auto d = trace.metadata.number(meta_key::diameter_mm, trace.source)) {
    ev.nominal_radius_mm = *d / 2.0;
    ev.nominal_radius_source = ValueSource::metadata;
  }
  if (options.centre) {
    ev.centre = options.centre;
    ev.centre_source = ValueSource::option;
  } else if (auto c = metadata_centre(trace, ev.plane)) {
    ev.centre = c;
    ev.centre_source = ValueSource::metadata;
  }
  if (ev.nominal_radius_mm && *ev.nominal_radius_mm <= 0.0) {
    throw UsageError(fmt::format("nominal radius must be positive, got {}", *ev.nominal_radius_mm));
  }

  ev.temperatures = options.temperatures;
  // Recorded over the test (a column, or the key at the start and at the end): F is corrected
  // at the mean; recorded once: at that value.
  auto meta_temp = [&](const char* key, std::optional<double>& dst) {
    if (dst) return;
    if (const auto series = detail::temperature_series(trace, key)) {
      dst = series->mean_C;
    } else {
      dst = trace.metadata.number(key, trace.source);
    }
  };
  meta_temp(meta_key::temperature_machine_C, ev.temperatures.machine_C);
  meta_temp(meta_key::temperature_instrument_C, ev.temperatures.instrument_C);
  if (auto v = trace.metadata.number(meta_key::expansion_machine_per_K, trace.source)) {
    ev.temperatures.machine_expansion_per_K = *v;
  }
  if (auto v = trace.metadata.number(meta_key::expansion_instrument_per_K, trace.source)) {
    ev.temperatures.instrument_expansion_per_K = *v;
  }
  ev.temperature_factor = ev.temperatures.radius_factor();
}

using detail::with_rows_context;

// The commanded columns of the first run give the nominal circle when nothing else did.
void resolve_from_commanded(const Trace& trace, const Segmentation& seg, RemedyWords words,
                            Evaluation& ev) {
  const std::vector<double>* cmd_a =
      trace.column(column_name::commanded(plane_axes(ev.plane).first));
  const std::vector<double>* cmd_b =
      trace.column(column_name::commanded(plane_axes(ev.plane).second));
  if ((!ev.nominal_radius_mm || !ev.centre) && cmd_a && cmd_b) {
    const Run& r0 = seg.runs.front();
    if (r0.size() >= 3) {
      const Circle c = with_rows_context(trace, r0.begin, r0.end, "commanded circle of run 1", [&] {
        return fit_lsc(slice(*cmd_a, r0), slice(*cmd_b, r0));
      });
      if (!ev.nominal_radius_mm) {
        ev.nominal_radius_mm = c.radius_mm;
        ev.nominal_radius_source = ValueSource::commanded;
      }
      if (!ev.centre) {
        ev.centre = PlanePoint{c.centre_a_mm, c.centre_b_mm};
        ev.centre_source = ValueSource::commanded;
      }
    }
  }
  if (!ev.nominal_radius_mm) {
    ev.notes.push_back(
        fmt::format("F not computed: no nominal radius (give {}, a radius_mm metadata line, or "
                    "commanded columns)",
                    words(Remedy::give_radius)));
  }
}

// Clause 3: G and F of one run (and its LSC, MZC and feed).
RunResult evaluate_run(const Trace& trace, const Evaluation& ev, std::size_t number, const Run& run,
                       FCentre f_centre, RemedyWords words, std::vector<std::string>& notes) {
  const auto& col_a = trace.values[ev.columns.a];
  const auto& col_b = trace.values[ev.columns.b];
  RunResult rr;
  rr.run = run;
  rr.label = direction_label(ev.plane, run.direction);
  rr.first_line = trace.line_of_row[run.begin];
  rr.last_line = trace.line_of_row[run.end - 1];
  const auto a = slice(col_a, run);
  const auto b = slice(col_b, run);
  rr.lsc = fit_lsc(a, b);
  // One glitched row would set the minimum zone: named, not evaluated.
  check_outliers(trace, number, run, a, b, rr.lsc);
  rr.mzc = fit_mzc(a, b);
  rr.g_mzc_mm = rr.mzc.zone_width_mm;
  const RadialRange about_lsc = radial_range(a, b, rr.lsc.centre_a_mm, rr.lsc.centre_b_mm);
  rr.g_lsc_mm = about_lsc.width_mm();
  if (const std::vector<double>* t = trace.column(column_name::t); t && run.size() > 1) {
    const double dt = (*t)[run.end - 1] - (*t)[run.begin];
    if (dt > 0) rr.feed_mm_per_min = run.sweep_deg / kRadToDeg * rr.lsc.radius_mm / dt * 60.0;
    // The bound of feed_mm_per_min metadata: a time column that makes the run faster than any
    // machine does not belong to its motion, and the diagnosis would take its servo terms from
    // it. The feed is then not measured.
    if (rr.feed_mm_per_min && !(*rr.feed_mm_per_min <= kMaxFeedMmPerMin)) {
      const bool inch = detail::trace_in_inch(trace);
      notes.push_back(fmt::format(
          "run {} (lines {}-{}): feed not measurable: its time column gives {} (t "
          "from {:g} to {:g} s), above any machine's {}",
          number, rr.first_line, rr.last_line, detail::user_feed(*rr.feed_mm_per_min, inch),
          (*t)[run.begin], (*t)[run.end - 1],
          inch ? detail::user_feed(kMaxFeedMmPerMin, true)
               : fmt::format("{:.0f}", kMaxFeedMmPerMin)));
      rr.feed_mm_per_min.reset();
    }
  }

  const bool full = run.sweep_deg >= 359.0;
  bool use_lsc = false;
  switch (f_centre) {
    case FCentre::automatic:
      use_lsc = full || !ev.centre;
      break;
    case FCentre::lsc:
      use_lsc = true;
      break;
    case FCentre::nominal:
      if (!ev.centre) {
        throw UsageError(
            fmt::format("{} needs the set-up centre: give {} A,B or a centre_mm metadata line",
                        words(Remedy::f_about_nominal), words(Remedy::give_centre)));
      }
      break;
  }
  if (use_lsc && !full) {
    notes.push_back(fmt::format(
        "run {} sweeps {:.1f} deg: F about the LSC centre of a partial arc is not an ISO "
        "230-4 method (3.5 b needs a full circle); give the set-up centre with {}",
        number, run.sweep_deg, words(Remedy::give_centre)));
  }
  rr.f_centre_method = use_lsc ? FCentreMethod::lsc : FCentreMethod::nominal;
  rr.f_centre = use_lsc ? PlanePoint{rr.lsc.centre_a_mm, rr.lsc.centre_b_mm} : *ev.centre;
  if (ev.nominal_radius_mm) {
    // About the LSC centre the range is the one G_lsc already took.
    const RadialRange rng =
        use_lsc ? about_lsc : radial_range(a, b, rr.f_centre.a_mm, rr.f_centre.b_mm);
    rr.f_max_mm = rng.max_mm * ev.temperature_factor - *ev.nominal_radius_mm;
    rr.f_min_mm = rng.min_mm * ev.temperature_factor - *ev.nominal_radius_mm;
  }
  return rr;
}

// H pairing (clause 5): adjacent runs of opposite direction, measured one right after the
// other; the index of each pair's first run.
std::vector<std::size_t> hysteresis_pairs(const std::vector<Run>& runs) {
  std::vector<std::size_t> firsts;
  for (std::size_t i = 0; i + 1 < runs.size();) {
    if (runs[i].direction == runs[i + 1].direction) {
      ++i;
      continue;
    }
    firsts.push_back(i);
    i += 2;
  }
  return firsts;
}

// Below this many samples in all, the runs are evaluated on the calling thread alone: a
// thread costs more than it saves (and the fuzzers stay single-threaded).
constexpr std::size_t kParallelMinSamples = std::size_t{1} << 16;

}  // namespace

Evaluation evaluate(const Trace& trace, const EvaluationOptions& options) {
  Evaluation ev;
  ev.source = trace.source;
  ev.conditions = trace.metadata;
  for (const auto& [key, value] : options.conditions) ev.conditions.set(key, value);
  ev.g_method = options.g_method;
  ev.uncertainty_options = options.uncertainty;
  resolve_set_up(trace, options, ev);
  check_plane_motion(trace, ev.plane, ev.columns, options.input_checks.remedy_words,
                     ev.nominal_radius_mm);

  SegmentationOptions so;
  so.centre = ev.centre;
  so.radius_mm = ev.nominal_radius_mm;
  so.min_sweep_deg = options.min_arc_deg;
  so.threads = options.threads;
  const Segmentation seg = segment_trace(trace, ev.columns, so);
  ev.segmentation = seg.method;
  ev.notes.insert(ev.notes.end(), seg.notes.begin(), seg.notes.end());
  resolve_from_commanded(trace, seg, options.input_checks.remedy_words, ev);
  for (auto note : {check_announced_runs(trace, seg.runs, options.input_checks),
                    check_time_column(trace, seg.runs, options.input_checks)}) {
    if (note) ev.notes.push_back(*note);
  }

  // Each run's results, and each H pair's common circle and profiles, depend on no other
  // run's: they are worked out side by side, then gathered in run order.
  const std::vector<Run>& runs = seg.runs;
  const std::vector<std::size_t> pairs = hysteresis_pairs(runs);
  std::size_t samples = 0;
  for (const Run& run : runs) samples += run.size();
  const unsigned threads = thread_count(ThreadCountRequest{
      .asked = options.threads, .work = samples, .min_work = kParallelMinSamples});
  const auto& col_a = trace.values[ev.columns.a];
  const auto& col_b = trace.values[ev.columns.b];

  // Without arc_deg the longest run the program marked stands for the arc it ran (runs found
  // automatically are the circle's stretches, not the program's runs).
  std::optional<double> longest_sweep_deg;
  if (runs.size() >= 2 && seg.method != SegmentationMethod::automatic) {
    for (const Run& run : runs) {
      if (std::isfinite(run.sweep_deg)) {
        longest_sweep_deg = std::max(longest_sweep_deg.value_or(0.0), run.sweep_deg);
      }
    }
  }
  std::vector<RunResult> results(runs.size());
  std::vector<std::vector<std::string>> run_notes(runs.size());
  std::vector<Circle> common(pairs.size());
  std::vector<std::exception_ptr> common_error(pairs.size());
  // H's circles: the LSC of both runs of each pair together, each pass over the points shared
  // out over the threads (a third task beside the runs' two would leave one core idle while it
  // ran).
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    const Run& r1 = runs[pairs[p]];
    const Run& r2 = runs[pairs[p] + 1];
    // Each run's own fit passes or fails below, so this one refuses only what a joint fit adds
    // (none known); a refusal of a run's is reported first, as the run's own.
    try {
      common[p] = with_rows_context(
          trace, r1.begin, r2.end,
          fmt::format("common circle of runs {} and {} (H)", pairs[p] + 1, pairs[p] + 2), [&] {
            return fit_lsc(slice(col_a, r1), slice(col_b, r1), slice(col_a, r2), slice(col_b, r2),
                           threads);
          });
    } catch (...) {
      common_error[p] = std::current_exception();
    }
  }
  run_tasks(runs.size(), threads, [&](std::size_t k) {
    const Run& run = runs[k];
    const std::size_t number = k + 1;
    std::vector<std::string>& notes = run_notes[k];
    for (auto note :
         {check_run_arc(trace, number, run, options.input_checks, longest_sweep_deg),
          check_off_plane(trace, ev.plane, ev.columns, number, run, options.input_checks)}) {
      if (note) notes.push_back(*note);
    }
    RunResult rr = with_rows_context(trace, run.begin, run.end, fmt::format("run {}", number), [&] {
      return evaluate_run(trace, ev, number, run, options.f_centre,
                          options.input_checks.remedy_words, notes);
    });
    if (ev.nominal_radius_mm) {
      if (auto note = check_nominal_radius(
              trace, number, run, rr.lsc.radius_mm * ev.temperature_factor, *ev.nominal_radius_mm,
              std::string(value_source_name(ev.nominal_radius_source)), options.input_checks)) {
        notes.push_back(*note);
      }
    }
    results[k] = std::move(rr);
  });
  for (const std::exception_ptr& e : common_error) {
    if (e) std::rethrow_exception(e);
  }
  for (std::size_t k = 0; k < runs.size(); ++k) {
    ev.notes.insert(ev.notes.end(), run_notes[k].begin(), run_notes[k].end());
    ev.runs.push_back(std::move(results[k]));
  }

  // Clause 5: H of each pair, both runs' radii about their common centre.
  std::vector<detail::RadialProfile> profiles(2 * pairs.size());
  run_tasks(profiles.size(), threads, [&](std::size_t k) {
    const Run& run = runs[pairs[k / 2] + k % 2];
    const Circle& c = common[k / 2];
    profiles[k] = detail::radial_profile(slice(col_a, run), slice(col_b, run),
                                         PlanePoint{c.centre_a_mm, c.centre_b_mm});
  });
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    const std::size_t first = pairs[p];
    HysteresisResult h;
    const bool ccw_first = runs[first].direction == Direction::CCW;
    h.run_ccw = ccw_first ? first : first + 1;
    h.run_cw = ccw_first ? first + 1 : first;
    h.common_lsc = common[p];
    const RadialDifference d =
        detail::radial_difference(profiles[2 * p], profiles[2 * p + 1], threads);
    h.h_mm = d.max_mm;
    h.at_angle_deg = d.at_angle_deg;
    h.overlap_deg = d.overlap_deg;
    // H compares the two runs where both went: on a sliver of shared arc (or none, where it
    // read 0.0 um) it says nothing about the machine.
    if (!(h.overlap_deg >= options.min_arc_deg)) {
      ev.notes.push_back(fmt::format(
          "H of runs {} and {} not measurable: they share {:.1f} deg of arc, needs {:.0f} deg",
          first + 1, first + 2, h.overlap_deg, options.min_arc_deg));
      continue;
    }
    ev.hysteresis.push_back(h);
  }
  if (pairs.empty()) {
    ev.notes.push_back("H not computed: no CCW run followed by a CW run (or the reverse)");
  }
  ev.budget_inputs = detail::measure_budget_inputs(trace, ev);
  return ev;
}

}  // namespace circtest
