// circcomp's servo step: the per-axis following lag of a diagnosis matched by velocity feed
// forward (FF1, and P where FF1 alone cannot match) of each joint's pid, written where the
// configuration's HAL reads it ([JOINT_n] keys, or a literal setp edited in place); stepgen
// joints get the stepgen checks instead (docs/compensation.md, "Servo"); without a per-axis
// lag, the mismatch advice.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>

#include "circtest/compensation/friction.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "context.hpp"

namespace circtest::compensation {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// FF1 within 0..kMaxFf1 (issue bounds); the target lag is chosen so that no joint needs more
// than full feed forward (1.0 of an ideal velocity drive) where that suffices.
constexpr double kMaxFf1 = 1.2;
constexpr double kPreferredFf1 = 1.0;
// P within this factor of the value before.
constexpr double kMinPFactor = 0.5;
constexpr double kMaxPFactor = 2.0;
// The effective position gain times the servo period stays below this: the sampled loop with
// its one period of delay is critically damped at Kv T = 1/4 (z^2 - z + Kv T = 0).
constexpr double kMaxGainTimesPeriod = 0.25;
// Below these there is nothing worth changing.
constexpr double kMinFf1Change = 0.005;
// A following lag beyond this is no servo loop's (1 / P of P = 0.1 1/s): implausible.
constexpr double kMaxLagMs = 10000.0;

// How a pid pin gets its value: the HAL command that decides it (the last halcmd runs).
struct Gain {
  enum class Kind { ini_key, literal, unset } kind = Kind::unset;
  double value = 0.0;
  std::string section, key;                    // ini_key: the [SECTION]KEY the HAL names
  HalPlace place;                              // the command (ini_key, literal)
  std::string setter;                          // its words before the value: "setp pid.x.FF1"
  std::vector<std::string> pins;               // the pins it sets (a sets: the signal's)
  std::size_t value_begin = 0, value_end = 0;  // literal: the value's bytes in the file
};

// A joint's position loop as the HAL wires it.
struct Loop {
  enum class Kind { pid, stepgen, none } kind = Kind::none;
  std::string instance;  // pid.x, pid.0, stepgen.0, hm2_7i92.0.stepgen.00
};

bool is_pid(const HalWiring& w, const std::string& instance) {
  return instance.starts_with("pid.") || std::find(w.pid_instances.begin(), w.pid_instances.end(),
                                                   instance) != w.pid_instances.end();
}

// The instances of the pins on the signal of PIN that end with SUFFIX and pass KEEP.
template <class Keep>
std::vector<std::string> instances_on(const HalWiring& w, const std::string& pin,
                                      const std::string& suffix, Keep keep) {
  std::vector<std::string> out;
  const auto it = w.pin_signal.find(pin);
  if (it == w.pin_signal.end()) return out;
  for (const auto& p : w.signals.at(it->second).pins) {
    if (!p.ends_with(suffix)) continue;
    const std::string inst = p.substr(0, p.size() - suffix.size());
    if (keep(inst)) out.push_back(inst);
  }
  return out;
}

// The joint's loop: the pid whose feedback is the joint's motor-pos-fb (else whose command is
// its motor-pos-cmd), else a stepgen reading motor-pos-cmd as its position command.
Loop find_loop(const HalWiring& w, int joint) {
  const std::string fb = fmt::format("joint.{}.motor-pos-fb", joint);
  const std::string cmd = fmt::format("joint.{}.motor-pos-cmd", joint);
  const auto pid = [&](const std::string& i) { return is_pid(w, i); };
  std::vector<std::string> pids = instances_on(w, fb, ".feedback", pid);
  if (pids.empty()) pids = instances_on(w, cmd, ".command", pid);
  if (pids.size() > 1) {
    const auto& sig = w.signals.at(w.pin_signal.at(fb));
    throw DataError(sig.place.file, sig.place.line,
                    fmt::format("{} or {} reaches more than one pid ({}, {}): circcomp cannot "
                                "tell which closes joint {}'s loop",
                                fb, cmd, pids[0], pids[1], joint));
  }
  if (pids.size() == 1) return {Loop::Kind::pid, pids[0]};
  const auto stepgen = [](const std::string& i) { return i.find("stepgen") != std::string::npos; };
  const std::vector<std::string> steps = instances_on(w, cmd, ".position-cmd", stepgen);
  if (!steps.empty()) return {Loop::Kind::stepgen, steps[0]};
  return {};
}

// The words of the logical HAL line at PLACE with their byte offsets in TEXT.
std::vector<std::pair<std::size_t, std::size_t>> raw_words(const std::string& text,
                                                           std::size_t line) {
  std::size_t pos = 0;
  for (std::size_t n = 1; n < line && pos != std::string::npos; ++n) {
    pos = text.find('\n', pos);
    if (pos != std::string::npos) ++pos;
  }
  std::vector<std::pair<std::size_t, std::size_t>> words;
  if (pos == std::string::npos) return words;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::size_t stop = end;
    if (stop > pos && text[stop - 1] == '\r') --stop;
    const bool continued = stop > pos && text[stop - 1] == '\\';
    if (continued) --stop;
    for (std::size_t i = pos; i < stop;) {
      while (i < stop && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
      if (i >= stop) break;
      if (text[i] == '#') return words;
      const std::size_t b = i;
      while (i < stop && !std::isspace(static_cast<unsigned char>(text[i]))) ++i;
      words.emplace_back(b, i);
    }
    if (!continued) break;
    pos = end + 1;
  }
  return words;
}

// The command that decides PIN's value as halcmd runs the files: for a pin on a signal the
// last "sets SIGNAL VALUE", else the last "setp PIN VALUE" or "PIN = VALUE". Refused naming
// the file and line where circcomp cannot change it.
HalPlace value_command(const HalWiring& w, const std::string& pin, std::vector<std::string>& pins) {
  pins = {pin};
  if (const auto s = w.pin_signal.find(pin); s != w.pin_signal.end()) {
    const auto& signal = w.signals.at(s->second);
    const auto set = w.sets.find(s->second);
    if (set == w.sets.end()) {
      throw DataError(signal.place.file, signal.place.line,
                      fmt::format("{} is on signal {}: its value comes from the HAL at run time, "
                                  "not from a setp or sets circcomp could change; set it by hand",
                                  pin, s->second));
    }
    pins.assign(signal.pins.begin(), signal.pins.end());
    return set->second;
  }
  const auto it = w.setp.find(pin);
  return it == w.setp.end() ? HalPlace{} : it->second;
}

// The INI key a whole value word names ([SECTION]KEY or [SECTION](KEY), halcmd's key
// characters), or nullopt.
std::optional<std::pair<std::string, std::string>> ini_reference(const std::string& word) {
  if (word.size() <= 3 || word.front() != '[') return std::nullopt;
  const std::size_t close = word.find(']');
  if (close == std::string::npos || close <= 1) return std::nullopt;
  std::string key = word.substr(close + 1);
  if (key.size() > 2 && key.front() == '(' && key.back() == ')')
    key = key.substr(1, key.size() - 2);
  const bool plain = !key.empty() && std::all_of(key.begin(), key.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.' || c == '-';
  });
  if (!plain) return std::nullopt;
  return std::pair{word.substr(1, close - 1), key};
}

// How PIN (pid.x.FF1) gets its value, read from the deciding command's file as written.
Gain gain_of(const HalWiring& w, const IniDocument& ini, const std::string& pin) {
  Gain g;
  g.place = value_command(w, pin, g.pins);
  if (g.place.file.empty()) return g;
  if (g.place.ini_halcmd) {
    throw DataError(g.place.file, g.place.line,
                    fmt::format("{} is set by this [HAL] HALCMD, which LinuxCNC runs after the "
                                "HAL files: circcomp does not edit HALCMD entries; move it into "
                                "a HAL file, or set it by hand",
                                pin));
  }
  bool existed = false;
  const std::string text = slurp_if(g.place.file, existed);
  const auto words = raw_words(text, g.place.line);
  if (words.size() < 3) {
    throw DataError(g.place.file, g.place.line,
                    fmt::format("expected 'setp {} VALUE' on this line", pin));
  }
  const auto word_at = [&](std::size_t i) {
    return text.substr(words[i].first, words[i].second - words[i].first);
  };
  g.setter = word_at(0) + " " + word_at(1);
  const std::string word = word_at(2);
  if (const auto ref = ini_reference(word)) {
    g.kind = Gain::Kind::ini_key;
    g.section = ref->first;
    g.key = ref->second;
    const auto e = ini.find(g.section, g.key);
    if (!e) {
      throw DataError(g.place.file, g.place.line,
                      fmt::format("{} {}: the INI has no [{}] {}, so halcmd cannot load this "
                                  "file; add the key, measure, then plan again",
                                  g.setter, word, g.section, g.key));
    }
    const auto v = parse_finite(e->value);
    if (!v) {
      throw DataError(e->file, e->line,
                      fmt::format("[{}] {} = '{}' (read by {}): expected a number", g.section,
                                  g.key, e->value, pin));
    }
    g.value = *v;
    return g;
  }
  const auto v = parse_finite(word);
  if (!v) {
    throw DataError(g.place.file, g.place.line,
                    fmt::format("{} {}: neither a number nor one [SECTION]KEY; circcomp "
                                "changes only those: set it by hand",
                                g.setter, word));
  }
  g.kind = Gain::Kind::literal;
  g.value = *v;
  g.value_begin = words[2].first;
  g.value_end = words[2].second;
  return g;
}

// One joint's servo proposal.
struct JointServo {
  char axis = 'X';
  int joint = 0;
  std::string pid;
  Gain p, ff1;
  double lag_s = 0.0;  // measured
  double c = 0.0;      // lag P + FF1: the output that holds one unit/s (1 for an ideal drive)
  double p_new = 0.0, ff1_new = 0.0;
};

double ini_number(const IniDocument& ini, const std::string& section, const char* key,
                  double fallback) {
  const auto e = ini.find(section, key);
  if (!e) return fallback;
  const auto v = parse_finite(e->value);
  if (!v) {
    throw DataError(e->file, e->line,
                    fmt::format("[{}] {} = '{}': expected a number", section, key, e->value));
  }
  return *v;
}

// The new text of the HAL file holding a gain: the literal replaced, or a setp inserted.
void write_gain(const JointServo& js, const Gain& g, const std::string& pin, double value,
                const Gain& after, IniDocument& ini, PlanFiles& files) {
  if (g.kind == Gain::Kind::ini_key) {
    ini.set(g.section, g.key, number_text(value));
    return;
  }
  const std::string& file = g.kind == Gain::Kind::literal ? g.place.file : after.place.file;
  auto it = files.find(file);
  if (it == files.end()) {
    bool existed = false;
    std::string text = slurp_if(file, existed);
    it = files.emplace(file, std::pair{existed, std::move(text)}).first;
  }
  std::string& text = it->second.second;
  bool existed = false;
  const std::string original = slurp_if(file, existed);
  if (g.kind == Gain::Kind::literal) {
    // Offsets of the original file: an edit of the same file before this one (the other
    // joint's line) changed the text only before or after this line, so the line is found
    // again by its content.
    const std::size_t line_begin = original.rfind('\n', g.value_begin) == std::string::npos
                                       ? 0
                                       : original.rfind('\n', g.value_begin) + 1;
    std::size_t line_end = original.find('\n', g.value_end);
    if (line_end == std::string::npos) line_end = original.size();
    const std::string line = original.substr(line_begin, line_end - line_begin);
    std::string next = line;
    next.replace(g.value_begin - line_begin, g.value_end - g.value_begin, number_text(value));
    const std::size_t at = text.find(line);
    if (at == std::string::npos || text.find(line, at + 1) != std::string::npos) {
      throw DataError(
          g.place.file, g.place.line,
          fmt::format("cannot place the edit of {} uniquely: set it by hand", g.setter));
    }
    text.replace(at, line.size(), next);
    return;
  }
  // No setp: one is added after the pid's Pgain setp, reading the joint's INI key.
  const auto words = raw_words(original, after.place.line);
  std::size_t end = original.find('\n', words.empty() ? 0 : words.back().second);
  end = end == std::string::npos ? original.size() : end + 1;
  std::size_t begin = original.rfind('\n', words.empty() ? 0 : words.front().first);
  begin = begin == std::string::npos ? 0 : begin + 1;
  const std::string anchor = original.substr(begin, end - begin);
  const std::string section = fmt::format("JOINT_{}", js.joint);
  const std::string key = pin.substr(pin.rfind('.') + 1);
  std::string added = fmt::format("setp {} [{}]{}\n", pin, section, key);
  if (!anchor.empty() && anchor.back() != '\n') added = "\n" + added;
  const std::size_t at = text.find(anchor);
  if (at == std::string::npos) {
    throw DataError(after.place.file, after.place.line,
                    fmt::format("cannot place setp {} after this line: set it by hand", pin));
  }
  text.insert(at + anchor.size(), added);
  ini.set(section, key, number_text(value));
}

// The stepgen checks of a stepper joint: STEPGEN_MAXACCEL's headroom over MAX_ACCELERATION
// (a backlash compensation moves the motor on top of the planned motion: pncconf doubles it),
// STEPGEN_MAXVEL's over MAX_VELOCITY. Problems are advice, a clean joint a note.
void stepgen_checks(const HalWiring& w, const IniDocument& ini, char axis, int joint,
                    const Loop& loop, Plan& plan) {
  const std::string section = fmt::format("JOINT_{}", joint);
  const bool compensated =
      ini_number(ini, section, "BACKLASH", 0.0) != 0.0 || ini.get(section, "COMP_FILE").has_value();
  const double need = compensated ? 2.0 : 1.0;
  std::vector<std::string> problems;
  struct Limit {
    const char* pin;
    const char* joint_key;
    const char* what;
  };
  for (const Limit& l : {Limit{"maxaccel", "MAX_ACCELERATION", "acceleration"},
                         Limit{"maxvel", "MAX_VELOCITY", "velocity"}}) {
    const std::string pin = loop.instance + "." + l.pin;
    Gain g;
    try {
      g = gain_of(w, ini, pin);
    } catch (const DataError& e) {
      plan.notes.push_back(fmt::format("{}: {}", axis, e.what()));
      continue;
    }
    const double joint_limit = ini_number(ini, section, l.joint_key, 0.0);
    // 0 (or no setp): the stepgen does not limit; no joint limit: nothing to compare.
    if (g.kind == Gain::Kind::unset || g.value <= 0.0 || joint_limit <= 0.0) continue;
    if (g.value >= need * joint_limit) continue;
    const std::string name = g.kind == Gain::Kind::ini_key
                                 ? fmt::format("[{}] {}", g.section, g.key)
                                 : fmt::format("{} ({}:{})", pin, g.place.file, g.place.line);
    problems.push_back(fmt::format(
        "{} {} is {:.2f}x [{}] {} {}: {}", name, number_text(g.value), g.value / joint_limit,
        section, l.joint_key, number_text(joint_limit),
        compensated ? fmt::format("with backlash compensation the stepgen needs {}x (pncconf "
                                  "doubles it), or it falls behind at every reversal",
                                  number_text(need))
                    : std::string("the stepgen cannot follow the planned ") + l.what));
  }
  for (const auto& p : problems) plan.advice.push_back(fmt::format("{} stepgen: {}", axis, p));
  if (problems.empty()) {
    plan.notes.push_back(fmt::format(
        "{} (joint {}) is a stepper ({} in position mode, no pid): its lag is the stepgen's "
        "timing, not a gain to tune; stepgen limits checked{}, fine",
        axis, joint, loop.instance, compensated ? " against backlash compensation" : ""));
  } else {
    plan.advice.push_back(fmt::format(
        "{} (joint {}) is a stepper ({} in position mode, no pid): its lag is the stepgen's "
        "timing, not a gain to tune; no FF1 or P proposed",
        axis, joint, loop.instance));
  }
}

// The gains of one pid joint, with the measured lag of its axis.
JointServo read_joint(const HalWiring& w, const IniDocument& ini, char axis, int joint,
                      const Loop& loop, double lag_s) {
  JointServo js;
  js.axis = axis;
  js.joint = joint;
  js.pid = loop.instance;
  js.p = gain_of(w, ini, loop.instance + ".Pgain");
  if (js.p.kind == Gain::Kind::unset || !(js.p.value > 0.0)) {
    const HalPlace at = js.p.kind == Gain::Kind::unset ? HalPlace{ini.path(), 0} : js.p.place;
    throw DataError(at.file, at.line,
                    fmt::format("{}.Pgain of joint {} is {}: circcomp proposes FF1 only "
                                "against a positive P",
                                loop.instance, joint,
                                js.p.kind == Gain::Kind::unset ? "set by no setp in the HAL "
                                                                 "files read"
                                                               : number_text(js.p.value)));
  }
  js.ff1 = gain_of(w, ini, loop.instance + ".FF1");
  js.lag_s = lag_s;
  js.c = lag_s * js.p.value + js.ff1.value;
  return js;
}

// The common target lag and each joint's FF1 and P; empty string when it works, else why not.
std::string propose(std::vector<JointServo>& joints, double period_s, const PlanOptions& o) {
  double target = 0.0;
  for (const auto& js : joints) {
    target = std::max(target, (js.c - std::min(js.c, kPreferredFf1)) / js.p.value);
  }
  // A joint that would need FF1 < 0: the target comes down to its lag, and the slow joints
  // reach it with a higher P.
  for (const auto& js : joints) target = std::min(target, js.c / js.p.value);
  target = std::max(target, 0.0);  // a joint that leads already: no lead asked of the others
  for (auto& js : joints) {
    double p = js.p.value;
    double ff1 = js.c - p * target;
    if (ff1 > kPreferredFf1 && target > 0) {
      p = (js.c - kPreferredFf1) / target;
      ff1 = kPreferredFf1;
    }
    ff1 = std::max(ff1, 0.0);
    if (!std::isfinite(p) || !std::isfinite(ff1)) {
      return fmt::format("joint {}: no finite FF1 and P reach the common lag", js.joint);
    }
    if (p > kMaxPFactor * js.p.value || p < kMinPFactor * js.p.value) {
      return fmt::format("joint {} would need P {} ({:.2f}x of {}), outside {}x..{}x", js.joint,
                         number_text(p), p / js.p.value, number_text(js.p.value), kMinPFactor,
                         kMaxPFactor);
    }
    const double kv = p / js.c;
    if (kv * period_s > kMaxGainTimesPeriod) {
      return fmt::format(
          "joint {} would need P {}, a position gain of {:.1f} 1/s: more than "
          "{} / the servo period ({} s) allows",
          js.joint, number_text(p), kv, kMaxGainTimesPeriod, period_s);
    }
    if (ff1 > kMaxFf1) {
      return fmt::format("joint {} would need FF1 {}, above {}", js.joint, number_text(ff1),
                         kMaxFf1);
    }
    js.p_new = js.p.value + o.gain * (p - js.p.value);
    js.ff1_new = js.ff1.value + o.gain * (ff1 - js.ff1.value);
  }
  return "";
}

// The new following error at the joint's top speed against its FERROR.
void check_ferror(const IniDocument& ini, const JointServo& js) {
  const std::string section = fmt::format("JOINT_{}", js.joint);
  const double lag = std::abs((js.c - js.ff1_new) / js.p_new);
  const double vmax = ini_number(ini, section, "MAX_VELOCITY", 0.0);
  const auto fe = ini.find(section, "FERROR");
  if (!fe || vmax <= 0.0) return;
  const double ferror = ini_number(ini, section, "FERROR", 0.0);
  const double min_ferror = ini_number(ini, section, "MIN_FERROR", ferror);
  const double at_top = lag * vmax;
  if (!(at_top < ferror)) {
    throw DataError(fe->file, fe->line,
                    fmt::format("[{}] FERROR {} (MIN_FERROR {}): the proposed lag of {:.2f} ms "
                                "gives a following error of {} at MAX_VELOCITY {}, not below it",
                                section, number_text(ferror), number_text(min_ferror), lag * 1e3,
                                number_text(at_top), number_text(vmax)));
  }
}

// Whether A and B are one place of the configuration: one INI key, or one HAL literal.
bool same_command(const Gain& a, const Gain& b) {
  if (a.kind != b.kind || a.kind == Gain::Kind::unset) return false;
  if (a.kind == Gain::Kind::ini_key) return a.section == b.section && a.key == b.key;
  return a.place.file == b.place.file && a.place.line == b.place.line;
}

std::string gain_where(const Gain& g, const std::string& pin, int joint, const HalPlace& anchor) {
  switch (g.kind) {
    case Gain::Kind::ini_key:
      return fmt::format("[{}] {}", g.section, g.key);
    case Gain::Kind::literal:
      return fmt::format("{}:{} ({})", g.place.file, g.place.line, g.setter);
    case Gain::Kind::unset:
      break;
  }
  return fmt::format("[JOINT_{}] {} (a new setp {} after {}:{})", joint,
                     pin.substr(pin.rfind('.') + 1), pin, anchor.file, anchor.line);
}

// One command setting the gain of two joints (their pids read the same INI key, a gantry's
// second joint set up with the first joint's section, a copied line; or one sets of a signal
// joining both pins) cannot take two different values: the last write would win silently.
// The same value is written once; different ones are refused naming both lines. A sets whose
// signal also joins a pin this plan does not set is refused: the change would reach it too.
void check_shared_gains(const std::vector<JointServo>& joints) {
  struct Use {
    const JointServo* joint;
    const Gain* gain;
    double value;
    const char* pin;
  };
  std::vector<Use> uses;
  std::set<std::string> planned;
  for (const auto& js : joints) {
    uses.push_back({&js, &js.ff1, js.ff1_new, "FF1"});
    uses.push_back({&js, &js.p, js.p_new, "Pgain"});
    planned.insert(js.pid + ".FF1");
    planned.insert(js.pid + ".Pgain");
  }
  for (const Use& u : uses) {
    for (const std::string& other : u.gain->pins) {
      if (planned.count(other) == 0) {
        throw DataError(
            u.gain->place.file, u.gain->place.line,
            fmt::format("{} sets {}.{} and also {}, which this plan does not change: "
                        "give {}.{} a value of its own",
                        u.gain->setter, u.joint->pid, u.pin, other, u.joint->pid, u.pin));
      }
    }
  }
  for (std::size_t i = 0; i < uses.size(); ++i) {
    for (std::size_t k = 0; k < i; ++k) {
      const Use &a = uses[k], &b = uses[i];
      if (!same_command(*a.gain, *b.gain)) continue;
      if (std::abs(a.value - b.value) <= 1e-9 * std::max(std::abs(a.value), std::abs(b.value))) {
        continue;
      }
      const std::string what =
          a.gain->kind == Gain::Kind::ini_key
              ? fmt::format("{} reads [{}]{} as {} does ({}:{})", b.gain->setter, b.gain->section,
                            b.gain->key, a.gain->setter, a.gain->place.file, a.gain->place.line)
              : fmt::format("{} sets {}.{} and {}.{}", b.gain->setter, a.joint->pid, a.pin,
                            b.joint->pid, b.pin);
      throw DataError(
          b.gain->place.file, b.gain->place.line,
          fmt::format("{}, but joint {} needs {} and joint {} needs {}: give each "
                      "joint its own {}",
                      what, a.joint->joint, number_text(a.value), b.joint->joint,
                      number_text(b.value), a.gain->kind == Gain::Kind::ini_key ? "key" : "value"));
    }
  }
}

// Advice: the servo mismatch, which no configuration value of circcomp's changes.
void servo_advice(PlanContext& c) {
  const Diagnosis& d = c.d();
  if (!d.servo_mismatch_ms.value || std::fabs(*d.servo_mismatch_ms.value) < 0.05) return;
  const double m = *d.servo_mismatch_ms.value;
  const char slow = m > 0 ? d.axes[0] : d.axes[1];
  const char fast = m > 0 ? d.axes[1] : d.axes[0];
  std::string joints;
  for (int j : joints_of(c.ini, slow)) joints += fmt::format(" [JOINT_{}]", j);
  std::string how = "until their lag times 1/Kv agree";
  if (d.kv_per_s.value && *d.kv_per_s.value > 0) {
    const double kv = *d.kv_per_s.value;
    const double lag_slow = 1.0 / kv + std::fabs(m) * 1e-3 / 2;
    const double lag_fast = 1.0 / kv - std::fabs(m) * 1e-3 / 2;
    how = fmt::format("(about Kv {:.1f} 1/s now against {:.1f} 1/s: raise it by {:.1f} %)",
                      1.0 / lag_slow, 1.0 / lag_fast, (lag_slow / lag_fast - 1.0) * 100.0);
  }
  c.plan.advice.push_back(fmt::format(
      "servo mismatch: {} lags {} by {:.2f} ms: raise the position-loop gain (P, Kv) of{} "
      "{} or lower {}'s; no INI value of circcomp's changes that",
      slow, fast, std::fabs(m), joints, how, fast));
}

}  // namespace

bool plan_servo(PlanContext& c) {
  IniDocument& ini = c.ini;
  const Diagnosis& d = c.d();
  const PlanOptions& o = c.o;
  Plan& plan = c.plan;
  PlanFiles& files = c.files;
  const HalWiring w = read_hal_wiring(ini, "", true);
  std::vector<JointServo> joints;
  std::vector<std::string> skipped;
  bool stepper = false;
  for (int k = 0; k < 2; ++k) {
    for (const int j : joints_of(ini, d.axes[k])) {
      const Loop loop = find_loop(w, j);
      if (loop.kind == Loop::Kind::stepgen) {
        stepgen_checks(w, ini, d.axes[k], j, loop, plan);
        stepper = true;
        continue;
      }
      if (loop.kind == Loop::Kind::none) {
        skipped.push_back(fmt::format("joint {}", j));
        continue;
      }
      const Measured& lag = d.axis_lag[k].lag_ms;
      if (!lag.value) {
        plan.notes.push_back(fmt::format(
            "{} servo: the diagnosis has no lag of axis {} (it needs commanded columns or a feed "
            "sweep): no FF1 proposed",
            d.axes[k], d.axes[k]));
        return false;
      }
      if (!(std::abs(*lag.value) <= kMaxLagMs)) {
        throw MeasurementError(
            c.source(), 0,
            fmt::format("{} servo lag = {:g} ms is implausible (more than {:g} ms); "
                        "check the measurement",
                        d.axes[k], *lag.value, kMaxLagMs));
      }
      JointServo js = read_joint(w, ini, d.axes[k], j, loop, *lag.value * 1e-3);
      if (lag.standard_error && *lag.standard_error * 10.0 > std::abs(*lag.value)) {
        // A lag whose whole uncertainty asks less of FF1 than is worth changing is matched.
        const double reach = (std::abs(*lag.value) + 2.0 * *lag.standard_error) * 1e-3;
        if (reach * js.p.value >= kMinFf1Change) {
          plan.notes.push_back(fmt::format(
              "{} servo: the lag {:.3f} ms has a standard error of {:.3f} ms, more than a tenth "
              "of it: no FF1 proposed; measure again",
              d.axes[k], *lag.value, *lag.standard_error));
          return false;
        }
        plan.notes.push_back(fmt::format(
            "{} servo: the lag {:.3f} ms (standard error {:.3f} ms) is already matched: FF1 "
            "would change by less than {}",
            d.axes[k], *lag.value, *lag.standard_error, kMinFf1Change));
      }
      joints.push_back(std::move(js));
    }
  }
  if (!skipped.empty() && !stepper) {
    plan.notes.push_back(fmt::format(
        "servo: no pid or stepgen in the HAL files read ({}{}) closes the loop of {}: no FF1 "
        "proposed",
        fmt::join(w.read, ", "),
        w.unread.empty() ? "" : fmt::format("; not read: {}", fmt::join(w.unread, ", ")),
        fmt::join(skipped, ", ")));
  }
  if (joints.empty()) return stepper;
  if (stepper) {
    plan.notes.push_back("servo: the plane mixes stepper and pid joints: no FF1 proposed");
    return true;
  }
  const double period_s = ini_number(ini, "EMCMOT", "SERVO_PERIOD", 1e6) * 1e-9;
  const std::string why = propose(joints, period_s, o);
  if (!why.empty()) {
    plan.advice.push_back(
        fmt::format("servo: FF1 and P within their bounds cannot match the lags ({}): tune by hand "
                    "(docs/compensation.md, Servo)",
                    why));
    return true;
  }
  bool any = false;
  for (const auto& js : joints) {
    any = any || std::abs(js.ff1_new - js.ff1.value) >= kMinFf1Change ||
          std::abs(js.p_new - js.p.value) > 1e-9 * js.p.value;
  }
  if (!any) {
    plan.notes.push_back("servo: FF1 and P already match the measured lags: nothing to change");
    return true;
  }
  for (const auto& js : joints) check_ferror(ini, js);
  check_shared_gains(joints);
  std::set<std::pair<std::string, std::size_t>> written;  // HAL literals, each written once
  auto write = [&](const JointServo& js, const Gain& g, const char* name, double value) {
    const std::string pin = js.pid + "." + name;
    if (g.kind == Gain::Kind::literal && !written.insert({g.place.file, g.place.line}).second) {
      return;
    }
    write_gain(js, g, pin, value, js.p, ini, files);
    if (g.kind == Gain::Kind::literal) {
      plan.hal_values.push_back({g.place.file, g.place.line, g.setter, name, js.axis,
                                 number_text(g.value), number_text(value)});
    }
  };
  for (const auto& js : joints) {
    const double lag_after = (js.c - js.ff1_new) / js.p_new;
    if (std::abs(js.p_new - js.p.value) > 1e-9 * js.p.value) write(js, js.p, "Pgain", js.p_new);
    write(js, js.ff1, "FF1", js.ff1_new);
    plan.changes.push_back(fmt::format(
        "{} servo (joint {}, {}): FF1 {} -> {} at {}{}; lag {:.2f} -> {:.2f} ms", js.axis, js.joint,
        js.pid, number_text(js.ff1.value), number_text(js.ff1_new),
        gain_where(js.ff1, js.pid + ".FF1", js.joint, js.p.place),
        std::abs(js.p_new - js.p.value) > 1e-9 * js.p.value
            ? fmt::format(", P {} -> {} at {}", number_text(js.p.value), number_text(js.p_new),
                          gain_where(js.p, js.pid + ".Pgain", js.joint, js.p.place))
            : fmt::format(", P {} kept", number_text(js.p.value)),
        js.lag_s * 1e3, lag_after * 1e3));
  }
  return true;
}

// Servo: tried on a trial context (the configuration's texts, an empty plan), so that a
// configuration it cannot take keeps every other correction. A refusal of the diagnosis
// itself (MeasurementError) is thrown as for every other step.
void servo_step(PlanContext& c) {
  c.changes_before_servo = c.plan.changes.size();
  if (!c.wants(Correction::servo)) return;
  PlanContext tried = c.trial();
  try {
    if (!plan_servo(tried)) {
      c.plan.notes.insert(c.plan.notes.end(), tried.plan.notes.begin(), tried.plan.notes.end());
      return;
    }
  } catch (const MeasurementError&) {
    throw;
  } catch (const DataError& e) {
    if (c.o.servo_requested) throw;
    c.plan.notes.push_back(fmt::format("servo gains not planned: {}", e.what()));
    return;
  }
  c.merge(std::move(tried));
  c.servo_answered = true;
}

void servo_advice_step(PlanContext& c) {
  if (!c.servo_answered) servo_advice(c);
}

}  // namespace circtest::compensation
