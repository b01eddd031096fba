#include "circtest/analysis/uncertainty.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <utility>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest {

namespace {

const double kSqrt2 = std::sqrt(2.0);
const double kSqrt3 = std::sqrt(3.0);

// The defaults of a profile (docs/uncertainty.md says where each comes from).
struct ProfileDefaults {
  double calibration_mm;   // standard uncertainty of the radius reading (normal)
  double resolution_mm;    // digit step
  double centring_mm;      // standard uncertainty of the set-up centre
  double unseen_mm;        // half-width of what the scales cannot see (scales only)
  double expansion_per_K;  // the instrument's own expansion, for the budget's note
};

ProfileDefaults defaults_of(InstrumentProfile p) {
  switch (p) {
    case InstrumentProfile::ballbar:
      return {0.0005, 0.0001, 0.002, 0.0, 0.0};
    case InstrumentProfile::grid_encoder:
      return {0.0005, 0.000001, 0.005, 0.0, 0.0};
    default:
      return {0.001, 0.001, 0.0, 0.002, 0.0};
  }
}

bool ends_with(const std::string& s, std::string_view tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The profile of the evaluation: stated, else from its channels and instrument metadata.
std::pair<InstrumentProfile, std::string> profile_of(const Evaluation& ev,
                                                     const UncertaintyOptions& o) {
  if (o.profile != InstrumentProfile::automatic) return {o.profile, "stated"};
  if (ends_with(ev.channel_a, "_r")) return {InstrumentProfile::ballbar, "the length channel r"};
  if (ends_with(ev.channel_a, "_fb")) {
    return {InstrumentProfile::scales, "the feedback channel " + ev.channel_a};
  }
  if (const std::string* i = ev.conditions.find(meta_key::instrument); i && !i->empty()) {
    const std::string l = lower(*i);
    if (l.find("grid") != std::string::npos || l.find("kgm") != std::string::npos) {
      return {InstrumentProfile::grid_encoder, "instrument: " + *i};
    }
    if (l.find("ball") != std::string::npos || l.find("qc") != std::string::npos) {
      return {InstrumentProfile::ballbar, "instrument: " + *i};
    }
    if (l.find("feedback") != std::string::npos || l.find("scale") != std::string::npos) {
      return {InstrumentProfile::scales, "instrument: " + *i};
    }
  }
  return {InstrumentProfile::scales,
          "no instrument recorded: taken as the machine's own scales (no external instrument)"};
}

// Pooled standard deviation of a quantity over groups of repeated runs; nullopt without a
// group of two or more.
std::optional<double> pooled_sd(const std::vector<std::vector<double>>& groups) {
  double ss = 0.0;
  std::size_t dof = 0;
  for (const auto& g : groups) {
    if (g.size() < 2) continue;
    double mean = 0.0;
    for (double v : g) mean += v;
    mean /= static_cast<double>(g.size());
    for (double v : g) ss += (v - mean) * (v - mean);
    dof += g.size() - 1;
  }
  if (dof == 0) return std::nullopt;
  return std::sqrt(ss / static_cast<double>(dof));
}

bool same_feed(const std::optional<double>& a, const std::optional<double>& b) {
  if (!a || !b) return !a && !b;
  return std::abs(*a - *b) <= 0.05 * std::max(*a, *b);
}

// Runs grouped by direction and feed: the repeated runs of one test.
std::vector<std::vector<std::size_t>> repeat_groups(const Evaluation& ev) {
  std::vector<std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < ev.runs.size(); ++i) {
    auto it = std::find_if(groups.begin(), groups.end(), [&](const auto& g) {
      const RunResult& r = ev.runs[g.front()];
      return r.run.direction == ev.runs[i].run.direction &&
             same_feed(r.feed_mm_per_min, ev.runs[i].feed_mm_per_min);
    });
    if (it == groups.end()) {
      groups.push_back({i});
    } else {
      it->push_back(i);
    }
  }
  return groups;
}

void add_repeatability(const Evaluation& ev, const UncertaintyOptions& o,
                       std::vector<UncertaintyContribution>& out) {
  const auto groups = repeat_groups(ev);
  std::vector<std::vector<double>> g_values, f_values, h_values;
  for (const auto& g : groups) {
    std::vector<double> gs, fmax, fmin;
    for (std::size_t i : g) {
      gs.push_back(ev.runs[i].g_mm(ev.g_method));
      if (ev.runs[i].f_max_mm) {
        fmax.push_back(*ev.runs[i].f_max_mm);
        fmin.push_back(*ev.runs[i].f_min_mm);
      }
    }
    g_values.push_back(std::move(gs));
    f_values.push_back(std::move(fmax));
    f_values.push_back(std::move(fmin));
  }
  // Pairs at one feed are repeats of one H.
  std::vector<std::optional<double>> h_feeds;
  for (const auto& h : ev.hysteresis) {
    const std::optional<double>& feed = ev.runs[h.run_ccw].feed_mm_per_min;
    std::size_t k = 0;
    while (k < h_feeds.size() && !same_feed(h_feeds[k], feed)) ++k;
    if (k == h_feeds.size()) {
      h_feeds.push_back(feed);
      h_values.emplace_back();
    }
    h_values[k].push_back(h.h_mm);
  }
  const auto measured_g = pooled_sd(g_values);
  const auto measured_f = pooled_sd(f_values);
  const auto measured_h = pooled_sd(h_values);
  struct Item {
    const char* name;
    const std::optional<double>& stated;
    std::optional<double> measured;
    std::optional<double> derived;  // H from G's repeatability
    double fallback;
    double UncertaintyContribution::*coefficient;
  };
  const Item items[] = {
      {"repeatability of G", o.repeatability_g_mm, measured_g, std::nullopt,
       kDefaultRepeatabilityMm, &UncertaintyContribution::c_g},
      {"repeatability of H", o.repeatability_h_mm, measured_h,
       measured_g ? std::optional<double>(*measured_g * kSqrt2) : std::nullopt,
       kDefaultRepeatabilityMm * kSqrt2, &UncertaintyContribution::c_h},
      {"repeatability of F", o.repeatability_f_mm, measured_f, std::nullopt,
       kDefaultRepeatabilityMm, &UncertaintyContribution::c_f},
  };
  for (const Item& item : items) {
    UncertaintyContribution c;
    c.name = item.name;
    if (item.stated) {
      c.value_mm = *item.stated;
      c.source = "option";
      c.note = "stated standard deviation of a single result";
    } else if (item.measured) {
      c.value_mm = *item.measured;
      c.source = "measured";
      c.note = "pooled standard deviation over the repeated runs of one direction and feed";
    } else if (item.derived) {
      c.value_mm = *item.derived;
      c.source = "measured";
      c.note = "sqrt(2) x the repeatability of G: H is the difference of two runs";
    } else {
      c.value_mm = item.fallback;
      c.source = "stated assumption";
      c.note = "not measured: no repeated runs of one direction (circgen --repeat N)";
    }
    c.*item.coefficient = 1.0;
    out.push_back(std::move(c));
  }
}

void add_temperature(const Evaluation& ev, double radius_mm, const UncertaintyOptions& o,
                     std::vector<UncertaintyContribution>& out) {
  const Temperatures& t = ev.temperatures;
  const double a_m = t.machine_expansion_per_K;
  const double a_i = t.instrument_expansion_per_K;
  if (!t.available()) {
    UncertaintyContribution c;
    c.name = "temperature";
    c.value_mm = radius_mm * std::abs(a_m - a_i) * o.assumed_temperature_half_width_K;
    c.distribution = Distribution::rectangular;
    c.source = "stated assumption";
    c.note = fmt::format(
        "no temperatures recorded, F not corrected: machine and instrument taken at 20 +- {:g} "
        "deg C, R x |a_m - a_i| x {:g} K (a_m = {:g}/K, a_i = {:g}/K); G and H scale by the "
        "same factor, negligible",
        o.assumed_temperature_half_width_K, o.assumed_temperature_half_width_K, a_m, a_i,
        o.assumed_temperature_half_width_K);
    c.c_f = 1.0;
    out.push_back(std::move(c));
    return;
  }
  auto one = [&](const char* name, const std::optional<double>& temp, double a) {
    UncertaintyContribution c;
    c.name = name;
    c.c_f = 1.0;
    if (temp) {
      const double dt = *temp - 20.0;
      c.value_mm = radius_mm * std::hypot(a * o.thermometer_K, a * o.expansion_relative * dt);
      c.source = "measured";
      c.note = fmt::format(
          "recorded {:.2f} deg C, corrected to 20 deg C; R x sqrt((a u_T)^2 + (u_a dT)^2) with "
          "u_T = {:g} K, u_a = {:g} x a = {:g}/K",
          *temp, o.thermometer_K, o.expansion_relative, a);
    } else {
      c.value_mm = radius_mm * std::abs(a) * o.assumed_temperature_half_width_K;
      c.distribution = Distribution::rectangular;
      c.source = "stated assumption";
      c.note = fmt::format("not recorded: taken as 20 +- {:g} deg C, a = {:g}/K",
                           o.assumed_temperature_half_width_K, a);
    }
    out.push_back(std::move(c));
  };
  one("temperature of the machine", t.machine_C, a_m);
  one("temperature of the instrument", t.instrument_C, a_i);
}

// Thermal drift: the temperature changing during the test moves the radius the instrument
// reads by R (a_m dT_m + a_i dT_i) (each coefficient's magnitude: their signs are not known
// to cancel). Within a run the run's end misses its start by it (G), over a CCW/CW pair the
// two runs' radii differ by it (H), and F, corrected at one temperature, departs by it.
void add_drift(const Evaluation& ev, double radius_mm, const UncertaintyOptions& o,
               std::vector<UncertaintyContribution>& out) {
  const BudgetMeasurements& m = ev.budget_inputs;
  const double a_m = std::abs(ev.temperatures.machine_expansion_per_K);
  const double a_i = std::abs(ev.temperatures.instrument_expansion_per_K);
  struct Part {
    const char* name;
    const char* what;
    double machine_K, instrument_K;
    const std::optional<double>& duration_s;
    double UncertaintyContribution::*coefficient;
  };
  const Part parts[] = {
      {"thermal drift within a run", "within a run", m.machine_run_K, m.instrument_run_K, m.run_s,
       &UncertaintyContribution::c_g},
      {"thermal drift over a CCW/CW pair", "over a CCW/CW pair", m.machine_pair_K,
       m.instrument_pair_K, m.pair_s, &UncertaintyContribution::c_h},
      {"thermal drift from the temperature F is corrected at", "from the corrected temperature",
       m.machine_from_corrected_K, m.instrument_from_corrected_K, m.test_s,
       &UncertaintyContribution::c_f},
  };
  for (const Part& p : parts) {
    UncertaintyContribution c;
    c.name = p.name;
    c.distribution = Distribution::rectangular;
    c.*p.coefficient = 1.0;
    if (!m.drift_source.empty()) {
      // Measured: an effect of this size, not corrected (a bias: added to U as it is).
      c.distribution = Distribution::bias;
      c.value_mm = radius_mm * (a_m * p.machine_K + a_i * p.instrument_K);
      c.source = "measured";
      c.note = fmt::format(
          "temperatures recorded over the test ({}): machine {:.3f} K, instrument {:.3f} K {} "
          "(a straight line through the readings); R x (a_m dT_m + a_i dT_i), not corrected: "
          "added to U",
          m.drift_source, p.machine_K, p.instrument_K, p.what);
    } else if (p.duration_s) {
      // Machine and instrument in one room: their difference drifts (as the stated 20 +- 2 K).
      const double change_K = o.assumed_drift_K_per_h * *p.duration_s / 3600.0;
      c.value_mm = radius_mm * std::abs(a_m - a_i) * change_K;
      c.source = "stated assumption";
      c.note = fmt::format(
          "no temperatures recorded over the test (once or not at all): the drift is not "
          "measured, taken as {:g} K/h over {:.1f} s {} ({:.4f} K), R x |a_m - a_i| x dT",
          o.assumed_drift_K_per_h, *p.duration_s, p.what, change_K);
    } else {
      c.source = "not known";
      c.note =
          "no temperatures recorded over the test and no time column to time the runs: the "
          "drift is not known and not included";
    }
    out.push_back(std::move(c));
  }
}

// The readings' noise widens the zone: its largest values among the samples near each edge
// (a bias per quantity, with the sensitivity 1 so that tests alike share one table), and the
// spread of those largest values about their expected size.
void add_noise(const Evaluation& ev, std::vector<UncertaintyContribution>& out) {
  const BudgetMeasurements& m = ev.budget_inputs;
  struct Part {
    const char* name;
    double value_mm;
    double UncertaintyContribution::*coefficient;
  };
  const Part parts[] = {
      {"measurement noise: widening of G", m.noise_g_mm, &UncertaintyContribution::c_g},
      {"measurement noise: widening of F", m.noise_f_mm, &UncertaintyContribution::c_f},
      {"measurement noise: widening of H", m.noise_h_mm, &UncertaintyContribution::c_h},
  };
  for (const Part& p : parts) {
    UncertaintyContribution c;
    c.name = p.name;
    // The zone only widens: a bias of the expected size, not corrected, added to U.
    c.distribution = Distribution::bias;
    c.value_mm = p.value_mm;
    c.source = "measured";
    c.*p.coefficient = 1.0;
    c.note = fmt::format(
        "the readings scatter by {:.3f} um from sample to sample (standard deviation, from "
        "second differences of the radius); the expected largest noise among the {} and {} "
        "samples near the zone's edges (H: of two runs' difference); not corrected: added to U",
        m.noise_mm * 1000.0, m.noise_samples_top, m.noise_samples_bottom);
    out.push_back(std::move(c));
  }
  // The largest of m noise values scatters about its expected value too (Gumbel: a standard
  // deviation of pi / sqrt(6) / sqrt(2 ln m) of the noise, at most the noise itself).
  auto spread = [](std::size_t count) {
    if (count <= 2) return 1.0;
    return std::min(1.0, 1.2825 / std::sqrt(2.0 * std::log(static_cast<double>(count))));
  };
  const double s = std::max(spread(m.noise_samples_top), spread(m.noise_samples_bottom));
  UncertaintyContribution r;
  r.name = "measurement noise: spread of its largest values";
  r.value_mm = m.noise_mm * s;
  r.source = "measured";
  r.c_g = kSqrt2;  // two edges
  r.c_f = 1.0;
  r.c_h = kSqrt2;  // two runs
  r.note = fmt::format(
      "the noise's largest value among the samples near an edge varies from test to test by "
      "{:.2f} of the noise's standard deviation",
      s);
  out.push_back(std::move(r));
}

double sample_period_s(const Evaluation& ev) {
  if (const std::string* p = ev.conditions.find(meta_key::sample_period_s)) {
    try {
      return std::stod(*p);
    } catch (...) {
      return 0.0;
    }
  }
  return 0.0;
}

// U = k sqrt(sum (c u)^2) + sum c b: the root sum of squares of the uncertainties, expanded,
// and the uncorrected biases added as they are.
void combine(UncertaintyBudget& b) {
  double g = 0.0, h = 0.0, f = 0.0;
  double bias_g = 0.0, bias_h = 0.0, bias_f = 0.0;
  for (const auto& c : b.contributions) {
    const double u = c.standard_mm();
    if (c.distribution == Distribution::bias) {
      bias_g += std::abs(c.c_g) * u;
      bias_h += std::abs(c.c_h) * u;
      bias_f += std::abs(c.c_f) * u;
      continue;
    }
    g += c.c_g * c.c_g * u * u;
    h += c.c_h * c.c_h * u * u;
    f += c.c_f * c.c_f * u * u;
  }
  b.u_g_mm = b.k * std::sqrt(g) + bias_g;
  b.u_h_mm = b.k * std::sqrt(h) + bias_h;
  b.u_f_mm = b.k * std::sqrt(f) + bias_f;
}

void add_instrument(InstrumentProfile profile, const ProfileDefaults& d,
                    const UncertaintyOptions& o, std::vector<UncertaintyContribution>& out) {
  UncertaintyContribution cal;
  cal.name = "instrument calibration";
  cal.value_mm = o.calibration_mm.value_or(d.calibration_mm);
  cal.source = o.calibration_mm ? "option" : "profile default";
  cal.note = profile == InstrumentProfile::scales
                 ? "the scales' accuracy at the test's radius; a length error enters F only"
                 : "the calibration certificate's uncertainty of the length (k = 1); enters F "
                   "only";
  cal.c_f = 1.0;
  out.push_back(std::move(cal));
  UncertaintyContribution res;
  res.name = "instrument resolution";
  res.value_mm = o.resolution_mm.value_or(d.resolution_mm) / 2.0;
  res.distribution = Distribution::rectangular;
  res.source = o.resolution_mm ? "option" : "profile default";
  res.note = "half a digit; G and H are differences of two readings (x sqrt 2)";
  res.c_g = kSqrt2;
  res.c_h = kSqrt2;
  res.c_f = 1.0;
  out.push_back(std::move(res));
}

void add_centring(const Evaluation& ev, InstrumentProfile profile, double radius_mm,
                  const ProfileDefaults& d, const UncertaintyOptions& o,
                  std::vector<UncertaintyContribution>& out) {
  const bool nominal = std::any_of(ev.runs.begin(), ev.runs.end(), [](const RunResult& r) {
    return r.f_centre_method == FCentreMethod::nominal;
  });
  UncertaintyContribution c;
  c.name = "set-up centring";
  c.value_mm = o.centring_mm.value_or(d.centring_mm);
  c.source = o.centring_mm ? "option" : "profile default";
  const double second_order = radius_mm > 0 ? c.value_mm / (2.0 * radius_mm) : 0.0;
  if (profile == InstrumentProfile::ballbar) {
    // The bar reads |p - pivot|: an offset e of the pivot is a first-order centre shift the
    // fits remove, plus a second-order e^2 / (2R).
    c.c_g = second_order;
    c.c_h = second_order;
    c.c_f = nominal ? 1.0 : second_order;
    c.note =
        "G, H: second order e^2/(2R) only (the fit takes the centre); F " +
        std::string(nominal ? "about the set-up centre: first order" : "about the LSC: e^2/(2R)");
  } else {
    // Positions shift as a whole: the fits take it; F about the set-up centre does not.
    c.c_f = nominal ? 1.0 : 0.0;
    c.note = std::string("a shift of all positions: G, H not affected; F ") +
             (nominal ? "about the set-up centre: first order" : "about the LSC: not affected");
  }
  out.push_back(std::move(c));
}

void add_evaluation_terms(const Evaluation& ev, double radius_mm,
                          std::vector<UncertaintyContribution>& out) {
  double feed = 0.0;
  for (const auto& r : ev.runs) feed = std::max(feed, r.feed_mm_per_min.value_or(0.0));
  const double period = sample_period_s(ev);
  UncertaintyContribution s;
  s.name = "sampling";
  s.distribution = Distribution::rectangular;
  if (feed > 0 && period > 0 && radius_mm > 0) {
    const double step = feed / 60.0 * period;
    s.value_mm = step * step / (8.0 * radius_mm);
    s.source = "measured";
    s.note = fmt::format(
        "{:.4f} mm travel per sample ({:.0f} mm/min, {:g} s): the path between two samples "
        "sags d^2/(8R) from their chord; a feature shorter than a sample shows in the "
        "repeatability",
        step, feed, period);
  } else {
    s.source = "stated assumption";
    s.note = "feed or sample period unknown: taken as negligible";
  }
  s.c_g = s.c_h = s.c_f = 1.0;
  out.push_back(std::move(s));
  UncertaintyContribution fit;
  fit.name = "fit (least squares vs minimum zone)";
  fit.distribution = Distribution::rectangular;
  double diff = 0.0;
  bool certified = true;
  for (const auto& r : ev.runs) {
    diff = std::max(diff, std::abs(r.g_lsc_mm - r.g_mzc_mm));
    certified = certified && r.mzc.certified;
  }
  if (ev.g_method == GMethod::least_squares || !certified) {
    fit.value_mm = diff;
    fit.source = "measured";
    fit.note =
        "G by a method other than the certified minimum zone: half-width the largest "
        "difference of the two G";
  } else {
    fit.source = "measured";
    fit.note = fmt::format(
        "G by the certified minimum zone: no contribution (the least-squares G differs by up to "
        "{:.2f} um, a different measurand)",
        diff * 1000.0);
  }
  fit.c_g = 1.0;
  out.push_back(std::move(fit));
}

}  // namespace

std::string_view instrument_profile_name(InstrumentProfile p) noexcept {
  switch (p) {
    case InstrumentProfile::automatic:
      return "auto";
    case InstrumentProfile::ballbar:
      return "ballbar";
    case InstrumentProfile::grid_encoder:
      return "grid-encoder";
    case InstrumentProfile::scales:
      return "scales";
  }
  return "auto";
}

std::optional<InstrumentProfile> parse_instrument_profile(std::string_view name) {
  for (auto p : {InstrumentProfile::automatic, InstrumentProfile::ballbar,
                 InstrumentProfile::grid_encoder, InstrumentProfile::scales}) {
    if (instrument_profile_name(p) == name) return p;
  }
  return std::nullopt;
}

std::string_view distribution_name(Distribution d) noexcept {
  switch (d) {
    case Distribution::normal:
      return "normal";
    case Distribution::rectangular:
      return "rectangular";
    case Distribution::bias:
      return "bias";
  }
  return "normal";
}

double UncertaintyContribution::standard_mm() const {
  return distribution == Distribution::rectangular ? value_mm / kSqrt3 : value_mm;
}

UncertaintyBudget uncertainty_budget(const Evaluation& ev, const UncertaintyOptions& o) {
  UncertaintyBudget b;
  std::tie(b.profile, b.profile_note) = profile_of(ev, o);
  const ProfileDefaults d = defaults_of(b.profile);
  double radius_mm = ev.nominal_radius_mm.value_or(0.0);
  if (radius_mm <= 0 && !ev.runs.empty()) radius_mm = ev.runs.front().lsc.radius_mm;
  add_instrument(b.profile, d, o, b.contributions);
  add_temperature(ev, radius_mm, o, b.contributions);
  add_drift(ev, radius_mm, o, b.contributions);
  add_centring(ev, b.profile, radius_mm, d, o, b.contributions);
  add_repeatability(ev, o, b.contributions);
  add_evaluation_terms(ev, radius_mm, b.contributions);
  add_noise(ev, b.contributions);
  if (b.profile == InstrumentProfile::scales) {
    UncertaintyContribution u;
    u.name = "what the scales cannot see";
    u.value_mm = o.unseen_mm.value_or(d.unseen_mm);
    u.distribution = Distribution::rectangular;
    u.source = o.unseen_mm ? "option" : "stated assumption";
    u.note =
        "a test on the feedback signal (ISO 230-4 Annex E): the path between the scales and the "
        "tool (pitch, play, bending, heat) is not measured; a model term, not a measurement";
    u.c_g = u.c_h = u.c_f = 1.0;
    b.contributions.push_back(std::move(u));
  }
  combine(b);
  return b;
}

UncertaintyBudget without_contribution(const UncertaintyBudget& budget, std::string_view name) {
  UncertaintyBudget b = budget;
  std::erase_if(b.contributions, [name](const UncertaintyContribution& c) {
    return c.name.compare(0, name.size(), name) == 0;
  });
  combine(b);
  return b;
}

Decision decide(double value_mm, double u_mm, double limit_mm) noexcept {
  if (value_mm + u_mm <= limit_mm) return Decision::pass;
  if (value_mm - u_mm > limit_mm) return Decision::fail;
  return Decision::not_decided;
}

std::string_view decision_words(Decision d) noexcept {
  switch (d) {
    case Decision::pass:
      return "pass";
    case Decision::fail:
      return "fail";
    case Decision::not_decided:
      return "not decided: within the uncertainty";
  }
  return "not decided: within the uncertainty";
}

std::vector<LimitDecision> decide_limits(const Evaluation& ev, const UncertaintyBudget& b,
                                         const ResultLimits& limits) {
  std::optional<double> h, g, f;
  auto keep_max = [](std::optional<double>& m, double v) { m = m ? std::max(*m, v) : v; };
  for (const auto& p : ev.hysteresis) keep_max(h, p.h_mm);
  for (const auto& r : ev.runs) {
    keep_max(g, r.g_mm(ev.g_method));
    if (r.f_max_mm) keep_max(f, std::max(std::abs(*r.f_max_mm), std::abs(*r.f_min_mm)));
  }
  std::vector<LimitDecision> out;
  auto one = [&out](const char* q, const std::optional<double>& limit,
                    const std::optional<double>& value, double u) {
    if (!limit) return;
    LimitDecision d{q, value, u, *limit, std::nullopt};
    if (value) d.decision = decide(*value, u, *limit);
    out.push_back(d);
  };
  one("H", limits.h_mm, h, b.u_h_mm);
  one("G", limits.g_mm, g, b.u_g_mm);
  one("F", limits.f_mm, f, b.u_f_mm);
  return out;
}

bool all_pass(const std::vector<LimitDecision>& decisions) noexcept {
  return std::all_of(decisions.begin(), decisions.end(), [](const LimitDecision& d) {
    return d.decision && *d.decision == Decision::pass;
  });
}

}  // namespace circtest
