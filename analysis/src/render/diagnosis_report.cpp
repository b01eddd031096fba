// The diagnosis as text (its JSON: core/diagnosis_document.hpp).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <iterator>

#include "circtest/analysis/diagnosis.hpp"

namespace circtest {

namespace {

std::string um(double mm) {
  return fmt::format("{:.2f} um", mm * 1e3);
}

// The residual's G as a share of the measured G: the part of G the model does not explain;
// the measured G with its U (k = 2) when the diagnosis holds it.
std::string residual_share(const Diagnosis& d) {
  if (!d.measured_g_mm || !(*d.measured_g_mm > 0)) return {};
  return fmt::format(
      " ({:.1f} % of the measured G {}{})", d.residual_g_mm / *d.measured_g_mm * 100.0,
      um(*d.measured_g_mm),
      d.measured_g_u_mm ? fmt::format(", U = {} (k = 2)", um(*d.measured_g_u_mm)) : "");
}

std::string pm_um(const Estimate& e) {
  if (!e.value) return "not available";
  return fmt::format("{:+.2f} um (+- {:.2f})", *e.value * 1e3, e.standard_error.value_or(0) * 1e3);
}

// The servo per axis: lag, gain and source, the mismatch, and per feed the ellipse's share.
void servo_axis_lines(const Diagnosis& d, std::string& s) {
  auto out = std::back_inserter(s);
  for (std::size_t k = 0; k < 2; ++k) {
    const AxisLag& al = d.axis_lag[k];
    if (!al.lag_ms.value) {
      fmt::format_to(out, "  {} servo lag: not measured\n", d.axes[k]);
      continue;
    }
    // A lag within twice its standard error of zero gives no gain worth a number (1 / lag).
    const double lag_se_ms = al.lag_ms.standard_error.value_or(0);
    const std::string gain = !al.kv_per_s ? "not positive"
                             : *al.lag_ms.value <= 2 * lag_se_ms
                                 ? "not measurable (the lag is within its uncertainty of 0)"
                                 : fmt::format("{:.2f} 1/s", *al.kv_per_s);
    fmt::format_to(out, "  {} servo lag {:.3f} ms (+- {:.3f}), position gain {} (from the {})\n",
                   d.axes[k], *al.lag_ms.value, lag_se_ms, gain,
                   al.source == "feedback"     ? "motor feedback"
                   : al.source == "instrument" ? "instrument"
                                               : "radius change over the feeds");
  }
  if (d.axis_lag_mismatch_ms.value) {
    fmt::format_to(out, "  servo lag mismatch {} - {}: {:+.3f} ms (+- {:.3f})\n", d.axes[0],
                   d.axes[1], *d.axis_lag_mismatch_ms.value,
                   d.axis_lag_mismatch_ms.standard_error.value_or(0));
  }
  for (const ServoShare& sh : d.servo_share) {
    fmt::format_to(out, "  servo mismatch ellipse at {:.0f} mm/min: G {:.2f} um{}\n",
                   sh.feed_mm_per_min, sh.g_mm * 1e3,
                   sh.percent ? fmt::format(" ({:.0f} % of the measured {:.2f} um)", *sh.percent,
                                            *sh.measured_g_mm * 1e3)
                              : "");
  }
}

}  // namespace

std::string text_report(const Diagnosis& d) {
  std::string s;
  auto out = std::back_inserter(s);
  const std::string A(1, d.axes[0]), B(1, d.axes[1]);
  fmt::format_to(out, "Diagnosis of {}: plane {}, {} runs, {} samples, radius {:.3f} mm", d.source,
                 plane_name(d.plane), d.runs, d.samples, d.radius_mm);
  if (!d.feeds_mm_per_min.empty()) {
    s += ", feeds";
    for (double f : d.feeds_mm_per_min) fmt::format_to(out, " {:.0f}", f);
    s += " mm/min";
  }
  s += "\n(model and signs: docs/diagnosis.md; +- one standard error)\n\n";
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string X(1, d.axes[k]);
    const Estimate& b = d.backlash_mm[k];
    if (b.value) {
      fmt::format_to(out, "  {} backlash {:.1f} um (+- {:.2f}){}\n", X, *b.value * 1e3,
                     b.standard_error.value_or(0) * 1e3,
                     *b.value < -std::max(1e-4, 2 * b.standard_error.value_or(0))
                         ? ": negative, over-compensated"
                         : (*b.value > 1e-4 ? " of lost motion" : ""));
      if (const auto& e = d.backlash_reversals_mm[k]) {
        fmt::format_to(out, "    at the + end of {} {:.1f} um, at the - end {:.1f} um\n", X,
                       (*e)[0] * 1e3, (*e)[1] * 1e3);
      }
    } else {
      fmt::format_to(out, "  {} backlash: not available\n", X);
    }
    const Estimate& h = d.spike_mm[k];
    if (h.value && d.spike_ms[k].value) {
      fmt::format_to(
          out, "  {} reversal spike {:.1f} um (+- {:.2f}), decaying in {:.1f} ms (+- {:.1f})\n", X,
          *h.value * 1e3, h.standard_error.value_or(0) * 1e3, *d.spike_ms[k].value,
          d.spike_ms[k].standard_error.value_or(0));
    } else if (h.value) {
      fmt::format_to(out, "  {} reversal spike: none stands out of the noise\n", X);
    }
  }
  if (d.squareness_urad.value) {
    const double a = *d.squareness_urad.value;
    fmt::format_to(out,
                   "  squareness {:+.1f} urad (+- {:.2f}): the angle between +{} and +{} is 90 deg "
                   "{} {:.1f} urad ({:.5f} deg)\n",
                   a, d.squareness_urad.standard_error.value_or(0), A, B, a >= 0 ? "-" : "+",
                   std::abs(a), 90.0 - a * 1e-6 * 180.0 / M_PI);
  } else {
    s += "  squareness: not available\n";
  }
  if (d.scale_mismatch_ppm.value) {
    fmt::format_to(out, "  scale mismatch s_{} - s_{} = {:+.1f} ppm (+- {:.2f})\n", A, B,
                   *d.scale_mismatch_ppm.value, d.scale_mismatch_ppm.standard_error.value_or(0));
  }
  for (std::size_t k = 0; k < 2; ++k) {
    if (d.scale_ppm[k].value) {
      fmt::format_to(out, "  {} scale {:+.1f} ppm (+- {:.2f})\n", std::string(1, d.axes[k]),
                     *d.scale_ppm[k].value, d.scale_ppm[k].standard_error.value_or(0));
    }
  }
  if (d.servo_mismatch_ms.value) {
    const double m = *d.servo_mismatch_ms.value;
    fmt::format_to(out, "  servo mismatch: {} lags {} by {:.3f} ms (+- {:.3f})\n", m >= 0 ? A : B,
                   m >= 0 ? B : A, std::abs(m), d.servo_mismatch_ms.standard_error.value_or(0));
  } else {
    s += "  servo mismatch: not available\n";
  }
  for (const auto& fr : d.radius_change) {
    fmt::format_to(out, "  radius change at {:.0f} mm/min: {}\n", fr.feed_mm_per_min,
                   pm_um(fr.dr_mm));
  }
  if (d.lag_ms.value) fmt::format_to(out, "  mean following lag {:.3f} ms\n", *d.lag_ms.value);
  if (d.kv_per_s.value) {
    fmt::format_to(out, "  position-loop gain Kv {:.1f} 1/s (from the {})\n", *d.kv_per_s.value,
                   d.kv_source == "feeds" ? "radius change over the feeds" : "following lag");
  }
  servo_axis_lines(d, s);
  for (std::size_t k = 0; k < 2; ++k) {
    const auto& c = d.cyclic[k];
    if (c) {
      fmt::format_to(out, "  {} cyclic error {:.2f} um (+- {:.2f}) at pitch {:.3f} mm ({})",
                     std::string(1, d.axes[k]), c->amplitude_mm * 1e3, c->amplitude_se_mm * 1e3,
                     c->pitch_mm, c->pitch_source);
      if (c->peak_to_median_power) {
        fmt::format_to(out, ", periodogram peak {:.0f}x the median", *c->peak_to_median_power);
      }
      s += '\n';
    }
  }
  if (!d.unseparable.empty()) {
    fmt::format_to(out, "  cannot be separated by this trace (not reported): {}\n",
                   fmt::join(d.unseparable, ", "));
  }
  fmt::format_to(out, "  set-up centre offset {}, {}\n", pm_um(d.centre_offset_mm[0]),
                 pm_um(d.centre_offset_mm[1]));
  fmt::format_to(out, "\nContributions to the modelled G of {} (ranked)\n", um(d.model_g_mm));
  for (const auto& c : d.contributions) {
    fmt::format_to(out, "  {:<18} G {:>9}  {:5.1f} %\n", c.source, um(c.g_mm), c.percent);
  }
  fmt::format_to(out, "Residual (measured - model): RMS {}, G {}{}\n", um(d.residual_rms_mm),
                 um(d.residual_g_mm), residual_share(d));
  for (const auto& n : d.notes) fmt::format_to(out, "Note: {}\n", n);
  return s;
}

std::string short_text_report(const Diagnosis& d) {
  std::string s = "\nDiagnosis (circana diagnose for details)\n";
  auto out = std::back_inserter(s);
  std::size_t shown = 0;
  for (const auto& c : d.contributions) {
    if (shown++ == 4) break;
    fmt::format_to(out, "  {:<18} G {:>9}  {:5.1f} %\n", c.source, um(c.g_mm), c.percent);
  }
  fmt::format_to(out, "  residual RMS {}, G {}{}\n", um(d.residual_rms_mm), um(d.residual_g_mm),
                 residual_share(d));
  return s;
}

}  // namespace circtest
