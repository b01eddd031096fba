// The servo per axis: each axis' following lag (following error over velocity, a least-squares
// fit over the part of the circle where the axis moves at speed), its effective position gain,
// the lag mismatch and the part of G the mismatch ellipse makes at each feed
// (docs/diagnosis.md, "Servo per axis").
#include <fmt/format.h>
#include <Eigen/Dense>
#include <cmath>

#include "circtest/core/trace_keys.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

// A sample enters the fit only where the axis moves at least this share of the path speed:
// around its reversal the friction spike and the backlash transition are no lag.
constexpr double kMinSpeedShare = 0.3;
// Columns of the fit: velocity (the lag), sign of velocity (play, Coulomb friction a drive
// without integral action loses), constant, position (scale), acceleration (the loop's second
// order; only with more than one feed, else it is the position column again), and for the
// instrument reference the other axis' position (squareness, only with both directions).
constexpr int kMaxColumns = 6;

struct LagFit {
  std::optional<double> lag_s, se_s;
  std::size_t samples = 0;
};

// What the per-axis lag fits read.
struct LagContext {
  const Inputs& in;
  const TraceDescription& td;
  const SampleSet& ss;
  const FollowingLag& lag;
};

// Least squares of the following error on the columns above for axis AX against REFERENCE.
LagFit fit_axis_lag(const LagContext& ctx, int ax, const std::vector<double>& cmd,
                    const std::vector<double>& reference, const std::vector<double>* other_cmd) {
  const Trace& trace = ctx.in.trace;
  const SampleSet& ss = ctx.ss;
  const std::vector<double>* t = trace.column(column_name::t);
  const Samples& S = ss.S;
  const double centre = ax == 0 ? ss.ca : ss.cb;
  const double other_centre = ax == 0 ? ss.cb : ss.ca;
  const bool with_acc = ss.group_feed.size() > 1;
  const bool with_other = other_cmd != nullptr && ss.have_ccw && ss.have_cw;
  const int n_cols = 4 + (with_acc ? 1 : 0) + (with_other ? 1 : 0);
  Eigen::MatrixXd ata = Eigen::MatrixXd::Zero(n_cols, n_cols);
  Eigen::VectorXd atb = Eigen::VectorXd::Zero(n_cols);
  double btb = 0.0;
  std::size_t n = 0;
  double x[kMaxColumns];
  for (const RunInfo& info : S.runs) {
    const std::size_t len = info.end - info.begin;
    if (len < 3 || info.speed_mm_s <= 0) continue;
    const double w2 = (info.speed_mm_s / ss.R) * (info.speed_mm_s / ss.R);
    for (std::size_t q = 1; q + 1 < len; ++q) {
      const std::size_t i = info.trace_begin + q;
      const double dt = t ? (*t)[i + 1] - (*t)[i - 1] : 2.0 * ctx.lag.period;
      if (!(dt > 0)) continue;
      const double v = (cmd[i + 1] - cmd[i - 1]) / dt;
      if (!(std::abs(v) >= kMinSpeedShare * info.speed_mm_s)) continue;
      const double pos = cmd[i] - centre;
      int c = 0;
      x[c++] = v;
      x[c++] = v > 0 ? 1.0 : -1.0;
      x[c++] = 1.0;
      x[c++] = pos;
      if (with_acc) x[c++] = -w2 * pos;
      if (with_other) x[c++] = (*other_cmd)[i] - other_centre;
      const double e = cmd[i] - reference[i];
      if (!std::isfinite(e) || !std::isfinite(v)) continue;
      for (int r = 0; r < n_cols; ++r) {
        for (int k = 0; k <= r; ++k) ata(r, k) += x[r] * x[k];
        atb(r) += x[r] * e;
      }
      btb += e * e;
      ++n;
    }
  }
  LagFit out;
  out.samples = n;
  if (n < static_cast<std::size_t>(4 * n_cols)) return out;
  ata = ata.selfadjointView<Eigen::Lower>();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(ata);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return out;
  const Eigen::VectorXd sol = ldlt.solve(atb);
  const double rss = std::max(0.0, btb - sol.dot(atb));
  const double sigma2 = rss / static_cast<double>(n - static_cast<std::size_t>(n_cols));
  Eigen::VectorXd e0 = Eigen::VectorXd::Zero(n_cols);
  e0(0) = 1.0;
  const double var = ldlt.solve(e0)(0);
  if (!std::isfinite(sol(0)) || !(var > 0)) return out;
  out.lag_s = sol(0);
  out.se_s = std::sqrt(sigma2 * var);
  return out;
}

// The largest G (least squares centre) of the runs at feed group G.
std::optional<double> measured_g_of_group(const Evaluation& ev, const Samples& S, int g) {
  std::optional<double> best;
  for (std::size_t k = 0; k < S.runs.size() && k < ev.runs.size(); ++k) {
    if (S.runs[k].group != g) continue;
    const double v = ev.runs[k].g_lsc_mm;
    if (!best || v > *best) best = v;
  }
  return best;
}

// Per axis from the commanded column against the motor feedback (else the instrument).
void lags_from_columns(const LagContext& ctx, Diagnosis& D) {
  const Trace& trace = ctx.in.trace;
  const TraceDescription& td = ctx.td;
  const char letters[2] = {td.la, td.lb};
  const std::vector<double>* cmds[2] = {trace.column(column_name::commanded(td.la)),
                                        trace.column(column_name::commanded(td.lb))};
  for (int ax = 0; ax < 2; ++ax) {
    if (!cmds[ax]) continue;
    const std::vector<double>* fb = trace.column(column_name::feedback(letters[ax]));
    AxisLag& al = D.axis_lag[ax];
    LagFit f;
    if (fb) {
      f = fit_axis_lag(ctx, ax, *cmds[ax], *fb, nullptr);
      if (f.lag_s) al.source = "feedback";
    } else {
      const auto& col = ax == 0 ? td.col_a : td.col_b;
      // The plane's first axis carries the squareness (a_actual = a + alpha b): the other
      // axis' position is a column of its fit.
      f = fit_axis_lag(ctx, ax, *cmds[ax], col, ax == 0 ? cmds[1] : nullptr);
      if (f.lag_s) al.source = "instrument";
    }
    if (!f.lag_s) continue;
    // The following error over velocity as the trace logs it (what joint.N.f-error over
    // joint.N.vel-cmd shows): LinuxCNC's pid with error-previous-target follows a P-only loop's
    // 1 / P exactly so, and circcomp works with differences of it.
    const double lag_s = *f.lag_s;
    al.lag_ms.value = lag_s * 1e3;
    al.lag_ms.standard_error = *f.se_s * 1e3;
    if (lag_s > 0) al.kv_per_s = 1.0 / lag_s;
  }
  if (!cmds[0] || !cmds[1]) {
    D.notes.push_back(fmt::format(
        "servo per axis: no {} column: the lag of {} cannot be measured against its command",
        !cmds[0] ? column_name::commanded(td.la) : column_name::commanded(td.lb),
        !cmds[0] ? td.A : td.B));
  } else if (D.axis_lag[0].source == "instrument" || D.axis_lag[1].source == "instrument") {
    D.notes.push_back(fmt::format(
        "servo per axis: no motor feedback column ({}, {}): the lag is measured against the "
        "instrument, with play, scale and squareness fitted out; a cyclic error stays in it",
        column_name::feedback(td.la), column_name::feedback(td.lb)));
  }
}

// Without commanded columns: the mean lag of a feed sweep (the radius change, Kv) split by the
// fitted mismatch.
void lags_from_feeds(const SampleSet& ss, Diagnosis& D) {
  if (D.kv_source == "feeds" && D.kv_per_s.value && *D.kv_per_s.value > 0 &&
      D.servo_mismatch_ms.value) {
    const double mean_ms = 1e3 / *D.kv_per_s.value;
    const double half = *D.servo_mismatch_ms.value / 2.0;
    const double se_mean =
        D.kv_per_s.standard_error ? mean_ms * *D.kv_per_s.standard_error / *D.kv_per_s.value : 0.0;
    const double se_half = D.servo_mismatch_ms.standard_error.value_or(0.0) / 2.0;
    for (int ax = 0; ax < 2; ++ax) {
      AxisLag& al = D.axis_lag[ax];
      al.lag_ms.value = mean_ms + (ax == 0 ? half : -half);
      al.lag_ms.standard_error = std::hypot(se_mean, se_half);
      if (*al.lag_ms.value > 0) al.kv_per_s = 1e3 / *al.lag_ms.value;
      al.source = "feeds";
    }
    return;
  }
  D.notes.push_back(
      ss.group_feed.size() > 1
          ? "servo per axis: not measured (no commanded columns, and the radius change over the "
            "feeds gives no position-loop gain)"
          : "servo per axis: not measured (no commanded columns and one feed only: the mean lag "
            "needs commanded columns or a feed sweep)");
}

}  // namespace

void measure_axis_lags(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                       const FollowingLag& lag, Diagnosis& D) {
  if (!ss.speed_known) {
    D.notes.push_back("servo per axis: the feed is unknown, no lag can be measured");
    return;
  }
  const Trace& trace = in.trace;
  if (td.radial) {
    D.notes.push_back(
        "servo per axis: a radial trace's commanded columns give each length reading's angle, "
        "not a command the axes follow: no lag is measured against them");
    lags_from_feeds(ss, D);
  } else if (trace.column(column_name::commanded(td.la)) ||
             trace.column(column_name::commanded(td.lb))) {
    lags_from_columns({in, td, ss, lag}, D);
  } else {
    lags_from_feeds(ss, D);
  }
  const AxisLag &a = D.axis_lag[0], &b = D.axis_lag[1];
  std::optional<double> dtau_ms;
  if (a.lag_ms.value && b.lag_ms.value && a.source != "feeds") {
    D.axis_lag_mismatch_ms.value = *a.lag_ms.value - *b.lag_ms.value;
    D.axis_lag_mismatch_ms.standard_error =
        std::hypot(a.lag_ms.standard_error.value_or(0.0), b.lag_ms.standard_error.value_or(0.0));
    dtau_ms = D.axis_lag_mismatch_ms.value;
  } else if (D.servo_mismatch_ms.value) {
    // From the instrument alone: the fitted ellipse, which grows with the feed.
    dtau_ms = D.servo_mismatch_ms.value;
    if (ss.group_feed.size() < 2 && D.squareness_urad.value) {
      D.notes.push_back(
          "servo per axis: one feed only: the mismatch ellipse and squareness are told apart by "
          "the run directions alone; a feed sweep separates them by how they grow with feed");
    }
  }
  if (!dtau_ms) return;
  for (std::size_t g = 0; g < ss.group_feed.size(); ++g) {
    ServoShare share;
    share.feed_mm_per_min = ss.group_feed[g];
    share.g_mm = ss.group_feed[g] / 60.0 * std::abs(*dtau_ms) * 1e-3;
    share.measured_g_mm = measured_g_of_group(in.ev, ss.S, static_cast<int>(g));
    if (share.measured_g_mm && *share.measured_g_mm > 0) {
      share.percent = share.g_mm / *share.measured_g_mm * 100.0;
    }
    D.servo_share.push_back(share);
  }
}

}  // namespace circtest::diagnosis_detail
