// The radius change per feed split into the axes' mean scale and the servo's radius loss, from
// which the position-loop gain Kv follows.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "circtest/core/diagnosis_keys.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

// Absolute scale and Kv from the radius change: it is R (sA + sB) / 2 - v^2 lag^2 / (2 R).
MeanScale split_radius_change(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                              const FollowingLag& lag, Diagnosis& D) {
  const Evaluation& ev = in.ev;
  const double R = ss.R;
  const std::optional<double>& lag_s = lag.lag_s;
  const double period = lag.period;
  const std::optional<double> mismatch_ppm = D.scale_mismatch_ppm.value;
  std::optional<double> mean_scale, mean_scale_se;
  std::size_t nfeeds = 0;
  for (const auto& fr : D.radius_change) nfeeds += fr.dr_mm.value ? 1 : 0;
  if (ev.nominal_radius_mm && nfeeds >= 2) {
    // Weighted line dr = c0 + k v^2.
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const auto& fr : D.radius_change) {
      if (!fr.dr_mm.value) continue;
      const double v = fr.feed_mm_per_min / 60.0;
      const double se = std::max(fr.dr_mm.standard_error.value_or(1e-6), 1e-9);
      const double w = 1.0 / (se * se);
      const double x = v * v, y = *fr.dr_mm.value;
      sw += w;
      sx += w * x;
      sy += w * y;
      sxx += w * x * x;
      sxy += w * x * y;
    }
    const double det = sw * sxx - sx * sx;
    if (det > 0) {
      const double k = (sw * sxy - sx * sy) / det;
      const double c0 = (sxx * sy - sx * sxy) / det;
      const double se_k = std::sqrt(sw / det), se_c0 = std::sqrt(sxx / det);
      mean_scale = c0 / R;
      mean_scale_se = se_c0 / R;
      if (k < 0 && -k > 2 * se_k) {
        const double kv = std::sqrt(-1.0 / (2.0 * R * k));
        D.kv_per_s.value = kv;
        D.kv_per_s.standard_error = kv * 0.5 * se_k / std::abs(k);
        D.kv_source = "feeds";
      } else {
        D.notes.push_back(
            "the radius does not shrink measurably with feed: no position-loop gain derived");
      }
    }
  } else if (ev.nominal_radius_mm && nfeeds == 1 && lag_s) {
    const auto& fr = *std::find_if(D.radius_change.begin(), D.radius_change.end(),
                                   [](const FeedRadius& f) { return f.dr_mm.value.has_value(); });
    const double v = fr.feed_mm_per_min / 60.0;
    const double dtau = D.servo_mismatch_ms.value.value_or(0.0) * 1e-3;
    const double loss = -v * v * (*lag_s * *lag_s + dtau * dtau / 4.0) / (2.0 * R);
    mean_scale = (*fr.dr_mm.value - loss) / R;
    mean_scale_se = fr.dr_mm.standard_error.value_or(0.0) / R;
    if (*lag_s > 2.0 * period) {
      D.kv_per_s.value = 1.0 / *lag_s;
      D.kv_source = "lag";
    }
    if (!td.feedback)
      D.notes.push_back(fmt::format(
          "one feed: the servo radius loss ({:.2f} um) is taken from the following lag against "
          "the commanded columns ({:.3f} ms); the rest of the radius change is scale",
          loss * 1e3, *lag_s * 1e3));
  } else if (ev.nominal_radius_mm) {
    D.notes.push_back(
        "one feed and no commanded columns: the radius change mixes the mean scale of the "
        "axes and the servo radius loss; absolute scale not reported (run two feeds)");
  }
  if (td.feedback) {
    // The loop drives its feedback to the command whatever the machine's scale: what the
    // radius and the cos 2theta term show here is the loop's amplitude response (a first-order
    // loss from the lag only where the loop is first order), never scale.
    mean_scale.reset();
    if (D.scale_mismatch_ppm.value) {
      D.unseparable.emplace_back(diagnosis_json::key::scale_mismatch_ppm);
      D.scale_mismatch_ppm = {};
    }
    D.unseparable.emplace_back(diagnosis_json::key::scale_ppm);
    D.notes.push_back(fmt::format(
        "the positions are the motor feedback ({}, {}): the loop drives them to the command "
        "whatever the machine's scale, so their radius and ellipse are the servo's amplitude "
        "response; scale and scale mismatch not reported (they need an instrument)",
        in.ev.channel_a, in.ev.channel_b));
  } else if (!D.absolute_channels) {
    mean_scale.reset();
    D.notes.push_back("instrument is not absolute (ballbar): only the scale mismatch is reported");
  }
  MeanScale out;
  if (mean_scale) {
    out.value = mean_scale;
    out.se = mean_scale_se.value_or(0.0);
  }
  if (mean_scale && mismatch_ppm) {
    const double se_ds = D.scale_mismatch_ppm.standard_error.value_or(0.0);
    const double m = *mean_scale * 1e6, mse = mean_scale_se.value_or(0.0) * 1e6;
    D.scale_ppm[0].value = m + *mismatch_ppm / 2;
    D.scale_ppm[1].value = m - *mismatch_ppm / 2;
    D.scale_ppm[0].standard_error = D.scale_ppm[1].standard_error = std::hypot(mse, se_ds / 2);
  }
  return out;
}

}  // namespace circtest::diagnosis_detail
