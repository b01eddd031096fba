// The last stage: a diagnosis whose numbers are not all finite is refused, never printed.
#include <fmt/format.h>

#include <cmath>

#include "circtest/core/error.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

// The first number of the diagnosis that is not finite, by name; none when all are. A fit the
// samples do not determine (noise far above the radius, feeds from a time column that stalls
// and jumps) can leave NaN in its solution, which no output may carry.
std::optional<std::string> first_not_finite(const Diagnosis& D) {
  const auto bad = [](const std::optional<double>& v) { return v && !std::isfinite(*v); };
  const auto bad_estimate = [&](const Estimate& e) {
    return bad(e.value) || bad(e.standard_error);
  };
  for (std::size_t ax = 0; ax < 2; ++ax) {
    const std::string axis(1, D.axes[ax]);
    if (bad_estimate(D.backlash_mm[ax])) return "backlash " + axis;
    if (bad_estimate(D.spike_mm[ax]) || bad_estimate(D.spike_ms[ax])) return "spike " + axis;
    if (bad_estimate(D.scale_ppm[ax])) return "scale " + axis;
    if (bad_estimate(D.centre_offset_mm[ax])) return "centre offset " + axis;
    if (const auto& r = D.backlash_reversals_mm[ax]; r && (bad((*r)[0]) || bad((*r)[1]))) {
      return "backlash at the reversals of " + axis;
    }
    if (const auto& c = D.cyclic[ax];
        c && !(std::isfinite(c->amplitude_mm) && std::isfinite(c->pitch_mm) &&
               std::isfinite(c->phase_rad) && std::isfinite(c->amplitude_se_mm))) {
      return "cyclic error " + axis;
    }
  }
  if (bad_estimate(D.scale_mismatch_ppm)) return std::string("scale mismatch");
  if (bad_estimate(D.squareness_urad)) return std::string("squareness");
  if (bad_estimate(D.servo_mismatch_ms)) return std::string("servo mismatch");
  if (bad_estimate(D.kv_per_s)) return std::string("Kv");
  if (bad_estimate(D.lag_ms)) return std::string("following lag");
  for (const FeedRadius& f : D.radius_change) {
    if (bad_estimate(f.dr_mm)) return std::string("radius change");
  }
  for (const Contribution& c : D.contributions) {
    if (!std::isfinite(c.g_mm) || !std::isfinite(c.share_mm) || !std::isfinite(c.percent)) {
      return "contribution of " + c.source;
    }
  }
  if (!std::isfinite(D.model_g_mm)) return std::string("modelled G");
  if (!std::isfinite(D.residual_rms_mm) || !std::isfinite(D.residual_g_mm)) {
    return std::string("residual");
  }
  return std::nullopt;
}

}  // namespace

void check_finite(const Inputs& in, const SampleSet& ss, const Diagnosis& D) {
  const Trace& trace = in.trace;
  const Evaluation& ev = in.ev;
  const Samples& S = ss.S;
  if (const auto what = first_not_finite(D)) {
    const Run& first = ev.runs.front().run;
    throw DataError(trace.source, trace.line_of_row[first.begin],
                    fmt::format("diagnosis not measurable: the model fit gives no finite {} on "
                                "these {} samples (lines {}-{}): the samples do not determine "
                                "the model (noise far above the errors, or a time column that "
                                "stalls and jumps)",
                                *what, S.size(), trace.line_of_row[first.begin],
                                trace.line_of_row[ev.runs.back().run.end - 1]));
  }
}

}  // namespace circtest::diagnosis_detail
