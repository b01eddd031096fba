// The circle's scale bounded by the amplitude response a loop the trace cannot see may add at
// the test's angular speed, and, where the trace has the motor feedback, the screws' scale
// from the instrument against it, said beside it (docs/diagnosis.md, "Scale against the
// feedback").
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "../evaluation/median.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/trace_keys.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

// A sample enters the feedback fit only where its axis moves at least this share of the path
// speed: around a reversal the motor crosses the play window while the table stands.
constexpr double kMinSpeedShare = 0.3;
// The trace's instrument columns are the feedback themselves when they never differ by more.
constexpr double kSameColumnMm = 1e-9;
// Robust refit: samples further from the first fit than this many robust standard deviations
// (1.4826 MAD) are left out of the second.
constexpr double kOutlierSigmas = 5.0;
// What a position loop may add to the axes' amplitude beyond the first-order loss of its lag,
// relative, per (rad/s)^2 of angular speed: a loop with a drive of time constant tau_v under a
// position gain P (and any FF1) has |H(jw)| = 1 - w^2 / (2 P^2) + w^2 tau_v / P + O(w^4); the
// lag the trace measures shows the first part only (none at FF1 = 1). Bound: tau_v / P of a
// 6 ms drive under P = 30 1/s (configs/sim-servo's slowest axis is 6 ms / 31 1/s); servo
// drives with velocity loops of 1-3 ms and P of 20-60 1/s stay below it.
constexpr double kLoopSecondOrderS2 = 2e-4;
// A bound on the scale above this cannot tell a scale from the servo at all: circcomp's own
// plausibility bound on a scale correction (compensation/src/plan/axis_tables.cpp).
constexpr double kMaxLoopBoundPpm = 500.0;

// Columns: offset, position, direction of motion, the other axis' position, and the cyclic
// error's sine and cosine when the circle's fit found one on the axis.
constexpr int kMaxColumns = 6;

struct AxisScale {
  double scale = 0.0, se = 0.0;
  std::size_t samples = 0;
};

using Row = Eigen::Matrix<double, kMaxColumns, 1>;

struct LinearFit {
  Eigen::VectorXd x;
  AxisScale scale;
  double rss = 0.0;
};

// Least squares of d = instrument - feedback on the first NCOLS columns of X over the samples
// KEEP marks.
std::optional<LinearFit> solve(const std::vector<Row>& x, const std::vector<double>& d,
                               const std::vector<char>& keep, int ncols) {
  Eigen::Matrix<double, kMaxColumns, kMaxColumns> full =
      Eigen::Matrix<double, kMaxColumns, kMaxColumns>::Zero();
  Row atb_full = Row::Zero();
  double btb = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    if (!keep[i]) continue;
    full.selfadjointView<Eigen::Lower>().rankUpdate(x[i]);
    atb_full += x[i] * d[i];
    btb += d[i] * d[i];
    ++n;
  }
  if (n < 4 * static_cast<std::size_t>(ncols)) return std::nullopt;
  const Eigen::MatrixXd ata =
      full.topLeftCorner(ncols, ncols).selfadjointView<Eigen::Lower>().toDenseMatrix();
  const Eigen::VectorXd atb = atb_full.head(ncols);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(ata);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return std::nullopt;
  const Eigen::VectorXd sol = ldlt.solve(atb);
  const double rss = std::max(0.0, btb - sol.dot(atb));
  const double sigma2 = rss / static_cast<double>(n - static_cast<std::size_t>(ncols));
  const double var = ldlt.solve(Eigen::VectorXd::Unit(ncols, 1))(1);
  if (!sol.allFinite() || !(var > 0)) return std::nullopt;
  return LinearFit{sol, {sol(1), std::sqrt(sigma2 * var), n}, rss};
}

// The pitch of a cyclic error left in RES (d less the fit without one), over the feedback
// positions POS: a periodogram of the residual binned over the position (bins of an eighth of
// the shortest pitch), over screw-like pitches from kMinPitchMm to half the travel in steps
// that keep the phase over the travel within a quarter turn; the peak counts when its power is
// the diagnosis's cyclic_detection_factor times the median and its amplitude at least
// min_cyclic_amplitude_mm (docs/diagnosis.md).
constexpr double kMinPitchMm = 1.0, kMaxPitchMm = 40.0;

std::optional<double> residual_pitch(const std::vector<double>& pos, const std::vector<double>& res,
                                     const DiagnosisOptions& o) {
  if (pos.empty()) return std::nullopt;
  const auto [lo_it, hi_it] = std::minmax_element(pos.begin(), pos.end());
  const double lo = *lo_it, span = *hi_it - lo, h = kMinPitchMm / 8.0;
  const double top = std::min(kMaxPitchMm, span / 2.0);
  if (!(top > kMinPitchMm)) return std::nullopt;
  const auto nbins = static_cast<std::size_t>(span / h) + 1;
  std::vector<double> sum(nbins, 0.0), count(nbins, 0.0);
  for (std::size_t i = 0; i < pos.size(); ++i) {
    const auto b = std::min(nbins - 1, static_cast<std::size_t>((pos[i] - lo) / h));
    sum[b] += res[i];
    count[b] += 1.0;
  }
  std::vector<double> centre, mean, weight;
  for (std::size_t b = 0; b < nbins; ++b) {
    if (count[b] == 0.0) continue;
    centre.push_back(lo + (static_cast<double>(b) + 0.5) * h);
    mean.push_back(sum[b] / count[b]);
    weight.push_back(count[b]);
  }
  const double total = std::accumulate(weight.begin(), weight.end(), 0.0);
  const auto power_at = [&](double p) {
    const double k = 2.0 * kPi / p;
    double sc = 0.0, sn = 0.0;
    for (std::size_t b = 0; b < centre.size(); ++b) {
      sc += weight[b] * mean[b] * std::cos(k * centre[b]);
      sn += weight[b] * mean[b] * std::sin(k * centre[b]);
    }
    return sc * sc + sn * sn;
  };
  std::vector<double> power;
  double best = 0.0, best_pitch = 0.0;
  for (double p = kMinPitchMm; p <= top; p *= 1.0 + p / (4.0 * span)) {
    power.push_back(power_at(p));
    if (power.back() > best) {
      best = power.back();
      best_pitch = p;
    }
  }
  if (power.size() < 8) return std::nullopt;
  const double median_power = detail::median_in_place(power);
  // The peak between its grid neighbours.
  const double step = 1.0 + best_pitch / (4.0 * span);
  best_pitch =
      golden([&](double p) { return -power_at(p); }, best_pitch / step, best_pitch * step, 40);
  best = power_at(best_pitch);
  const double amplitude = 2.0 * std::sqrt(best) / total;
  if (!(best > o.cyclic_detection_factor * median_power) || amplitude < o.min_cyclic_amplitude_mm)
    return std::nullopt;
  return best_pitch;
}

// Axis AX's scale from its instrument column against its feedback column: d = s (fb - centre)
// + offset + play / 2 (direction of motion) + a squareness-like term in the other axis, + the
// cyclic error at PITCH (the option's, the circle's, else one the residual shows); a second
// fit without the first's outliers (a glitch of one channel).
std::optional<AxisScale> fit_axis(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                                  int ax, const std::vector<double>& fb,
                                  const std::vector<double>& other_fb,
                                  std::optional<double> pitch) {
  const Samples& S = ss.S;
  const std::vector<double>& col = ax == 0 ? td.col_a : td.col_b;
  const double centre = ax == 0 ? ss.ca : ss.cb, other_centre = ax == 0 ? ss.cb : ss.ca;
  std::vector<Row> x;
  std::vector<double> d, pos;
  for (std::size_t i = 0; i < S.size(); ++i) {
    const RunInfo& r = S.runs[S.run[i]];
    // The axis' speed over the path speed is |sin| for A, |cos| for B; its direction
    // -dir sgn(sin) for A, dir sgn(cos) for B.
    const double share = ax == 0 ? S.s[i] : S.c[i];
    if (!(std::abs(share) >= kMinSpeedShare)) continue;
    const double dir = ax == 0 ? -r.dir * sgn(share) : r.dir * sgn(share);
    const std::size_t row = r.trace_begin + (i - r.begin);
    Row v = Row::Zero();
    v.head(4) << 1.0, fb[row] - centre, dir, other_fb[row] - other_centre;
    x.push_back(v);
    d.push_back(col[row] - fb[row]);
    pos.push_back(fb[row]);
  }
  std::vector<char> keep(d.size(), 1);
  const auto residual = [&](const LinearFit& f, int ncols) {
    std::vector<double> res(d.size());
    for (std::size_t i = 0; i < d.size(); ++i) res[i] = d[i] - f.x.dot(x[i].head(ncols));
    return res;
  };
  auto first = solve(x, d, keep, 4);
  if (!first) return std::nullopt;
  const auto with_pitch = [&](double p) {
    const double k = 2.0 * kPi / p;
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i](4) = std::sin(k * pos[i]);
      x[i](5) = std::cos(k * pos[i]);
    }
    return solve(x, d, keep, 6);
  };
  if (!pitch) {
    // The residual's peak, then the pitch where the whole fit (scale with it) leaves least.
    if (const auto peak = residual_pitch(pos, residual(*first, 4), in.options)) {
      const auto rss = [&](double p) {
        const auto f = with_pitch(p);
        return f ? f->rss : std::numeric_limits<double>::infinity();
      };
      pitch = golden(rss, *peak * 0.9, *peak * 1.1, 40);
    }
  }
  const int ncols = pitch ? 6 : 4;
  if (pitch) {
    first = with_pitch(*pitch);
    if (!first) return std::nullopt;
  }
  std::vector<double> res = residual(*first, ncols);
  for (double& r : res) r = std::abs(r);
  std::vector<double> scratch = res;
  const double sigma = 1.4826 * detail::median_in_place(scratch);
  if (sigma > 0) {
    for (std::size_t i = 0; i < d.size(); ++i) keep[i] = res[i] <= kOutlierSigmas * sigma ? 1 : 0;
    if (const auto second = solve(x, d, keep, ncols)) return second->scale;
  }
  return first->scale;
}

// The cyclic pitch of axis AX the diagnosis already knows: the option's, else the circle's.
std::optional<double> known_pitch(const Inputs& in, const TraceDescription& td, int ax,
                                  const Diagnosis& D) {
  const auto it = in.options.pitch_mm.find(ax == 0 ? td.la : td.lb);
  if (it != in.options.pitch_mm.end()) return it->second;
  if (const auto& c = D.cyclic[static_cast<std::size_t>(ax)]) return c->pitch_mm;
  return std::nullopt;
}

// The mean squared angular speed of the samples, (rad/s)^2.
double mean_w2(const SampleSet& ss) {
  const Samples& S = ss.S;
  double w2 = 0.0;
  for (const RunInfo& r : S.runs) {
    const double w = r.speed_mm_s / ss.R;
    w2 += w * w * static_cast<double>(r.end - r.begin);
  }
  return S.size() > 0 ? w2 / static_cast<double>(S.size()) : 0.0;
}

void mark_unseparable(Diagnosis& D, const std::string& key) {
  if (std::find(D.unseparable.begin(), D.unseparable.end(), key) == D.unseparable.end())
    D.unseparable.push_back(key);
}

// The scales from the feedback fit, said in a note beside the circle's. They are the screws'
// scale as the motor sees it: a comp table in effect moves the motor with it, so after a
// correction they still show the scale before it, and the circle's figure (what the
// correction changes) stays the one reported.
void note_feedback_scales(const Inputs& in, const TraceDescription& td,
                          const std::array<AxisScale, 2>& fit,
                          const std::array<std::string, 2>& fb_names, Diagnosis& D) {
  D.notes.push_back(fmt::format(
      "scale against the motor feedback ({} - {}, {} - {}; {} and {} samples away from the "
      "reversals, free of the servo): {} {:+.1f} +- {:.1f} ppm, {} {:+.1f} +- {:.1f} ppm; the "
      "screws as the motor sees them, before any comp table in effect (the motor moves with "
      "it), so the scale reported is the circle's",
      in.ev.channel_a, fb_names[0], in.ev.channel_b, fb_names[1], fit[0].samples, fit[1].samples,
      td.A, fit[0].scale * 1e6, fit[0].se * 1e6, td.B, fit[1].scale * 1e6, fit[1].se * 1e6));
}

// Without feedback columns: the circle's scale holds a loop's amplitude response beyond the
// first-order loss its lag explains, up to w^2 kLoopSecondOrderS2. Negligible against the
// standard error: nothing; up to kMaxLoopBoundPpm: the standard errors widened by it (a
// rectangular bound); beyond: not reported.
void bound_circle_scale(const TraceDescription& td, const SampleSet& ss, MeanScale& mean_scale,
                        Diagnosis& D, bool feedback_noted = false) {
  if (!ss.speed_known || (!D.scale_mismatch_ppm.value && !D.scale_ppm[0].value)) return;
  const double w2 = mean_w2(ss);
  const double bound_ppm = w2 * kLoopSecondOrderS2 * 1e6;
  // The mean scale from one feed leans on the loop model; a feed sweep's intercept does not.
  const bool one_feed = ss.group_feed.size() < 2;
  const double mean_bound = one_feed ? bound_ppm : 0.0;
  const double se_mismatch = D.scale_mismatch_ppm.standard_error.value_or(0.0);
  if (bound_ppm <= std::max(se_mismatch, D.scale_ppm[0].standard_error.value_or(0.0))) return;
  const double w = std::sqrt(w2);
  if (bound_ppm > kMaxLoopBoundPpm) {
    if (D.scale_mismatch_ppm.value) {
      D.scale_mismatch_ppm = {};
      mark_unseparable(D, diagnosis_json::key::scale_mismatch_ppm);
    }
    if (D.scale_ppm[0].value || D.scale_ppm[1].value) {
      D.scale_ppm = {};
      mark_unseparable(D, diagnosis_json::key::scale_ppm);
    }
    if (one_feed) mean_scale = {};
    D.notes.push_back(fmt::format(
        "scale and scale mismatch not reported: at {:.2f} rad/s the position loop may change "
        "the axes' amplitudes by up to {:.0f} ppm beyond the first-order loss of its lag, which "
        "the circle cannot tell from scale; run a larger diameter or a lower feed{}",
        w, bound_ppm,
        feedback_noted ? " (the note against the motor feedback gives the screws' scale)"
                       : fmt::format(", or record the feedback columns ({}, {}) for the screws' "
                                     "scale",
                                     column_name::feedback(td.la), column_name::feedback(td.lb))));
    return;
  }
  const double u = 1.0 / std::sqrt(3.0);  // a rectangular bound's standard deviation
  if (D.scale_mismatch_ppm.value)
    D.scale_mismatch_ppm.standard_error = std::hypot(se_mismatch, bound_ppm * u);
  const double axis_se_ppm = std::hypot(mean_bound, bound_ppm / 2) * u;
  for (Estimate& e : D.scale_ppm) {
    if (e.value) e.standard_error = std::hypot(e.standard_error.value_or(0.0), axis_se_ppm);
  }
  mean_scale.loop_se = axis_se_ppm * 1e-6;
  if (one_feed && mean_scale.value)
    mean_scale.se = std::hypot(mean_scale.se, mean_bound * 1e-6 * u);
  D.notes.push_back(fmt::format(
      "scale from the circle: at {:.2f} rad/s the position loop may change the axes' "
      "amplitudes by up to {:.1f} ppm beyond the first-order loss of its lag; the standard "
      "errors include it",
      w, bound_ppm));
}

}  // namespace

void scale_from_instrument(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                           MeanScale& mean_scale, Diagnosis& D) {
  if (td.feedback || td.radial || !in.ev.nominal_radius_mm) return;
  const Trace& trace = in.trace;
  const std::array<std::string, 2> fb_names = {column_name::feedback(td.la),
                                               column_name::feedback(td.lb)};
  const std::vector<double>* fb[2] = {trace.column(fb_names[0]), trace.column(fb_names[1])};
  if (!fb[0] || !fb[1] || !D.absolute_channels) {
    bound_circle_scale(td, ss, mean_scale, D);
    return;
  }
  double most = 0.0;
  for (const RunResult& rr : in.ev.runs)
    for (std::size_t i = rr.run.begin; i < rr.run.end; ++i)
      most = std::max(
          {most, std::abs(td.col_a[i] - (*fb[0])[i]), std::abs(td.col_b[i] - (*fb[1])[i])});
  if (most <= kSameColumnMm) {
    // The measured columns are the feedback under other names: as radius_loss.cpp says for
    // the feedback itself, they show the servo, never scale.
    D.scale_ppm = {};
    D.scale_mismatch_ppm = {};
    mean_scale = {};
    mark_unseparable(D, diagnosis_json::key::scale_ppm);
    mark_unseparable(D, diagnosis_json::key::scale_mismatch_ppm);
    D.notes.push_back(fmt::format(
        "the measured columns ({}, {}) equal the motor feedback ({}, {}): scale and scale "
        "mismatch not reported (they need an instrument)",
        in.ev.channel_a, in.ev.channel_b, fb_names[0], fb_names[1]));
    return;
  }
  const auto a = fit_axis(in, td, ss, 0, *fb[0], *fb[1], known_pitch(in, td, 0, D));
  const auto b = fit_axis(in, td, ss, 1, *fb[1], *fb[0], known_pitch(in, td, 1, D));
  if (!a || !b) {
    D.notes.push_back("scale against the feedback: too few samples away from the reversals");
    bound_circle_scale(td, ss, mean_scale, D);
    return;
  }
  note_feedback_scales(in, td, {*a, *b}, fb_names, D);
  bound_circle_scale(td, ss, mean_scale, D, true);
}

}  // namespace circtest::diagnosis_detail
