// The servo: the mean following lag from the commanded columns, and the part of the fitted
// scale mismatch that unequal position loops make.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "../evaluation/radial_profile.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/trace_keys.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

const std::vector<double>* cmd_column(const Trace& trace, char axis) {
  return trace.column(column_name::commanded(axis));
}

// Whether the fitted servo mismatch ellipse (in s, or a phase without the feed) stands out of
// its noise: more than three standard errors.
bool servo_ellipse_stands_out(const Model& m) {
  const auto j = find(m.cols, Kind::servo);
  if (!j) return false;
  const auto ji = static_cast<Eigen::Index>(*j);
  const double se = std::sqrt(std::max(0.0, m.sol.sigma2 * m.sol.inv(ji, ji)));
  return std::abs(m.sol.x[ji]) > 3.0 * se;
}

}  // namespace

// The mean following lag from the commanded columns (same servo period as the instrument).
FollowingLag measure_following_lag(const Inputs& in, const TraceDescription& td,
                                   const SampleSet& ss, const Model& m, Diagnosis& D) {
  const Trace& trace = in.trace;
  const Evaluation& ev = in.ev;
  const Samples& S = ss.S;
  const auto& col_a = td.col_a;
  const auto& col_b = td.col_b;
  const double ca = ss.ca, cb = ss.cb, R = ss.R;
  const bool speed_known = ss.speed_known;
  FollowingLag out;
  std::optional<double>& lag_s = out.lag_s;
  double& period = out.period;
  const char la = td.la, lb = td.lb;
  const std::vector<double>* cmd_a = cmd_column(trace, la);
  const std::vector<double>* cmd_b = cmd_column(trace, lb);
  if (cmd_a && cmd_b && speed_known && !td.radial) {
    const double oa = D.centre_offset_mm[0].value.value_or(0.0);
    const double ob = D.centre_offset_mm[1].value.value_or(0.0);
    const double alpha = D.squareness_urad.value.value_or(0.0) * 1e-6;
    const double mismatch = D.scale_mismatch_ppm.value.value_or(0.0) * 1e-6;
    const double ba = D.backlash_mm[0].value.value_or(0.0);
    const double bb = D.backlash_mm[1].value.value_or(0.0);
    const double dtau = D.servo_mismatch_ms.value.value_or(0.0) * 1e-3;
    // Per run, the sums of the tangential deviation and of the geometric terms' part of it; on
    // the threads, per block, added in block order.
    const std::size_t nruns = S.runs.size();
    const std::size_t nblocks = (S.size() + kBlockSamples - 1) / kBlockSamples;
    std::vector<double> tsums(nblocks * nruns, 0.0), gsums(nblocks * nruns, 0.0);
    for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t block) {
      // The block's part of each run: contiguous rows of the trace, summed without branches
      // (so the loop is vectorised); a row whose lag angle is too large for the series sends
      // the part through atan2 again.
      for (std::size_t j0 = lo; j0 < hi;) {
        const std::size_t k = S.run[j0];
        const RunInfo& info = S.runs[k];
        const std::size_t j1 = std::min(hi, info.end);
        const std::size_t i0 = info.trace_begin + (j0 - info.begin), n = j1 - j0;
        const double* ra = col_a.data() + i0;
        const double* rb = col_b.data() + i0;
        const double* qa_ = cmd_a->data() + i0;
        const double* qb_ = cmd_b->data() + i0;
        double tsum = 0.0, gsum = 0.0;
        int far = 0;
#pragma omp simd reduction(+ : tsum, gsum) reduction(| : far)
        for (std::size_t q = 0; q < n; ++q) {
          const double ma = ra[q] - ca - oa, mb = rb[q] - cb - ob;
          const double qa = qa_[q] - ca, qb = qb_[q] - cb;
          const double cross = qa * mb - qb * ma, dot = qa * ma + qb * mb;
          far |= static_cast<int>(!(dot > 0.0 && std::abs(cross) < detail::kAtanSeriesMax * dot));
          tsum += detail::atan_series(cross / dot);
          // No overflow or underflow at machine coordinates: hypot's care is not needed.
          const double r = std::sqrt(ma * ma + mb * mb);
          const double c = ma / r, s = mb / r;
          // Tangential deviations the fitted geometric terms make (docs/diagnosis.md).
          gsum += -info.dir * alpha * R * s * s - info.dir * R * mismatch * s * c -
                  0.5 * ba * std::abs(s) - 0.5 * bb * std::abs(c) -
                  info.speed_mm_s * 0.5 * dtau * (s * s - c * c);
        }
        if (far != 0) {
          tsum = 0.0;
          for (std::size_t q = 0; q < n; ++q) {
            const double ma = ra[q] - ca - oa, mb = rb[q] - cb - ob;
            const double qa = qa_[q] - ca, qb = qb_[q] - cb;
            tsum += detail::turn_angle(qa * mb - qb * ma, qa * ma + qb * mb);
          }
        }
        tsums[block * nruns + k] += info.dir * tsum * R;
        gsums[block * nruns + k] += gsum;
        j0 = j1;
      }
    });
    double num = 0.0, den = 0.0;
    for (std::size_t k = 0; k < nruns; ++k) {
      const RunInfo& info = S.runs[k];
      double tsum = 0.0, gsum = 0.0;
      for (std::size_t b = 0; b < nblocks; ++b) {
        tsum += tsums[b * nruns + k];
        gsum += gsums[b * nruns + k];
      }
      const auto n = static_cast<double>(info.end - info.begin);
      // T = -v lag + g  =>  lag = (g - T) / v
      num += (gsum - tsum) / info.speed_mm_s;
      den += n;
    }
    // The commanded value is sampled in the same period as the position it leads to: the
    // continuous loop's lag is half a sample longer than the delay seen between samples.
    if (const std::vector<double>* t = trace.column(column_name::t)) {
      const Run& r0 = ev.runs.front().run;
      if (r0.size() > 1)
        period = ((*t)[r0.end - 1] - (*t)[r0.begin]) / static_cast<double>(r0.size() - 1);
    }
    if (den > 0) {
      lag_s = num / den + period / 2.0;
      D.lag_ms.value = *lag_s * 1e3;
    }
  }
  // Unequal loops also scale the two axes' amplitudes differently (a cos 2theta term that
  // looks like a scale mismatch): -(v^2 / 2R)(tauA^2 - tauB^2)/2 = -(R/2) w^2 lag dtau.
  if (lag_s && D.servo_mismatch_ms.value && D.scale_mismatch_ppm.value) {
    double w2 = 0.0;
    for (std::size_t i = 0; i < S.size(); ++i) {
      const double w = S.runs[S.run[i]].speed_mm_s / R;
      w2 += w * w;
    }
    w2 /= static_cast<double>(S.size());
    out.scale_servo_per_s = w2 * *lag_s;
    *D.scale_mismatch_ppm.value += out.scale_servo_per_s * *D.servo_mismatch_ms.value * 1e-3 * 1e6;
  } else if ((!ss.speed_known || td.radial) && D.scale_mismatch_ppm.value &&
             servo_ellipse_stands_out(m)) {
    // The ellipse's cos 2theta part w^2 lag dtau is in the scale mismatch column, and the lag
    // is not known (no command to measure it against; without the feed not even w): the
    // mismatch is not reported rather than reported with the servo in it.
    D.unseparable.emplace_back(diagnosis_json::key::scale_mismatch_ppm);
    D.scale_mismatch_ppm = {};
    D.notes.push_back(fmt::format(
        "scale mismatch cannot be separated from the servo mismatch ellipse by this trace: "
        "unequal lags make a cos 2theta term w^2 lag (lag_{} - lag_{}) like it, and {}: not "
        "reported",
        td.A, td.B,
        td.radial ? "a radial trace has no command to measure the lag against"
                  : "without the feed and a command the lag is not known"));
  } else if (D.servo_mismatch_ms.value && D.scale_mismatch_ppm.value) {
    D.notes.push_back(
        "no commanded columns: the scale mismatch includes the cos 2theta part of the servo "
        "mismatch (w^2 lag dtau)");
  }
  return out;
}

}  // namespace circtest::diagnosis_detail
