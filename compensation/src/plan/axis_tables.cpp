// The per-axis corrections of a plan: backlash into [JOINT_n] BACKLASH, or with a scale or
// cyclic term every correction into the joint's compensation table (COMP_FILE).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/compensation/comp_table.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "context.hpp"

namespace circtest::compensation {

namespace fs = std::filesystem;

namespace detail {

// Plausibility bounds: beyond these a correction is more likely a mistake. Scale: a C7 rolled
// ball screw may deviate 50 um per 300 mm (167 ppm) and a steel screw 10 K warmer than at its
// calibration adds 115 ppm; 500 ppm leaves room above that (docs/compensation.md), and a
// diagnosis that reads a servo's amplitude response as scale gives more.
constexpr double kMaxBacklashMm = 0.2;
constexpr double kMaxScalePpm = 500.0;
constexpr double kMaxCyclicMm = 0.05;
// Below these there is nothing worth writing.
constexpr double kMinBacklashMm = 1e-4;
constexpr double kMinScalePpm = 0.5;
constexpr double kMinCyclicMm = 1e-4;
// What a compensation table is laid out over: a travel (MIN_LIMIT..MAX_LIMIT) beyond 100 m is
// LinuxCNC's "no limit" default (1e99), not a machine's; it sizes the table's loops and is
// checked before use.
constexpr double kMaxTravelMm = 1e5;
// Checks one measured value; returns it when it is to be applied.
std::string quantity_text(double v, const char* unit, double units_per_mm) {
  if (std::string_view(unit) != "mm" || std::fabs(units_per_mm - 1.0) < 1e-12) {
    return fmt::format("{} {}", number_text(v), unit);
  }
  if (std::fabs(units_per_mm * 25.4 - 1.0) < 1e-9) {
    return fmt::format("{} in ({} mm)", number_text(v * units_per_mm), number_text(v));
  }
  return fmt::format("{} mm ({} machine units)", number_text(v), number_text(v * units_per_mm));
}

std::optional<double> accepted(const Measured& m, const std::string& what, double min_abs,
                               double max_abs, const char* unit, const PlanOptions& o,
                               std::vector<std::string>& notes, double units_per_mm) {
  const bool force = o.force;
  const auto text = [&](double x) { return quantity_text(x, unit, units_per_mm); };
  if (!m.value) {
    notes.push_back(what + ": not in the diagnosis (null), not changed");
    return std::nullopt;
  }
  const double v = *m.value;
  if (std::fabs(v) < min_abs) {
    notes.push_back(
        fmt::format("{}: {} is below {}, nothing to correct", what, text(v), text(min_abs)));
    return std::nullopt;
  }
  if (!force && std::fabs(v) > max_abs) {
    throw DataError("", 0,
                    fmt::format("{} = {} is implausible (more than {}); check the "
                                "measurement, or {}",
                                what, text(v), text(max_abs), o.setting_words(PlanSetting::force)));
  }
  if (!force && m.standard_error && *m.standard_error > std::fabs(v)) {
    throw DataError(
        "", 0,
        fmt::format("{} = {} has a standard error of {}, larger than the "
                    "value: measure again, or {}",
                    what, text(v), text(*m.standard_error), o.setting_words(PlanSetting::force)));
  }
  return v;
}

}  // namespace detail

using namespace detail;

namespace {

struct AxisCorrection {
  std::optional<double> backlash_mm;
  std::optional<double> scale_ppm;
  std::optional<Cyclic> cyclic;
};

// The corrections of axis k that pass their checks (refusals name the diagnosis).
AxisCorrection accepted_correction(PlanContext& c, int k) {
  const char letter = c.d().axes[k];
  AxisCorrection corr;
  try {
    if (c.wants(Correction::backlash)) {
      corr.backlash_mm = accepted(c.d().backlash_mm[k], fmt::format("{} backlash", letter),
                                  kMinBacklashMm, kMaxBacklashMm, "mm", c.o, c.plan.notes, c.upm);
    }
    if (c.wants(Correction::scale)) {
      if (!c.d().scale_ppm[k].value && c.d().scale_mismatch_ppm.value) {
        c.plan.notes.push_back(fmt::format(
            "{} scale: only the mismatch of the plane's axes is known (relative channels); "
            "no absolute scale to write",
            letter));
      } else if (const Measured& s = c.d().scale_ppm[k];
                 s.value && s.standard_error && std::fabs(*s.value) >= kMinScalePpm &&
                 std::fabs(*s.value) <= kMaxScalePpm && *s.standard_error > std::fabs(*s.value)) {
        // A scale's standard error holds the loop's possible amplitude response at the test's
        // speed (docs/diagnosis.md), which measuring again does not shrink: no correction, and
        // the rest of the plan goes on.
        c.plan.notes.push_back(fmt::format(
            "{} scale: {:.1f} ppm is within its standard error of {:.1f} ppm: not changed (a "
            "larger diameter or a lower feed measures it closer)",
            letter, *s.value, *s.standard_error));
      } else {
        corr.scale_ppm = accepted(s, fmt::format("{} scale", letter), kMinScalePpm, kMaxScalePpm,
                                  "ppm", c.o, c.plan.notes);
      }
    }
    if (c.wants(Correction::cyclic) && c.d().cyclic[k]) {
      const Cyclic& cy = *c.d().cyclic[k];
      if (accepted({cy.amplitude_mm, cy.amplitude_se_mm}, fmt::format("{} cyclic", letter),
                   kMinCyclicMm, kMaxCyclicMm, "mm", c.o, c.plan.notes, c.upm)) {
        corr.cyclic = cy;
      }
    }
  } catch (const DataError& e) {
    throw DataError(c.source(), 0, e.detail());
  }
  return corr;
}

// [section] KEY (MIN_LIMIT, MAX_LIMIT) as the travel a compensation table is laid over.
double travel_limit(PlanContext& c, const std::string& section, const char* key) {
  const auto e = c.ini.find(section, key);
  const auto v = e ? parse_finite(e->value) : std::nullopt;
  if (!v) {
    throw DataError(c.ini_path, 0,
                    fmt::format("[{}] {} is needed to lay out a compensation table", section, key));
  }
  if (std::fabs(*v) > kMaxTravelMm * c.upm) {
    throw DataError(e->file, e->line,
                    fmt::format("[{}] {} = {}: a compensation table needs the real travel "
                                "(within +-{} mm)",
                                section, key, e->value, kMaxTravelMm));
  }
  return *v;
}

// The cyclic correction of a joint with its table's point count: at least 16 points a pitch
// over the whole travel, within LinuxCNC's 256; counted in double first, so that no pitch and
// travel overflow the count. Empty (with a note) when the table cannot hold it.
std::optional<std::pair<Cyclic, std::size_t>> cyclic_for_joint(PlanContext& c, char letter,
                                                               const std::string& section,
                                                               const Cyclic& cyclic) {
  const double span = travel_limit(c, section, "MAX_LIMIT") - travel_limit(c, section, "MIN_LIMIT");
  const double points = std::ceil(span / (cyclic.pitch_mm * c.upm / 16.0)) + 1;
  if (!(points <= static_cast<double>(kMaxCompEntries))) {
    c.plan.notes.push_back(
        fmt::format("{} cyclic: a {} mm pitch over [{}] MIN_LIMIT..MAX_LIMIT needs {:.0f} points, "
                    "more than LinuxCNC's 256: not written",
                    letter, number_text(cyclic.pitch_mm), section, points));
    return std::nullopt;
  }
  return std::pair{cyclic, static_cast<std::size_t>(std::max(points, 2.0))};
}

double backlash_in_ini(const IniDocument& ini, const std::string& section) {
  const auto e = ini.find(section, "BACKLASH");
  if (!e || e->value.empty()) return 0.0;
  const auto v = parse_finite(e->value);
  if (!v) throw ParseError(e->file, e->line, "[" + section + "] BACKLASH: not a number");
  return *v;
}

// A joint without a table: the backlash correction goes into [section] BACKLASH.
void plan_backlash_key(PlanContext& c, const std::string& section, char letter, double backlash_mm,
                       double backlash_now) {
  const double add = c.o.gain * backlash_mm * c.upm;
  double next = backlash_now + add;
  if (next < 0) {
    c.plan.notes.push_back(
        fmt::format("[{}] BACKLASH {} + {} is negative: set to 0 (the machine is over-compensated)",
                    section, number_text(backlash_now), number_text(add)));
    next = 0;
  }
  if (!std::isfinite(next)) {
    throw DataError(c.source(), 0,
                    fmt::format("[{}] BACKLASH {} + {} is not a finite number", section,
                                number_text(backlash_now), number_text(add)));
  }
  c.ini.set(section, "BACKLASH", number_text(next));
  c.plan.changes.push_back(fmt::format("[{}] BACKLASH {} -> {} (axis {} backlash {:+.4f} mm)",
                                       section, number_text(backlash_now), number_text(next),
                                       letter, backlash_mm));
}

struct JointTable {
  CompTable table;
  std::string path;
  bool existed = false;
};

// The joint's table: its COMP_FILE, or a new one over MIN_LIMIT..MAX_LIMIT with BACKLASH in it.
JointTable table_of_joint(PlanContext& c, const std::string& section, int j, double lo, double hi,
                          double backlash_now) {
  JointTable t;
  if (const auto comp_file = c.ini.get(section, "COMP_FILE")) {
    t.path =
        fs::path(*comp_file).is_absolute() ? *comp_file : (fs::path(c.dir) / *comp_file).string();
    const auto type_text = c.ini.get(section, "COMP_FILE_TYPE").value_or("0");
    const auto type = parse_finite(type_text);
    if (!type || (*type != 0 && *type != 1)) {
      throw DataError(
          c.ini_path, 0,
          fmt::format("[{}] COMP_FILE_TYPE = {} (expected 0 or 1)", section, type_text));
    }
    const auto it = c.files.find(t.path);
    const std::string text =
        it != c.files.end() ? it->second.second : read_target(c.config, t.path, t.existed);
    if (it != c.files.end()) t.existed = it->second.first;
    if (!t.existed && it == c.files.end()) {
      throw DataError(c.ini_path, 0,
                      fmt::format("[{}] COMP_FILE {}: no such file", section, *comp_file));
    }
    t.table = parse_comp_table(text, static_cast<int>(*type), t.path);
    if (backlash_now != 0.0) {
      c.plan.notes.push_back(fmt::format(
          "[{}] BACKLASH = {} has no effect: LinuxCNC ignores it when a COMP_FILE is set", section,
          number_text(backlash_now)));
    }
    return t;
  }
  const std::string name = fmt::format("circtest-joint{}.comp", j);
  t.path = (fs::path(c.dir) / name).string();
  t.table.type = 1;
  t.table.entries = {{lo, backlash_now / 2, -backlash_now / 2},
                     {hi, backlash_now / 2, -backlash_now / 2}};
  read_target(c.config, t.path, t.existed);
  if (t.existed) {
    throw DataError(t.path, 0,
                    fmt::format("exists but [{}] has no COMP_FILE: move it away first", section));
  }
  c.ini.set(section, "COMP_FILE", name);
  c.ini.set(section, "COMP_FILE_TYPE", "1");
  c.ini.set(section, "BACKLASH", "0");
  c.ini.comment_before(section, "BACKLASH",
                       fmt::format("circcomp: backlash ({}) is in {}; LinuxCNC ignores "
                                   "BACKLASH when a COMP_FILE is set",
                                   number_text(backlash_now), name));
  c.plan.changes.push_back(
      fmt::format("[{}] COMP_FILE {} created (type 1, BACKLASH {} moved into it)", section, name,
                  number_text(backlash_now)));
  return t;
}

// The nominal points of the corrected table: the table's own, the travel's ends (a scale trim
// grows along the whole travel), and for a cyclic term at least 16 points a pitch.
std::vector<double> corrected_nominals(const CompTable& table, const AxisCorrection& corr,
                                       const std::optional<std::pair<Cyclic, std::size_t>>& cyclic,
                                       double lo, double hi, const std::string& table_path) {
  std::vector<double> nominal;
  for (const auto& e : table.entries) nominal.push_back(e.nominal);
  if (corr.scale_ppm || cyclic) {
    nominal.push_back(lo);
    nominal.push_back(hi);
  }
  if (cyclic) {
    const std::size_t n = cyclic->second;
    for (std::size_t i = 0; i < n; ++i) {
      nominal.push_back(
          std::min(hi, lo + static_cast<double>(i) * (hi - lo) / static_cast<double>(n - 1)));
    }
  }
  std::sort(nominal.begin(), nominal.end());
  nominal.erase(std::unique(nominal.begin(), nominal.end(),
                            [](double a, double b) { return std::fabs(a - b) < 1e-9; }),
                nominal.end());
  if (nominal.size() > kMaxCompEntries) {
    throw DataError(
        table_path, 0,
        fmt::format("the merged table would have {} entries, more than 256", nominal.size()));
  }
  return nominal;
}

// The table with the corrections added to its trims at every nominal point.
CompTable corrected_table(PlanContext& c, const JointTable& t, const AxisCorrection& corr,
                          const std::optional<std::pair<Cyclic, std::size_t>>& cyclic, double lo,
                          double hi) {
  CompTable next;
  next.type = t.table.type;
  for (const double x : corrected_nominals(t.table, corr, cyclic, lo, hi, t.path)) {
    CompEntry e = t.table.at(x);
    double common = 0.0;
    if (corr.scale_ppm) common -= c.o.gain * *corr.scale_ppm * 1e-6 * x;
    if (cyclic) {
      const Cyclic& cy = cyclic->first;
      common -= c.o.gain * cy.amplitude_mm * c.upm *
                std::sin(2 * std::numbers::pi * x / (cy.pitch_mm * c.upm) + cy.phase_rad);
    }
    e.forward_trim += common;
    e.reverse_trim += common;
    if (corr.backlash_mm) {
      e.forward_trim += c.o.gain * *corr.backlash_mm * c.upm / 2;
      e.reverse_trim -= c.o.gain * *corr.backlash_mm * c.upm / 2;
    }
    if (!std::isfinite(e.forward_trim) || !std::isfinite(e.reverse_trim)) {
      throw DataError(t.path, 0,
                      fmt::format("the corrected trim at {} is not a finite number: the "
                                  "correction is out of any range a table can hold",
                                  number_text(x)));
    }
    next.entries.push_back(e);
  }
  return next;
}

// Joint j of axis `letter`: its BACKLASH, or its compensation table with every correction.
void plan_joint(PlanContext& c, char letter, const AxisCorrection& corr, int j) {
  const std::string section = fmt::format("JOINT_{}", j);
  if (!c.ini.has_section(section)) {
    throw DataError(c.ini_path, 0, fmt::format("no [{}] section for axis {}", section, letter));
  }
  const auto cyclic =
      corr.cyclic ? cyclic_for_joint(c, letter, section, *corr.cyclic) : std::nullopt;
  const bool needs_table = c.ini.get(section, "COMP_FILE") || corr.scale_ppm || cyclic;
  if (!needs_table && !corr.backlash_mm) return;
  const double backlash_now = backlash_in_ini(c.ini, section);
  if (!needs_table) {
    plan_backlash_key(c, section, letter, *corr.backlash_mm, backlash_now);
    return;
  }
  const double lo = travel_limit(c, section, "MIN_LIMIT"),
               hi = travel_limit(c, section, "MAX_LIMIT");
  if (!(hi > lo))
    throw DataError(c.ini_path, 0, fmt::format("[{}] MAX_LIMIT <= MIN_LIMIT", section));
  const JointTable t = table_of_joint(c, section, j, lo, hi, backlash_now);
  const CompTable next = corrected_table(c, t, corr, cyclic, lo, hi);
  c.files[t.path] = {t.existed, render_comp_table(next)};
  std::string what;
  if (corr.backlash_mm) what += fmt::format(" backlash {:+.4f} mm", c.o.gain * *corr.backlash_mm);
  if (corr.scale_ppm) what += fmt::format(" scale {:+.2f} ppm", -c.o.gain * *corr.scale_ppm);
  if (cyclic) {
    what += fmt::format(" cyclic {:.4f} mm / {} mm", cyclic->first.amplitude_mm,
                        number_text(cyclic->first.pitch_mm));
  }
  c.plan.changes.push_back(fmt::format("[{}] {} ({} entries, type {}):{}", section,
                                       fs::path(t.path).filename().string(), next.entries.size(),
                                       next.type, what));
}

// The per-axis corrections (backlash, scale, cyclic) of the plane's axes, except those a test
// set's earlier plane carries.
void plan_axes(PlanContext& c) {
  for (int k = 0; k < 2; ++k) {
    if (c.input().axis_in_earlier_plane[k]) continue;
    const AxisCorrection corr = accepted_correction(c, k);
    if (!corr.backlash_mm && !corr.scale_ppm && !corr.cyclic) continue;
    for (const int j : joints_of(c.ini, c.d().axes[k])) plan_joint(c, c.d().axes[k], corr, j);
  }
}

}  // namespace

void axes_step(PlanContext& c) {
  plan_axes(c);
}

}  // namespace circtest::compensation
