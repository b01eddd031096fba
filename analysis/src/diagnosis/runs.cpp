// The diagnosis's first stages: what the trace is, and its runs turned into samples about the
// linearisation point.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <span>

#include "../evaluation/radial_profile.hpp"
#include "../evaluation/rows_context.hpp"
#include "circtest/analysis/input_checks.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/memory.hpp"
#include "circtest/core/trace_keys.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

// The linearisation point: the nominal circle, else the least-squares circle of all runs.
void linearisation_point(const Inputs& in, const TraceDescription& td, SampleSet& ss,
                         Diagnosis& D) {
  const Trace& trace = in.trace;
  const Evaluation& ev = in.ev;
  double& ca = ss.ca;
  double& cb = ss.cb;
  double& R = ss.R;
  const auto& col_a = td.col_a;
  const auto& col_b = td.col_b;
  if (ev.centre && ev.nominal_radius_mm) {
    ca = ev.centre->a_mm;
    cb = ev.centre->b_mm;
    R = *ev.nominal_radius_mm;
  } else {
    std::vector<double> xa, xb;
    for (const auto& r : ev.runs) {
      xa.insert(xa.end(), col_a.begin() + static_cast<std::ptrdiff_t>(r.run.begin),
                col_a.begin() + static_cast<std::ptrdiff_t>(r.run.end));
      xb.insert(xb.end(), col_b.begin() + static_cast<std::ptrdiff_t>(r.run.begin),
                col_b.begin() + static_cast<std::ptrdiff_t>(r.run.end));
    }
    const Circle all =
        detail::with_rows_context(trace, ev.runs.front().run.begin, ev.runs.back().run.end,
                                  "the runs together", [&] { return fit_lsc(xa, xb); });
    ca = ev.centre ? ev.centre->a_mm : all.centre_a_mm;
    cb = ev.centre ? ev.centre->b_mm : all.centre_b_mm;
    R = ev.nominal_radius_mm.value_or(all.radius_mm);
    if (!ev.nominal_radius_mm) {
      D.notes.push_back(
          "no nominal radius: deviations are taken from the least-squares radius, so the "
          "radius change and absolute scale are not available");
    }
  }
}

// The sample arrays reserved for all runs.
void reserve_samples(const Evaluation& ev, Samples& S) {
  std::size_t total = 0;
  for (const RunResult& rr : ev.runs) total += rr.run.size();
  // Side by side: mapping in these fresh pages (27 MB on the benchmark trace) costs more
  // than filling them.
  std::vector<double>* arrays[] = {&S.c, &S.s, &S.dr, &S.u};
  for_each_task(5, [&](std::size_t k) {
    if (k < 4) {
      reserve_huge(*arrays[k], total);
    } else {
      reserve_huge(S.run, total);
    }
  });
}

// The runs' bookkeeping in order: their range of the samples, direction, speed, feed group and
// sample period in angle.
void run_bookkeeping(const Inputs& in, SampleSet& ss, const std::optional<double>& meta_feed) {
  const std::vector<Run> runs = [&in] {
    std::vector<Run> r;
    for (const RunResult& rr : in.ev.runs) r.push_back(rr.run);
    return r;
  }();
  // Each run's feed: measured (the time column), else as the program announced it, else the
  // trace's one feed.
  const std::vector<std::optional<double>> announced = announced_run_feeds(in.trace, runs);
  const Trace& trace = in.trace;
  const Evaluation& ev = in.ev;
  Samples& S = ss.S;
  std::vector<double>& group_feed = ss.group_feed;
  bool& speed_known = ss.speed_known;
  bool& have_ccw = ss.have_ccw;
  bool& have_cw = ss.have_cw;
  double& min_sweep = ss.min_sweep;
  const double R = ss.R;
  for (std::size_t k = 0; k < ev.runs.size(); ++k) {
    const RunResult& rr = ev.runs[k];
    RunInfo info;
    info.dir = rr.run.direction == Direction::CCW ? 1.0 : -1.0;
    (info.dir > 0 ? have_ccw : have_cw) = true;
    min_sweep = std::min(min_sweep, rr.run.sweep_deg);
    const std::optional<double> feed =
        rr.feed_mm_per_min ? rr.feed_mm_per_min : (announced[k] ? announced[k] : meta_feed);
    if (feed && *feed > 0) {
      info.speed_mm_s = *feed / 60.0;
      std::size_t g = 0;
      while (g < group_feed.size() && std::abs(group_feed[g] - *feed) > 0.02 * *feed) ++g;
      if (g == group_feed.size()) group_feed.push_back(*feed);
      info.group = static_cast<int>(g);
    } else {
      speed_known = false;
      if (group_feed.empty()) group_feed.push_back(0.0);
      info.group = 0;
    }
    info.ellipse_speed_mm_s = info.speed_mm_s;
    info.begin = S.runs.empty() ? 0 : S.runs.back().end;
    info.end = info.begin + rr.run.size();
    info.trace_begin = rr.run.begin;
    // One sample period in angle (the time column's mean step).
    if (const std::vector<double>* t = trace.column(column_name::t);
        t && rr.run.size() > 1 && info.speed_mm_s > 0) {
      const double dt =
          ((*t)[rr.run.end - 1] - (*t)[rr.run.begin]) / static_cast<double>(rr.run.size() - 1);
      info.eps_rad = 1.5 * dt * info.speed_mm_s / R;
    }
    S.runs.push_back(info);
  }
  // Without every run's feed the direction-dependent ellipse is still fitted, as a phase
  // (one radius per second for every run: runs of unknown feed are taken as one feed).
  if (!speed_known) {
    for (RunInfo& info : S.runs) info.ellipse_speed_mm_s = R;
  }
}

// The runs' samples side by side (each run's into its own range of the arrays); returns each
// run's lowest and highest unwrapped angle.
std::vector<std::array<double, 2>> fill_samples(const Evaluation& ev, const TraceDescription& td,
                                                SampleSet& ss) {
  Samples& S = ss.S;
  const auto& col_a = td.col_a;
  const auto& col_b = td.col_b;
  const double ca = ss.ca, cb = ss.cb, R = ss.R;
  {
    const std::size_t total = S.runs.empty() ? 0 : S.runs.back().end;
    for (auto* v : {&S.c, &S.s, &S.dr, &S.u}) v->resize(total);
    S.run.resize(total);
  }
  std::vector<std::array<double, 2>> angle_range(ev.runs.size());  // lowest, highest
  for_each_task(ev.runs.size(), [&](std::size_t k) {
    const Run& run = ev.runs[k].run;
    const RunInfo& info = S.runs[k];
    // The angle straight into u and the radius into dr (made r - R below): no copy.
    double* const angle = S.u.data() + info.begin;
    double* const radius = S.dr.data() + info.begin;
    detail::path_polar_into(std::span(col_a).subspan(run.begin, run.size()),
                            std::span(col_b).subspan(run.begin, run.size()), PlanePoint{ca, cb},
                            angle, radius);
    double lo = 0, hi = 0;
    for (std::size_t q = 0; q < run.size(); ++q) {
      const std::size_t i = run.begin + q, j = info.begin + q;
      const double da = col_a[i] - ca, db = col_b[i] - cb;
      const double r = radius[q];
      const double u = angle[q];
      if (q == 0) lo = hi = u;
      lo = std::min(lo, u);
      hi = std::max(hi, u);
      S.c[j] = da / r;
      S.s[j] = db / r;
      S.dr[j] = r - R;
      S.run[j] = static_cast<std::uint32_t>(k);
    }
    angle_range[k] = {lo, hi};
  });
  return angle_range;
}

void find_reversals(SampleSet& ss, const std::vector<std::array<double, 2>>& angle_range) {
  bool& reversal_a = ss.reversal_a;
  bool& reversal_b = ss.reversal_b;
  for (const std::array<double, 2>& range : angle_range) {
    const double lo = range[0], hi = range[1];
    // An axis reverses inside the run when the arc crosses its reversal angle (with a margin
    // so the step itself is inside the data).
    const double margin = 2.0 * kPi / 180.0;
    auto crosses = [&](double shift) {
      return std::floor((hi - margin - shift) / kPi) >= std::ceil((lo + margin - shift) / kPi);
    };
    reversal_a = reversal_a || crosses(0.0);
    reversal_b = reversal_b || crosses(kPi / 2);
  }
}

// What the runs cannot show.
void sample_notes(const Evaluation& ev, const SampleSet& ss, Diagnosis& D) {
  const bool speed_known = ss.speed_known, have_ccw = ss.have_ccw, have_cw = ss.have_cw;
  const double min_sweep = ss.min_sweep;
  D.runs = ev.runs.size();
  D.samples = ss.S.size();
  D.feeds_mm_per_min = ss.group_feed;
  if (!speed_known) {
    D.feeds_mm_per_min.clear();
    D.notes.push_back(
        "feed unknown (no time column, feed_mm_per_min or feeds the runs can be matched to): "
        "the servo mismatch ellipse is fitted as a phase (no lag in ms), reversal spikes are "
        "not fitted");
  }
  if (!have_ccw || !have_cw) {
    D.notes.push_back(fmt::format(
        "one direction only ({}): backlash and servo mismatch cannot be told apart from "
        "geometry by the direction change; a CCW and a CW run are needed for H-related terms",
        have_ccw ? "CCW" : "CW"));
  }
  if (min_sweep < 359.0) {
    D.notes.push_back(fmt::format(
        "partial arc ({:.0f} deg): only the terms the arc separates are fitted", min_sweep));
  }
}

}  // namespace

TraceDescription describe_trace(const Inputs& in, Diagnosis& D) {
  const Trace& trace = in.trace;
  const Evaluation& ev = in.ev;
  const DiagnosisOptions& options = in.options;
  if (ev.runs.empty()) throw DataError(trace.source, 0, "no run to diagnose");
  D.source = ev.source;
  D.plane = ev.plane;
  const PlaneAxes pa = plane_axes(ev.plane);
  D.axes = {static_cast<char>(pa.first - 'a' + 'A'), static_cast<char>(pa.second - 'a' + 'A')};
  TraceDescription td{pa.first,
                      pa.second,
                      std::string(1, D.axes[0]),
                      std::string(1, D.axes[1]),
                      trace.values[ev.columns.a],
                      trace.values[ev.columns.b],
                      ev.channel_a == column_name::from_radial(pa.first) ||
                          ev.channel_b == column_name::from_radial(pa.second)};
  td.feedback = ev.channel_a == column_name::feedback(pa.first) &&
                ev.channel_b == column_name::feedback(pa.second);
  if (const std::string* h = trace.metadata.find(meta_key::ini_sha256)) D.ini_sha256 = *h;
  D.absolute_channels = options.absolute_channels;
  if (const std::string* ins = trace.metadata.find(meta_key::instrument)) {
    std::string low = *ins;
    std::transform(low.begin(), low.end(), low.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    if (low.find("ballbar") != std::string::npos || low.find("radial") != std::string::npos) {
      D.absolute_channels = false;
    }
  }
  return td;
}

SampleSet set_up_samples(const Inputs& in, const TraceDescription& td, Diagnosis& D) {
  SampleSet ss;
  linearisation_point(in, td, ss, D);
  D.radius_mm = ss.R;
  // Feed groups: runs within 2 % of each other's feed share a radius parameter.
  const std::optional<double> meta_feed =
      in.trace.metadata.number(meta_key::feed_mm_per_min, in.trace.source);
  ss.S.radius = ss.R;
  ss.S.col_a = td.col_a.data();
  ss.S.col_b = td.col_b.data();
  reserve_samples(in.ev, ss.S);
  run_bookkeeping(in, ss, meta_feed);
  find_reversals(ss, fill_samples(in.ev, td, ss));
  sample_notes(in.ev, ss, D);
  return ss;
}

}  // namespace circtest::diagnosis_detail
