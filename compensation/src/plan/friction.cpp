#include "circtest/compensation/friction.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>

#include "circtest/core/circfric_limits.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "context.hpp"

namespace circtest::compensation {

namespace fs = std::filesystem;
using namespace detail;

namespace {

bool is_command_target(const HalWiring& w, const std::string& pin) {
  if (pin.ends_with(".position-cmd") && pin.find("stepgen.") != std::string::npos) return true;
  if (!pin.ends_with(".command")) return false;
  const std::string instance = pin.substr(0, pin.size() - 8);
  return instance.starts_with("pid.") || std::find(w.pid_instances.begin(), w.pid_instances.end(),
                                                   instance) != w.pid_instances.end();
}

// Where a refusal about the HAL as a whole points: the INI's first [HAL] HALFILE.
HalPlace halfile_place(const IniDocument& ini) {
  const auto all = ini.get_all("HAL", "HALFILE");
  if (all.empty()) return {ini.path(), 0};
  return {all.front().file, all.front().line};
}

std::string list_text(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& i : items) out += (out.empty() ? "" : ", ") + i;
  return out.empty() ? "none" : out;
}

// How one joint is spliced.
struct Splice {
  char axis = 'X';
  int joint = 0;
  std::string instance;       // fric-x, or fric-x-j3 for a second joint of the axis
  std::string pos_signal;     // carries joint.N.motor-pos-cmd
  HalPlace pos_place;         // its net
  std::string target;         // pid.x.command or stepgen.0.position-cmd
  std::string vel_signal;     // empty: circcomp nets joint.N.vel-cmd itself
  std::string enable_signal;  // empty: circcomp nets joint.N.amp-enable-out itself
};

std::string refusal_tail(const PlanOptions& o) {
  return fmt::format("wire circfric by hand (docs/circfric.md, WIRING), or {}",
                     o.setting_words(PlanSetting::without_friction));
}

Splice find_splice(const HalWiring& w, const IniDocument& ini, char axis, int joint,
                   const std::string& instance, const PlanOptions& o) {
  Splice s;
  s.axis = axis;
  s.joint = joint;
  s.instance = instance;
  const std::string cmd = fmt::format("joint.{}.motor-pos-cmd", joint);
  const auto it = w.pin_signal.find(cmd);
  // A pid or stepgen command given a literal (setp, on no net) is named as the reason.
  auto refuse_literal = [&] {
    for (const auto& [pin, place] : w.setp) {
      if (!is_command_target(w, pin) || w.pin_signal.count(pin)) continue;
      throw WiringError(
          place.file, place.line,
          fmt::format("{} is a literal (setp) and no pid or stepgen reads {} (axis {}): "
                      "circcomp finds no position command to compensate; {}",
                      pin, cmd, axis, refusal_tail(o)));
    }
  };
  if (it == w.pin_signal.end()) {
    refuse_literal();
    const HalPlace p = halfile_place(ini);
    throw WiringError(
        p.file, p.line,
        fmt::format("no net in the HAL files read ({}) carries {} (axis {}){}: {}",
                    list_text(w.read), cmd, axis,
                    w.unread.empty() ? "" : fmt::format(" (not read: {})", list_text(w.unread)),
                    refusal_tail(o)));
  }
  s.pos_signal = it->second;
  const auto& signal = w.signals.at(s.pos_signal);
  s.pos_place = signal.place;
  std::vector<std::string> targets, others;
  for (const auto& pin : signal.pins) {
    if (pin == cmd) continue;
    (is_command_target(w, pin) ? targets : others).push_back(pin);
  }
  if (targets.empty()) refuse_literal();
  if (targets.size() != 1) {
    throw WiringError(
        s.pos_place.file, s.pos_place.line,
        fmt::format("signal {} carries {} (axis {}) to {}: {}; {}", s.pos_signal, cmd, axis,
                    list_text(targets.empty() ? others : targets),
                    targets.empty() ? "no pid command or stepgen position-cmd, the only inputs "
                                      "circcomp splices circfric in front of"
                                    : "more than one pid or stepgen, circcomp cannot tell which "
                                      "drives the joint",
                    refusal_tail(o)));
  }
  s.target = targets.front();
  if (const auto v = w.pin_signal.find(fmt::format("joint.{}.vel-cmd", joint));
      v != w.pin_signal.end()) {
    s.vel_signal = v->second;
  }
  if (const auto e = w.pin_signal.find(fmt::format("joint.{}.amp-enable-out", joint));
      e != w.pin_signal.end()) {
    s.enable_signal = e->second;
  }
  return s;
}

// The servo thread and circfric's position in it: right after motion-controller.
std::pair<std::string, std::size_t> after_motion_controller(const HalWiring& w,
                                                            const IniDocument& ini,
                                                            const PlanOptions& o) {
  for (const auto& [thread, list] : w.threads) {
    const auto it = std::find(list.begin(), list.end(), "motion-controller");
    if (it != list.end()) {
      return {thread, static_cast<std::size_t>(it - list.begin()) + 2};
    }
  }
  const HalPlace p = halfile_place(ini);
  throw WiringError(p.file, p.line,
                    fmt::format("no HAL file read ({}) adds motion-controller to a thread ('addf "
                                "motion-controller servo-thread'): circfric must run right after "
                                "it; {}",
                                list_text(w.read), refusal_tail(o)));
}

std::string lower(char c) {
  return std::string(1, static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
}

std::string fric_hal_text(const std::vector<Splice>& splices, const std::string& thread,
                          std::size_t position, const IniDocument& ini) {
  std::string t =
      "# Written by circcomp (circtest): friction compensation at reversals, circfric(9)\n"
      "# (docs/circfric.md) spliced between motion's position command and the pid or stepgen.\n"
      "# The values live in the INI's [FRICTION_<axis>] sections; `circcomp revert` removes\n"
      "# this file and its [HAL] HALFILE line.\n";
  std::string names;
  for (const auto& s : splices) names += (names.empty() ? "" : ",") + s.instance;
  t += "loadrt circfric names=" + names + "\n";
  for (std::size_t i = 0; i < splices.size(); ++i) {
    t += fmt::format("addf {} {} {}\n", splices[i].instance, thread, position + i);
  }
  for (const auto& s : splices) {
    const std::string& n = s.instance;
    t += fmt::format("# axis {}, joint {}: {} ({}:{}) into {}\n", s.axis, s.joint, s.pos_signal,
                     fs::path(s.pos_place.file).filename().string(), s.pos_place.line, s.target);
    t += fmt::format("unlinkp {}\n", s.target);
    t += fmt::format("net {} => {}.pos-in\n", s.pos_signal, n);
    t += fmt::format("net {}-pos-out {}.pos-out => {}\n", n, n, s.target);
    if (s.vel_signal.empty()) {
      t += fmt::format("net {}-vel-cmd joint.{}.vel-cmd => {}.vel-cmd\n", n, s.joint, n);
    } else {
      t += fmt::format("net {} => {}.vel-cmd\n", s.vel_signal, n);
    }
    if (s.enable_signal.empty()) {
      t += fmt::format("net {}-enable joint.{}.amp-enable-out => {}.enable\n", n, s.joint, n);
    } else {
      t += fmt::format("net {} => {}.enable\n", s.enable_signal, n);
    }
    const std::string sec = "FRICTION_" + std::string(1, s.axis);
    t += fmt::format("setp {}.amplitude [{}]AMPLITUDE\n", n, sec);
    t += fmt::format("setp {}.amplitude-max [{}]AMPLITUDE_MAX\n", n, sec);
    t += fmt::format("setp {}.decay-ms [{}]DECAY_MS\n", n, sec);
    if (ini.find(sec, "RISE_MS")) t += fmt::format("setp {}.rise-ms [{}]RISE_MS\n", n, sec);
  }
  return t;
}

// A number of [FRICTION_X] KEY that step 2 reads.
double friction_value(const IniDocument& ini, const std::string& section, const char* key,
                      const char* what) {
  const auto e = ini.find(section, key);
  const auto v = e ? parse_finite(e->value) : std::nullopt;
  if (!e) {
    throw DataError(ini.path(), 0,
                    fmt::format("[{}] has no {} ({}): circcomp refines only what it wrote; "
                                "remove the section, or add the key",
                                section, key, what));
  }
  if (!v || *v < 0) {
    throw DataError(e->file, e->line,
                    fmt::format("[{}] {} = '{}': expected {}", section, key, e->value, what));
  }
  return *v;
}

// A spike (MM) as the user reads it: "4.70 um" with DECIMALS; on a machine in other units
// (UPM machine units per mm) in those and mm, "0.000185 in (0.0047 mm)", as the INI's
// AMPLITUDE is in the machine's units.
std::string spike_text(double mm, double upm, int decimals = 2) {
  if (std::fabs(upm - 1.0) < 1e-12) return fmt::format("{:.{}f} um", mm * 1e3, decimals);
  return quantity_text(mm, "mm", upm);
}

// The measured spike of one axis, when it is one circfric should answer; else a note.
std::optional<double> spike_to_compensate(const DiagnosisInput& in, int k, const char* what,
                                          double upm, const PlanOptions& o,
                                          std::vector<std::string>& notes) {
  const char axis = in.diagnosis.axes[k];
  const Measured& m = in.diagnosis.spike_mm[k];
  if (!m.value) {
    notes.push_back(
        fmt::format("{} {}: not in the diagnosis (null), friction not changed", axis, what));
    return std::nullopt;
  }
  const double v = *m.value;
  if (std::fabs(v) < kMinFrictionSpikeMm) {
    notes.push_back(fmt::format("{} {} of {} is below {}: no friction change", axis, what,
                                spike_text(v, upm), spike_text(kMinFrictionSpikeMm, upm, 0)));
    return std::nullopt;
  }
  if (m.standard_error && std::fabs(v) < 2.0 * *m.standard_error) {
    notes.push_back(
        fmt::format("{} {} of {} is not significant (standard error {}, needs |spike| >= "
                    "2 standard errors): no friction change; measure again",
                    axis, what, spike_text(v, upm), spike_text(*m.standard_error, upm)));
    return std::nullopt;
  }
  if (!o.force && std::fabs(v) > kMaxFrictionSpikeMm) {
    throw DataError(
        in.source, 0,
        fmt::format("{} {} = {} is implausible for friction (more than {}); check "
                    "the measurement, or {}",
                    axis, what, spike_text(v, upm, 1), spike_text(kMaxFrictionSpikeMm, upm, 0),
                    o.setting_words(PlanSetting::force)));
  }
  return v;
}

// Whether the axis follows its command within kFrictionMinLagMs (feed-forward, a stepgen).
bool follows_closely(const Diagnosis& d, int k) {
  const std::optional<double> lag_ms = d.axis_lag[k].lag_ms.value;
  return lag_ms && *lag_ms < kFrictionMinLagMs;
}

// The share of a command pulse A exp(-t / decay) that reaches the table through a position
// loop following with the lag T = 1 / Kv (first order): the peak of the lagged pulse,
// (decay / T)^(-T / (decay - T)), which is 1/e at decay = T and tends to 1 as T vanishes.
// circfric adds its pulse to the command, and a P loop without velocity feed-forward passes
// only this share of it on to the table; with feed-forward the lag, and with it the loss, is
// small. 1 when Kv is not known.
double loop_pass(double decay_s, std::optional<double> kv_per_s) {
  if (!kv_per_s || !(*kv_per_s > 0) || !std::isfinite(*kv_per_s) || !(decay_s > 0)) return 1.0;
  const double lag_s = 1.0 / *kv_per_s;
  const double ratio = decay_s / lag_s;
  if (std::fabs(ratio - 1.0) < 1e-9) return std::exp(-1.0);
  return std::pow(ratio, -1.0 / (ratio - 1.0));
}

// The rise time (ms) that puts the rising pulse's peak at PEAK_MS with the decay DECAY_MS, at
// most fric::kMaxRiseShareOfDecay of the decay (the latest peak circfric can make, about 0.97 of
// the decay). The peak time grows with the rise, so a bisection finds it.
double rise_for_peak_ms(double decay_ms, double peak_ms) {
  double lo = 0.0, hi = fric::kMaxRiseShareOfDecay * decay_ms;
  if (fric::pulse_peak_time(decay_ms, hi) <= peak_ms) return hi;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (fric::pulse_peak_time(decay_ms, mid) < peak_ms ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// A loop that follows within kFrictionMinLagMs passes a position pulse to the table at once;
// a spike that peaks after the reversal there is the drive sticking, and circfric's rising
// pulse, peaking at kFrictionRisePeakShare of the spike's peak time, pushes it free. The
// amplitude is the spike's height: the table sees the pulse whole.
struct PulseShape {
  double amplitude, rise_ms = 0;
  std::string how;  // how the amplitude and the rise were found, for the plan's line
};

PulseShape rising_pulse(const Diagnosis& d, int k, double spike_mm, double decay_ms, double upm,
                        double amplitude_max, const PlanOptions& o) {
  const double peak_ms = *d.spike_peak_ms[k].value;
  const double want_ms = kFrictionRisePeakShare * peak_ms;
  const double rise =
      parse_finite(number_text(std::max(rise_for_peak_ms(decay_ms, want_ms), fric::kMinDecayMs)))
          .value_or(fric::kMinDecayMs);
  const double at_ms = fric::pulse_peak_time(decay_ms, rise);
  return {std::min(o.gain * spike_mm * upm, amplitude_max), rise,
          fmt::format(", a rising pulse: the axis follows within {:.2g} ms and the spike peaks "
                      "{:.0f} ms after the reversal (the drive sticks), the pulse's at {:.0f} ms{}",
                      *d.axis_lag[k].lag_ms.value, peak_ms, at_ms,
                      at_ms < 0.99 * want_ms
                          ? fmt::format(" (the latest a decay of {} ms allows; {:.0f} ms wanted)",
                                        number_text(decay_ms), want_ms)
                          : fmt::format(", {:.0f} % of it", kFrictionRisePeakShare * 100.0))};
}

// A plain pulse at the reversal: through a loop with the lag 1 / Kv the table sees only the
// share loop_pass of it, so the amplitude is raised by that share (within AMPLITUDE_MAX).
PulseShape plain_pulse(const Diagnosis& d, double spike_mm, double decay_ms, double upm,
                       double amplitude_max, const PlanOptions& o) {
  const double pass = loop_pass(decay_ms * 1e-3, d.kv_per_s.value);
  const double amplitude = std::min(o.gain * spike_mm * upm / pass, amplitude_max);
  return {amplitude, 0,
          pass < 1.0 ? fmt::format(" / {:.2f}, the share of the pulse the {:.1f} ms lag (1 / Kv) "
                                   "passes{}",
                                   pass, 1e3 / *d.kv_per_s.value,
                                   amplitude == amplitude_max ? ", bounded by AMPLITUDE_MAX" : "")
                     : ""};
}

// Step 1 of one axis: the INI values from the measured spike and decay. Returns false when
// the axis is skipped (a note says why).
bool first_tuning(IniDocument& ini, const DiagnosisInput& in, int k, double upm,
                  const PlanOptions& o, Plan& plan) {
  const Diagnosis& d = in.diagnosis;
  const char axis = d.axes[k];
  const auto spike = spike_to_compensate(in, k, "reversal spike", upm, o, plan.notes);
  if (!spike) return false;
  if (*spike < 0) {
    plan.notes.push_back(
        fmt::format("{} reversal spike of {} points inwards: not friction's outward spike, not "
                    "compensated",
                    axis, spike_text(*spike, upm)));
    return false;
  }
  const auto decay = d.spike_ms[k].value;
  if (!decay || !(*decay >= fric::kMinDecayMs && *decay <= fric::kMaxDecayMs)) {
    plan.notes.push_back(
        fmt::format("{} reversal spike of {}: its decay {} is not within circfric's {} to {} ms, "
                    "not compensated",
                    axis, spike_text(*spike, upm),
                    decay ? fmt::format("{} ms", number_text(*decay)) : "was not measured",
                    fric::kMinDecayMs, fric::kMaxDecayMs));
    return false;
  }
  // From the spike as SPIKE_MM holds it, so that step 2's bound (2 x SPIKE_MM) is this one.
  const double amplitude_max = 2.0 * parse_finite(number_text(*spike)).value_or(*spike) * upm;
  const bool rising = follows_closely(d, k) && d.spike_peak_ms[k].value;
  const PulseShape pulse = rising ? rising_pulse(d, k, *spike, *decay, upm, amplitude_max, o)
                                  : plain_pulse(d, *spike, *decay, upm, amplitude_max, o);
  const double amplitude = pulse.amplitude;
  if (amplitude_max > fric::kMaxAmplitude) {
    throw DataError(in.source, 0,
                    fmt::format("{} reversal spike {}: twice it is beyond circfric's "
                                "bound of 1 machine unit",
                                axis, spike_text(*spike, upm, 1)));
  }
  const std::string sec = std::string("FRICTION_") + axis;
  if (ini.has_section(sec)) {
    plan.notes.push_back(fmt::format(
        "[{}] was not in effect ({} is not a [HAL] HALFILE): the measurement saw none of it, so "
        "it is replaced",
        sec, kFrictionHalFile));
  }
  ini.set(sec, "AMPLITUDE", number_text(amplitude));
  ini.set(sec, "AMPLITUDE_MAX", number_text(amplitude_max));
  ini.set(sec, "DECAY_MS", number_text(*decay));
  if (rising) ini.set(sec, "RISE_MS", number_text(pulse.rise_ms));
  ini.set(sec, "SPIKE_MM", number_text(*spike));
  ini.comment_before(sec, "AMPLITUDE",
                     fmt::format("circcomp: friction compensation of axis {} by circfric (set by "
                                 "{}): AMPLITUDE and AMPLITUDE_MAX in machine units, DECAY_MS "
                                 "{}in ms; SPIKE_MM is the spike first measured, and "
                                 "AMPLITUDE_MAX stays at most twice it",
                                 axis, kFrictionHalFile, rising ? "and RISE_MS " : ""));
  plan.changes.push_back(
      fmt::format("[{}] step 1 (first tuning): AMPLITUDE {} (spike {}{}), {}DECAY_MS {}, "
                  "AMPLITUDE_MAX {} (2 x spike); rerun the circle and plan again for step 2",
                  sec, number_text(amplitude), spike_text(*spike, upm), pulse.how,
                  rising ? "RISE_MS " + number_text(pulse.rise_ms) + ", " : "", number_text(*decay),
                  number_text(amplitude_max)));
  return true;
}

// Step 2 of one axis: the amplitude refined from the residual spike.
void refinement(IniDocument& ini, const DiagnosisInput& in, int k, double upm, const PlanOptions& o,
                Plan& plan) {
  const char axis = in.diagnosis.axes[k];
  const std::string sec = std::string("FRICTION_") + axis;
  const double first_mm = friction_value(ini, sec, "SPIKE_MM", "the spike first measured, mm");
  const double amplitude = friction_value(ini, sec, "AMPLITUDE", "a length in machine units");
  const double max_now = friction_value(ini, sec, "AMPLITUDE_MAX", "a length in machine units");
  const double bound = 2.0 * first_mm * upm;
  const auto residual = spike_to_compensate(in, k, "residual reversal spike", upm, o, plan.notes);
  if (!residual) return;
  if (std::fabs(*residual) <= kFrictionRefineShare * first_mm) {
    plan.notes.push_back(
        fmt::format("{} residual reversal spike of {} is {:.0f} % of the {} compensated, not "
                    "more than {:.0f} %: no step 2, [{}] unchanged",
                    axis, spike_text(*residual, upm), std::fabs(*residual) / first_mm * 100.0,
                    spike_text(first_mm, upm), kFrictionRefineShare * 100.0, sec));
    return;
  }
  const double limit = std::min(max_now, bound);
  // Written with a few digits: a last-digit difference is the same bound.
  if (max_now > bound * (1.0 + 1e-6)) {
    ini.set(sec, "AMPLITUDE_MAX", number_text(bound));
    plan.notes.push_back(
        fmt::format("[{}] AMPLITUDE_MAX {} -> {}: at most twice the spike first "
                    "measured ({})",
                    sec, number_text(max_now), number_text(bound), spike_text(first_mm, upm)));
  }
  const double wanted = amplitude + o.gain * *residual * upm;
  const double next = std::clamp(wanted, 0.0, limit);
  if (next != wanted) {
    plan.notes.push_back(fmt::format("[{}] AMPLITUDE {} + {} clamped to {} (0..AMPLITUDE_MAX)", sec,
                                     number_text(amplitude), number_text(o.gain * *residual * upm),
                                     number_text(next)));
  }
  ini.set(sec, "AMPLITUDE", number_text(next));
  plan.changes.push_back(fmt::format(
      "[{}] step 2 (refinement): AMPLITUDE {} -> {} (residual spike {}, {:.0f} % of the "
      "{} compensated)",
      sec, number_text(amplitude), number_text(next), spike_text(*residual, upm),
      std::fabs(*residual) / first_mm * 100.0, spike_text(first_mm, upm)));
  // Where the bound holds the amplitude below what an outward residual asks for, the pulse's
  // area (amplitude x decay, what it pushes the stuck table with) still grows by that share:
  // the decay lengthens, at most to twice its value in one step.
  if (wanted > limit && next > 0) {
    const double decay = friction_value(ini, sec, "DECAY_MS", "a time in ms");
    if (!(decay >= fric::kMinDecayMs && decay <= fric::kMaxDecayMs)) {
      const auto e = ini.find(sec, "DECAY_MS");
      throw DataError(e->file, e->line,
                      fmt::format("[{}] DECAY_MS = {}: expected {} to {} ms (circfric's range)",
                                  sec, e->value, fric::kMinDecayMs, fric::kMaxDecayMs));
    }
    const double longer = std::min({decay * wanted / next, 2.0 * decay, fric::kMaxDecayMs});
    ini.set(sec, "DECAY_MS", number_text(longer));
    plan.changes.push_back(fmt::format(
        "[{}] step 2 (refinement): DECAY_MS {} -> {} (AMPLITUDE bounded by AMPLITUDE_MAX: the "
        "pulse's area amplitude x decay grows by the {:.0f} % the amplitude cannot)",
        sec, number_text(decay), number_text(longer), (longer / decay - 1.0) * 100.0));
  }
}

// The reversal spikes' advice: friction, not play.
void spike_advice(PlanContext& c) {
  for (int k = 0; k < 2; ++k) {
    const auto& s = c.d().spike_mm[k];
    if (!s.value || std::fabs(*s.value) < 1e-3) continue;
    c.plan.advice.push_back(fmt::format(
        "{} reversal spikes of {}{}: friction (stick-slip at the reversal), not play; "
        "compensating them as backlash makes parts worse: check gibs and lubrication, or "
        "let circcomp plan friction compensation (circfric)",
        c.d().axes[k], spike_text(*s.value, c.upm, 1),
        c.d().spike_ms[k].value ? fmt::format(" decaying in {:.0f} ms", *c.d().spike_ms[k].value)
                                : ""));
  }
}

}  // namespace

void plan_friction(PlanContext& c) {
  IniDocument& ini = c.ini;
  const ConfigDir& config = c.config;
  const DiagnosisInput& in = c.input();
  const Diagnosis& d = in.diagnosis;
  const PlanOptions& o = c.o;
  Plan& plan = c.plan;
  PlanFiles& files = c.files;
  const double upm = units_per_mm(ini);
  bool loaded = false;
  for (const auto& h : ini.get_all("HAL", "HALFILE")) loaded |= h.value == kFrictionHalFile;
  // The axes circtest-fric.hal wires now, and those a first tuning adds.
  std::set<char> wired;
  if (loaded) {
    for (const auto& s : ini.sections()) {
      if (s.size() == 10 && s.starts_with("FRICTION_")) wired.insert(s[9]);
    }
  }
  std::set<char> added;
  for (int k = 0; k < 2; ++k) {
    if (follows_closely(d, k) && !d.spike_peak_ms[k].value && d.spike_mm[k].value &&
        std::fabs(*d.spike_mm[k].value) >= kMinFrictionSpikeMm && !wired.count(d.axes[k])) {
      plan.notes.push_back(fmt::format(
          "{} friction compensation not planned: the axis follows within {:.1f} ms (below "
          "{:.0f} ms: feed-forward or a stepgen) and its spike peaks at the reversal, not after "
          "it: a pulse would arrive before the table sticks and no rise to give it was "
          "measured; tune it by hand (docs/circfric.md, Halscope)",
          d.axes[k], *d.axis_lag[k].lag_ms.value, kFrictionMinLagMs));
      continue;
    }
    if (wired.count(d.axes[k])) {
      refinement(ini, in, k, upm, o, plan);
    } else if (first_tuning(ini, in, k, upm, o, plan)) {
      added.insert(d.axes[k]);
    }
  }
  if (added.empty()) return;

  const HalWiring hal = read_hal_wiring(ini, kFrictionHalFile);
  if (hal.loads_circfric) {
    throw WiringError(hal.loads_circfric->file, hal.loads_circfric->line,
                      fmt::format("the configuration loads circfric itself: circcomp does not "
                                  "wire it a second time; {}",
                                  refusal_tail(o)));
  }
  const auto [thread, position] = after_motion_controller(hal, ini, o);
  auto splices_of = [&](const std::set<char>& axes) {
    std::vector<Splice> out;
    for (const char axis : axes) {
      const auto joints = joints_of(ini, axis);
      for (const int j : joints) {
        const std::string name =
            joints.size() == 1 ? "fric-" + lower(axis) : fmt::format("fric-{}-j{}", lower(axis), j);
        out.push_back(find_splice(hal, ini, axis, j, name, o));
      }
    }
    return out;
  };
  std::set<char> all = wired;
  all.insert(added.begin(), added.end());
  const auto splices = splices_of(all);
  const std::string text = fric_hal_text(splices, thread, position, ini);
  for (const auto& s : splices) {
    for (const char* suffix : {"-pos-out", "-vel-cmd", "-enable"}) {
      const auto it = hal.signals.find(s.instance + suffix);
      if (it != hal.signals.end()) {
        throw WiringError(it->second.place.file, it->second.place.line,
                          fmt::format("signal {} exists already: circcomp's circfric wiring would "
                                      "join it; rename it",
                                      s.instance + suffix));
      }
    }
  }
  const std::string dir = ini_dir(ini.path());
  const fs::path path = fs::path(dir.empty() ? "." : dir) / kFrictionHalFile;
  bool existed = false;
  const std::string before = read_target(config, path.string(), existed);
  if (existed && before != text &&
      !(loaded && before == fric_hal_text(splices_of(wired), thread, position, ini))) {
    throw WiringError(path.string(), 0,
                      loaded ? "changed since circcomp wrote it: revert, or move it away first"
                             : "exists but is not [HAL] HALFILE and not circcomp's: move it away "
                               "first");
  }
  if (!loaded) ini.append("HAL", "HALFILE", kFrictionHalFile);
  files[path.string()] = {existed, text};
  plan.needs_fric_module = true;
  // The function reading the spliced input should run after circfric; one that runs before
  // motion-controller reads every command a period late, circfric's pulse too.
  const auto& order = hal.threads.at(thread);
  for (const auto& s : splices) {
    const std::string reader = s.target.ends_with(".command")
                                   ? s.target.substr(0, s.target.size() - 8) + ".do-pid-calcs"
                                   : "stepgen.update-freq";
    const auto at = std::find(order.begin(), order.end(), reader);
    // POSITION is motion-controller's place from 1, plus 1.
    if (at != order.end() && static_cast<std::size_t>(at - order.begin()) + 2 < position) {
      plan.notes.push_back(fmt::format(
          "{} runs before motion-controller in {}: it reads the position command (and "
          "circfric's pulse) a servo period late; move its addf after motion-controller",
          reader, thread));
    }
  }
  for (std::size_t i = 0; i < splices.size(); ++i) {
    if (!added.count(splices[i].axis)) continue;
    plan.changes.push_back(fmt::format("{}: circfric {} spliced between {} and {} ({} position {})",
                                       kFrictionHalFile, splices[i].instance, splices[i].pos_signal,
                                       splices[i].target, thread, position + i));
  }
}

// Friction: circfric wired by circtest-fric.hal, its values in [FRICTION_<axis>]. Not in a
// round whose servo gains change: the spike is the loop's answer to the friction, and step 1
// divides by the share of the pulse the old lag passes (tuned on the old loop, circfric would
// push the table by that share's inverse, 2.5x at FF1 0 -> 1).
void friction_step(PlanContext& c) {
  if (!c.wants(Correction::friction)) return;
  if (c.plan.changes.size() > c.changes_before_servo) {
    c.plan.notes.push_back(
        "friction compensation not planned in this round: the servo gains change, and the "
        "reversal spike changes with them; rerun the circle and plan again");
    c.friction_answered = true;
    return;
  }
  if (c.o.friction_requested) {
    plan_friction(c);
    c.friction_answered = true;
    return;
  }
  // Tried on a trial context: a configuration without a pid or stepgen to splice into (a
  // simulated machine, a HAL of its own kind) keeps every other correction.
  PlanContext tried = c.trial();
  try {
    plan_friction(tried);
  } catch (const WiringError& e) {
    // Only where to wire the compensator is in question here: what the measurement says (an
    // implausible spike) is refused as ever.
    c.plan.notes.push_back(fmt::format("friction compensation not planned: {}", e.what()));
    return;
  }
  c.merge(std::move(tried));
  c.friction_answered = true;
}

void spike_advice_step(PlanContext& c) {
  if (!c.friction_answered) spike_advice(c);
}

}  // namespace circtest::compensation
