#include "circtest/compensation/plan.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>

#include "circtest/compensation/comp_table.hpp"
#include "circtest/compensation/config_dir.hpp"
#include "circtest/compensation/friction.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/sha256.hpp"
#include "plan_internal.hpp"

namespace circtest::compensation {

namespace fs = std::filesystem;

namespace detail {

// Plausibility bounds: beyond these a correction is more likely a mistake.
constexpr double kMaxBacklashMm = 0.2;
constexpr double kMaxScalePpm = 1000.0;
constexpr double kMaxSquarenessUrad = 1000.0;
constexpr double kMaxCyclicMm = 0.05;
// Below these there is nothing worth writing.
constexpr double kMinBacklashMm = 1e-4;
constexpr double kMinScalePpm = 0.5;
constexpr double kMinCyclicMm = 1e-4;
constexpr double kMinSquarenessUrad = 0.5;
// What a compensation table is laid out over: a travel (MIN_LIMIT..MAX_LIMIT) beyond 100 m is
// LinuxCNC's "no limit" default (1e99), not a machine's; units per mm outside 0.001..1000 are
// no unit a machine uses. Both size the table's loops and are checked before use.
constexpr double kMaxTravelMm = 1e5;
constexpr double kMinUnitsPerMm = 1e-3;
constexpr double kMaxUnitsPerMm = 1e3;

std::string number_text(double v) {
  std::string s = fmt::format("{:.7f}", v);
  while (s.size() > 1 && s.back() == '0') s.pop_back();
  if (s.back() == '.') s += '0';
  if (s == "-0.0") s = "0.0";
  return s;
}

std::string upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// Machine (joint) units per mm, as LinuxCNC 2.9 reads [TRAJ] LINEAR_UNITS.
double units_per_mm(const IniDocument& ini) {
  const auto entry = ini.find("TRAJ", "LINEAR_UNITS");
  if (!entry || entry->value.empty()) return 1.0;
  if (const auto v = parse_finite(entry->value); v && *v > 0) {
    if (*v < kMinUnitsPerMm || *v > kMaxUnitsPerMm) {
      throw DataError(entry->file, entry->line,
                      fmt::format("[TRAJ] LINEAR_UNITS = {}: expected {} to {} machine units "
                                  "per mm (or mm, inch)",
                                  entry->value, kMinUnitsPerMm, kMaxUnitsPerMm));
    }
    return *v;
  }
  const std::string u = upper(entry->value);
  if (u == "MM" || u == "METRIC") return 1.0;
  if (u == "IN" || u == "INCH" || u == "IMPERIAL") return 1.0 / 25.4;
  throw ParseError(entry->file, entry->line,
                   "[TRAJ] LINEAR_UNITS: unknown unit '" + entry->value + "'");
}

// The joints that move axis LETTER, from the kinematics (trivkins and circtest_kins: the
// coordinates= letters in joint order, a letter twice for a gantry).
std::vector<int> joints_of(const IniDocument& ini, char letter) {
  const auto kins = ini.find("KINS", "KINEMATICS");
  if (!kins || kins->value.empty()) {
    throw DataError(ini.path(), 0, "no [KINS] KINEMATICS: cannot map axes to joints");
  }
  std::istringstream words(kins->value);
  std::string module;
  words >> module;
  if (module != "trivkins" && module != "circtest_kins") {
    throw DataError(kins->file, kins->line,
                    fmt::format("KINEMATICS = {}: circcomp maps axes to joints only for "
                                "trivkins (and circtest_kins); compensate this machine by hand",
                                kins->value));
  }
  std::string coordinates = "XYZABCUVW";  // trivkins' default: joint i is axis i
  for (std::string w; words >> w;) {
    if (w.rfind("coordinates=", 0) == 0) coordinates = upper(w.substr(12));
  }
  std::vector<int> joints;
  for (std::size_t i = 0; i < coordinates.size(); ++i) {
    if (coordinates[i] == letter) joints.push_back(static_cast<int>(i));
  }
  if (joints.empty()) {
    throw DataError(kins->file, kins->line,
                    fmt::format("the kinematics has no joint for axis {}", letter));
  }
  return joints;
}

struct Correction {
  std::optional<double> backlash_mm;
  std::optional<double> scale_ppm;
  std::optional<Cyclic> cyclic;
};

// Checks one measured value; returns it when it is to be applied.
std::optional<double> accepted(const Measured& m, const std::string& what, double min_abs,
                               double max_abs, const char* unit, const PlanOptions& o,
                               std::vector<std::string>& notes) {
  const bool force = o.force;
  if (!m.value) {
    notes.push_back(what + ": not in the diagnosis (null), not changed");
    return std::nullopt;
  }
  const double v = *m.value;
  if (std::fabs(v) < min_abs) {
    notes.push_back(fmt::format("{}: {} {} is below {} {}, nothing to correct", what,
                                number_text(v), unit, number_text(min_abs), unit));
    return std::nullopt;
  }
  if (!force && std::fabs(v) > max_abs) {
    throw DataError("", 0,
                    fmt::format("{} = {} {} is implausible (more than {} {}); check the "
                                "measurement, or {}",
                                what, number_text(v), unit, number_text(max_abs), unit,
                                o.setting_words(PlanSetting::force)));
  }
  if (!force && m.standard_error && *m.standard_error > std::fabs(v)) {
    throw DataError("", 0,
                    fmt::format("{} = {} {} has a standard error of {} {}, larger than the "
                                "value: measure again, or {}",
                                what, number_text(v), unit, number_text(*m.standard_error), unit,
                                o.setting_words(PlanSetting::force)));
  }
  return v;
}

// The INI's folder, "" for the current one (so paths in messages stay as the user wrote them).
std::string ini_dir(const std::string& ini_path) {
  return fs::path(ini_path).parent_path().string();
}

// A configuration file's text (bounded; a FIFO or a folder refused), "" when absent.
std::string slurp_if(const std::string& path, bool& existed) {
  const auto text = read_config_file(path);
  existed = text.has_value();
  return text.value_or("");
}

// The name inside CONFIG of a file the plan changes; UnsafePathError when it lies outside, is a
// link or is not a regular file (checked before it is read: a FIFO would block).
std::string target_name(const ConfigDir& config, const std::string& path) {
  const auto name = config.name_of(path);
  if (!name) {
    throw UnsafePathError(path,
                          fmt::format("outside the configuration directory {}: circcomp changes "
                                      "only files inside it (reading one outside is fine); move "
                                      "it in, or make this change by hand",
                                      config.root()));
  }
  config.regular_or_absent(*name);
  return *name;
}

// The text of a file the plan changes, "" when absent.
std::string read_target(const ConfigDir& config, const std::string& path, bool& existed) {
  target_name(config, path);
  return slurp_if(path, existed);
}

// The INI's own text, for its SHA-256.
std::string ini_text(const std::string& ini_path) {
  bool existed = false;
  std::string text = slurp_if(ini_path, existed);
  if (!existed) throw IoError(ini_path, "no such file (expected the machine's LinuxCNC INI)");
  return text;
}

// The squareness key of [CIRCTEST_COMP] and the circtest_kins pin for a plane.
struct SquarenessKey {
  const char* key;
  const char* pin;
};
constexpr SquarenessKey kSquarenessKeys[] = {
    {"SQUARENESS_XY", "squareness-xy"},
    {"SQUARENESS_YZ", "squareness-yz"},
    {"SQUARENESS_ZX", "squareness-zx"},
};

// The HAL file circcomp adds to [HAL] HALFILE: the kinematics' pins from the INI's values.
std::string comp_hal_text() {
  std::string t =
      "# Written by circcomp (circtest): the squareness compensation of the circtest_kins\n"
      "# kinematics. The values, in rad, live in the INI's [CIRCTEST_COMP] section;\n"
      "# `circcomp revert` removes this file. Pin meanings: docs/kinematics.md.\n";
  for (const auto& k : kSquarenessKeys) {
    t += fmt::format("setp circtest-kins.{} [CIRCTEST_COMP]{}\n", k.pin, k.key);
  }
  return t;
}

// Rewrites "loadrt trivkins ..." lines of a HAL file to load circtest_kins with the same
// arguments; returns the number of lines changed.
int swap_loadrt(std::string& text) {
  int changed = 0;
  std::size_t b = 0;
  while (b < text.size()) {
    std::size_t e = text.find('\n', b);
    if (e == std::string::npos) e = text.size();
    std::size_t p = text.find_first_not_of(" \t", b);
    if (p < e && text.compare(p, 6, "loadrt") == 0) {
      std::size_t q = text.find_first_not_of(" \t", p + 6);
      if (q < e && q > p + 6 && text.compare(q, 8, "trivkins") == 0 &&
          (q + 8 == e || text[q + 8] == ' ' || text[q + 8] == '\t' || text[q + 8] == '\r')) {
        text.replace(q, 8, "circtest_kins");
        e += 5;
        ++changed;
      }
    }
    b = e + 1;
  }
  return changed;
}

// Whether a HAL file loads the kinematics through the INI ("loadrt [KINS]KINEMATICS").
bool loads_kins_from_ini(const std::string& text) {
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    std::istringstream words(line);
    std::string cmd, what;
    words >> cmd >> what;
    if (cmd == "loadrt" && what == "[KINS]KINEMATICS") return true;
  }
  return false;
}

// One plane's squareness correction: its plane ("XY"), axes and angle (urad, gain applied).
struct SquarenessChange {
  std::string plane;
  std::array<char, 2> axes;
  double alpha_urad = 0.0;
};

// The [CIRCTEST_COMP] angle of one plane, rad: the current value plus the change, or the
// change alone when the kinematics is not circtest_kins yet (ACTIVE false).
double plan_squareness_angle(const IniDocument& ini, const SquarenessChange& change, bool active,
                             const std::string& module, Plan& plan) {
  const std::string key = "SQUARENESS_" + change.plane;
  double current = 0.0;
  if (const auto e = ini.find("CIRCTEST_COMP", key)) {
    const auto v = parse_finite(e->value);
    if (!v) {
      throw DataError(
          e->file, e->line,
          fmt::format("[CIRCTEST_COMP] {} = '{}': expected an angle in rad", key, e->value));
    }
    if (active) {
      current = *v;
    } else {
      plan.notes.push_back(fmt::format(
          "[CIRCTEST_COMP] {} = {} was not in effect (the kinematics is {}, not circtest_kins): "
          "the measurement saw none of it, so it is replaced, not added to",
          key, e->value, module));
    }
  }
  const double next = current + change.alpha_urad * 1e-6;
  plan.changes.push_back(fmt::format(
      "[CIRCTEST_COMP] {}: {:.3f} -> {:.3f} urad (circtest_kins{})", key, current * 1e6, next * 1e6,
      active ? "" : fmt::format(", replacing {} in [KINS] KINEMATICS", module)));
  return next;
}

// Squareness corrections (each plane's at most once) added to the kinematics' current values:
// [KINS] KINEMATICS becomes circtest_kins (same arguments), a literal "loadrt trivkins" in a HAL
// file follows, [CIRCTEST_COMP] keeps the three angles and circtest-comp.hal, added as the last
// [HAL] HALFILE, sets the pins from them.
void plan_squareness_set(IniDocument& ini, const ConfigDir& config,
                         const std::vector<SquarenessChange>& changes, Plan& plan,
                         std::map<std::string, std::pair<bool, std::string>>& files) {
  const auto kins = ini.find("KINS", "KINEMATICS");
  for (const SquarenessChange& change : changes) {
    // Refuses a kinematics circcomp cannot map, names a missing axis.
    joints_of(ini, change.axes[0]);
    joints_of(ini, change.axes[1]);
  }
  std::istringstream words(kins->value);
  std::string module, rest;
  words >> module;
  std::getline(words, rest);
  const bool active = module == "circtest_kins";
  std::map<std::string, double> next;  // key -> rad
  for (const SquarenessChange& change : changes) {
    next["SQUARENESS_" + change.plane] = plan_squareness_angle(ini, change, active, module, plan);
  }
  if (!active) ini.set("KINS", "KINEMATICS", "circtest_kins" + rest);
  for (const auto& k : kSquarenessKeys) {
    if (const auto it = next.find(k.key); it != next.end()) {
      ini.set("CIRCTEST_COMP", k.key, fmt::format("{:.6e}", it->second));
    } else if (!ini.find("CIRCTEST_COMP", k.key) || !active) {
      ini.set("CIRCTEST_COMP", k.key, "0.0");
    }
  }
  if (!active) {
    ini.comment_before("CIRCTEST_COMP", "SQUARENESS_XY",
                       "circcomp: squareness compensated by circtest_kins, rad (XY: x += value "
                       "* y; YZ: y += value * z; ZX: z += value * x); set by circtest-comp.hal");
  }

  // The HAL side: the module loaded, and its pins set.
  const std::string dir = ini_dir(ini.path());
  const auto halfiles = ini.get_all("HAL", "HALFILE");
  bool loaded = false, has_comp = false;
  for (const auto& h : halfiles) {
    if (h.value == "circtest-comp.hal") {
      has_comp = true;
      continue;
    }
    const fs::path path = fs::path(dir.empty() ? "." : dir) / h.value;
    std::error_code ec;
    if (fs::path(h.value).extension() != ".hal" || !fs::is_regular_file(path, ec)) continue;
    bool readable = false;
    std::string text = slurp_if(path.string(), readable);
    if (loads_kins_from_ini(text)) loaded = true;
    if (!active && swap_loadrt(text) > 0) {
      loaded = true;
      files[path.string()] = {true, text};
      plan.changes.push_back(fmt::format("{}: loadrt trivkins -> loadrt circtest_kins", h.value));
    } else if (active && text.find("circtest_kins") != std::string::npos) {
      loaded = true;
    }
  }
  if (!loaded) {
    plan.notes.push_back(
        "no HAL file beside the INI loads the kinematics ('loadrt [KINS]KINEMATICS' or 'loadrt "
        "trivkins'): make sure circtest_kins is what your configuration loads");
  }
  if (!has_comp) {
    ini.append("HAL", "HALFILE", "circtest-comp.hal");
    const fs::path comp = fs::path(dir.empty() ? "." : dir) / "circtest-comp.hal";
    bool existed = false;
    const std::string before = read_target(config, comp.string(), existed);
    if (existed && before != comp_hal_text()) {
      throw DataError(comp.string(), 0,
                      "exists but is not [HAL] HALFILE and not circcomp's: move it away first");
    }
    files[comp.string()] = {existed, comp_hal_text()};
  }
}

}  // namespace detail

using namespace detail;

std::string_view library_setting_words(PlanSetting setting) noexcept {
  switch (setting) {
    case PlanSetting::force:
      return "the force setting";
    case PlanSetting::gain:
      return "the gain setting";
    case PlanSetting::record_with_ini:
      return "with circtest-run, or with circlog-record given the INI";
    case PlanSetting::without_squareness:
      return "leave squareness out of the corrections";
    case PlanSetting::without_friction:
      return "leave friction out of the corrections";
  }
  return "a setting";
}

void require_fresh(const std::string& ini_path, const DiagnosisInput& diagnosis, bool force,
                   PlanSettingWords words) {
  if (force) return;
  if (!diagnosis.ini_sha256) {
    throw StaleError(
        fmt::format("{}: has no ini_sha256, so nothing shows it measured {} as it is now; record "
                    "{}, or {}",
                    diagnosis.source, ini_path, words(PlanSetting::record_with_ini),
                    words(PlanSetting::force)));
  }
  const std::string now = sha256_hex(ini_text(ini_path));
  if (*diagnosis.ini_sha256 != now) {
    throw StaleError(fmt::format(
        "{} changed since the measurement of {} (SHA-256 {} then, {} now): a correction "
        "applied twice doubles; measure again, or {}",
        ini_path, diagnosis.source, diagnosis.ini_sha256->substr(0, 12), now.substr(0, 12),
        words(PlanSetting::force)));
  }
}

namespace {

using TableFiles = std::map<std::string, std::pair<bool, std::string>>;  // path -> (existed, after)

// What every step of a plan reads and adds to.
struct PlanContext {
  const std::string& ini_path;
  const DiagnosisInput& d;
  const PlanOptions& o;
  IniDocument& ini;
  const ConfigDir& config;
  double upm;       // machine units per mm
  std::string dir;  // the INI's folder
  Plan& plan;
  TableFiles& tables;
  bool wants(const char* what) const { return o.only.count(what) > 0; }
};

// The corrections of axis k that pass their checks (refusals name the diagnosis).
Correction accepted_correction(const PlanContext& c, int k) {
  const char letter = c.d.axes[k];
  Correction corr;
  try {
    if (c.wants("backlash")) {
      corr.backlash_mm = accepted(c.d.backlash_mm[k], fmt::format("{} backlash", letter),
                                  kMinBacklashMm, kMaxBacklashMm, "mm", c.o, c.plan.notes);
    }
    if (c.wants("scale")) {
      if (!c.d.scale_ppm[k].value && c.d.scale_mismatch_ppm.value) {
        c.plan.notes.push_back(fmt::format(
            "{} scale: only the mismatch of the plane's axes is known (relative channels); "
            "no absolute scale to write",
            letter));
      } else {
        corr.scale_ppm = accepted(c.d.scale_ppm[k], fmt::format("{} scale", letter), kMinScalePpm,
                                  kMaxScalePpm, "ppm", c.o, c.plan.notes);
      }
    }
    if (c.wants("cyclic") && c.d.cyclic[k]) {
      const Cyclic& cy = *c.d.cyclic[k];
      if (accepted({cy.amplitude_mm, cy.amplitude_se_mm}, fmt::format("{} cyclic", letter),
                   kMinCyclicMm, kMaxCyclicMm, "mm", c.o, c.plan.notes)) {
        corr.cyclic = cy;
      }
    }
  } catch (const DataError& e) {
    throw DataError(c.d.source, 0, e.detail());
  }
  return corr;
}

// [section] KEY (MIN_LIMIT, MAX_LIMIT) as the travel a compensation table is laid over.
double travel_limit(const PlanContext& c, const std::string& section, const char* key) {
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
std::optional<std::pair<Cyclic, std::size_t>> cyclic_for_joint(const PlanContext& c, char letter,
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
    throw DataError(c.d.source, 0,
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
    const auto it = c.tables.find(t.path);
    const std::string text =
        it != c.tables.end() ? it->second.second : read_target(c.config, t.path, t.existed);
    if (it != c.tables.end()) t.existed = it->second.first;
    if (!t.existed && it == c.tables.end()) {
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
std::vector<double> corrected_nominals(const CompTable& table, const Correction& corr,
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
CompTable corrected_table(const PlanContext& c, const JointTable& t, const Correction& corr,
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
void plan_joint(PlanContext& c, char letter, const Correction& corr, int j) {
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
  c.tables[t.path] = {t.existed, render_comp_table(next)};
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

// The plane's squareness correction when it passes its checks.
std::optional<SquarenessChange> accepted_squareness(PlanContext& c) {
  std::optional<double> v;
  try {
    v = accepted(c.d.squareness_urad, fmt::format("{}/{} squareness", c.d.axes[0], c.d.axes[1]),
                 kMinSquarenessUrad, kMaxSquarenessUrad, "urad", c.o, c.plan.notes);
  } catch (const DataError& e) {
    throw DataError(c.d.source, 0, e.detail());
  }
  if (!v) return std::nullopt;
  return SquarenessChange{c.d.plane, c.d.axes, c.o.gain * *v};
}

// Squareness: through the circtest_kins kinematics module.
void plan_squareness_step(PlanContext& c, const std::vector<SquarenessChange>& changes) {
  if (changes.empty()) return;
  plan_squareness_set(c.ini, c.config, changes, c.plan, c.tables);
  c.plan.needs_kins_module = true;
}

// Advice: the servo mismatch, which no configuration value of circcomp's changes.
void servo_advice(PlanContext& c) {
  const DiagnosisInput& d = c.d;
  if (!d.servo_mismatch_ms.value || std::fabs(*d.servo_mismatch_ms.value) < 0.05) return;
  const double m = *d.servo_mismatch_ms.value;
  const char slow = m > 0 ? d.axes[0] : d.axes[1];
  const char fast = m > 0 ? d.axes[1] : d.axes[0];
  std::string joints;
  for (int j : joints_of(c.ini, slow)) joints += fmt::format(" [JOINT_{}]", j);
  std::string how = "until their lag times 1/Kv agree";
  if (d.kv_per_s && *d.kv_per_s > 0) {
    const double kv = *d.kv_per_s;
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

// Servo: FF1 (and P) per pid joint from the per-axis lags (servo.cpp), tried on copies as
// friction is. Returns whether it answered the servo (else the mismatch advice follows).
bool servo_step(PlanContext& c) {
  if (!c.wants("servo")) return false;
  IniDocument ini_tried = c.ini;
  Plan plan_tried = c.plan;
  TableFiles tables_tried = c.tables;
  try {
    if (!plan_servo(ini_tried, c.d, c.o, plan_tried, tables_tried)) {
      c.plan.notes = std::move(plan_tried.notes);
      return false;
    }
  } catch (const MeasurementError&) {
    throw;  // the diagnosis refused: as for every other step, whether asked for or not
  } catch (const DataError& e) {
    if (c.o.servo_requested) throw;
    c.plan.notes.push_back(fmt::format("servo gains not planned: {}", e.what()));
    return false;
  }
  c.ini = std::move(ini_tried);
  c.plan = std::move(plan_tried);
  c.tables = std::move(tables_tried);
  return true;
}

// Friction: circfric wired by circtest-fric.hal, its values in [FRICTION_<axis>]. Returns
// whether it was planned.
bool friction_step(PlanContext& c) {
  if (!c.wants("friction")) return false;
  if (c.o.friction_requested) {
    plan_friction(c.ini, c.config, c.d, c.o, c.plan, c.tables);
    return true;
  }
  // Tried on copies: a configuration without a pid or stepgen to splice into (a simulated
  // machine, a HAL of its own kind) keeps every other correction.
  IniDocument ini_tried = c.ini;
  Plan plan_tried = c.plan;
  TableFiles tables_tried = c.tables;
  try {
    plan_friction(ini_tried, c.config, c.d, c.o, plan_tried, tables_tried);
  } catch (const WiringError& e) {
    // Only where to wire the compensator is in question here: what the measurement says (an
    // implausible spike) is refused as ever.
    c.plan.notes.push_back(fmt::format("friction compensation not planned: {}", e.what()));
    return false;
  }
  c.ini = std::move(ini_tried);
  c.plan = std::move(plan_tried);
  c.tables = std::move(tables_tried);
  return true;
}

void spike_advice(PlanContext& c) {
  for (int k = 0; k < 2; ++k) {
    const auto& s = c.d.reversal_spike_mm[k];
    if (!s.value || std::fabs(*s.value) < 1e-3) continue;
    c.plan.advice.push_back(fmt::format(
        "{} reversal spikes of {:.1f} um{}: friction (stick-slip at the reversal), not play; "
        "compensating them as backlash makes parts worse: check gibs and lubrication, or "
        "let circcomp plan friction compensation (circfric)",
        c.d.axes[k], *s.value * 1e3,
        c.d.reversal_spike_ms[k] ? fmt::format(" decaying in {:.0f} ms", *c.d.reversal_spike_ms[k])
                                 : ""));
  }
}

// Every file whose content changes: the INI and its includes, then the tables and HAL files.
void collect_files(PlanContext& c) {
  auto add = [&](const std::string& path, std::string after) {
    FileChange f;
    f.path = path;
    f.name = target_name(c.config, path);
    for (const FileChange& other : c.plan.files) {
      if (other.name == f.name) {
        throw DataError(c.ini_path, 0,
                        fmt::format("{} and {} are the same file ({}): name it one way", other.path,
                                    path, c.config.path(f.name)));
      }
    }
    f.before = slurp_if(path, f.existed);
    f.after = std::move(after);
    if (f.before != f.after) c.plan.files.push_back(std::move(f));
  };
  for (std::size_t i = 0; i < c.ini.file_count(); ++i) {
    if (c.ini.file_modified(i)) add(c.ini.file_path(i), c.ini.render_file(i));
  }
  for (const auto& [path, t] : c.tables) add(path, t.second);
}

// The per-axis corrections (backlash, scale, cyclic) of the plane's axes, except those a test
// set's earlier plane carries.
void plan_axes(PlanContext& c) {
  for (int k = 0; k < 2; ++k) {
    if (c.d.axis_in_earlier_plane[k]) continue;
    const Correction corr = accepted_correction(c, k);
    if (!corr.backlash_mm && !corr.scale_ppm && !corr.cyclic) continue;
    for (const int j : joints_of(c.ini, c.d.axes[k])) plan_joint(c, c.d.axes[k], corr, j);
  }
}

}  // namespace

Plan make_plan(const std::string& ini_path, const DiagnosisInput& d, const PlanOptions& o) {
  if (!(o.gain > 0.0 && o.gain <= 1.0)) {
    throw UsageError(fmt::format("{}: expected 0 < F <= 1", o.setting_words(PlanSetting::gain)));
  }
  Plan plan;
  plan.ini_path = ini_path;
  IniDocument ini = IniDocument::load(ini_path);
  const ConfigDir config(ini_path);
  plan.ini_sha256 = sha256_hex(ini_text(ini_path));
  plan.provenance_checked = d.ini_sha256 && *d.ini_sha256 == plan.ini_sha256;
  TableFiles tables;
  PlanContext c{ini_path, d, o, ini, config, units_per_mm(ini), ini_dir(ini_path), plan, tables};

  plan_axes(c);
  if (c.wants("squareness")) {
    const std::optional<SquarenessChange> change = accepted_squareness(c);
    plan_squareness_step(
        c, change ? std::vector<SquarenessChange>{*change} : std::vector<SquarenessChange>{});
  }
  const std::size_t changes_before_servo = plan.changes.size();
  if (!servo_step(c)) servo_advice(c);
  if (plan.changes.size() > changes_before_servo && c.wants("friction")) {
    // The spike is the loop's answer to the friction: new gains make another spike, and step 1
    // divides by the share of the pulse the old lag passes. Tuned on the old loop, circfric
    // would push the table by that share's inverse (2.5x at FF1 0 -> 1).
    plan.notes.push_back(
        "friction compensation not planned in this round: the servo gains change, and the "
        "reversal spike changes with them; rerun the circle and plan again");
  } else if (!friction_step(c)) {
    spike_advice(c);
  }
  collect_files(c);
  return plan;
}

Plan make_plan(const std::string& ini_path, const std::vector<DiagnosisInput>& planes,
               const PlanOptions& o) {
  if (planes.size() == 1) return make_plan(ini_path, planes.front(), o);
  if (planes.empty()) throw DataError(ini_path, 0, "no plane's diagnosis to plan from");
  if (!(o.gain > 0.0 && o.gain <= 1.0)) {
    throw UsageError(fmt::format("{}: expected 0 < F <= 1", o.setting_words(PlanSetting::gain)));
  }
  for (const auto& [requested, what] :
       {std::pair{o.friction_requested, "friction"}, std::pair{o.servo_requested, "servo"}}) {
    if (requested && o.only.size() == 1) {
      throw UsageError(
          fmt::format("{}: {} is planned from one plane's diagnosis, not from a test set (circana "
                      "diagnose --plane P --json)",
                      planes.front().source, what));
    }
  }
  Plan plan;
  plan.ini_path = ini_path;
  IniDocument ini = IniDocument::load(ini_path);
  const ConfigDir config(ini_path);
  const DiagnosisInput& first = planes.front();
  plan.ini_sha256 = sha256_hex(ini_text(ini_path));
  plan.provenance_checked = first.ini_sha256 && *first.ini_sha256 == plan.ini_sha256;
  TableFiles tables;
  std::vector<SquarenessChange> squareness;
  for (const DiagnosisInput& d : planes) {
    PlanContext c{ini_path, d, o, ini, config, units_per_mm(ini), ini_dir(ini_path), plan, tables};
    plan_axes(c);
    if (c.wants("squareness")) {
      if (const auto change = accepted_squareness(c)) squareness.push_back(*change);
    }
    servo_advice(c);
    spike_advice(c);
  }
  PlanContext c{ini_path,          first, o,     ini, config, units_per_mm(ini),
                ini_dir(ini_path), plan,  tables};
  if (c.wants("squareness")) plan_squareness_step(c, squareness);
  if (c.wants("friction")) {
    plan.notes.push_back(
        "friction compensation is not planned from a test set: plan it from one plane's "
        "diagnosis (circana diagnose --plane P --json)");
  }
  if (c.wants("servo")) {
    // FF1 and P are matched to a common lag of the joints a plan changes together; the planes
    // of a set each measured two axes at their own feed, so one axis's lag comes from up to
    // two planes and a common target over three axes from none.
    plan.notes.push_back(
        "servo gains are not planned from a test set: its planes measured each axis's lag in "
        "different circles; plan them from one plane's diagnosis (circana diagnose --plane P "
        "--json)");
  }
  collect_files(c);
  return plan;
}

// ---- unified diff (LCS over lines; configuration files are small) ----

namespace {

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::size_t b = 0;
  while (b < text.size()) {
    std::size_t e = text.find('\n', b);
    e = e == std::string::npos ? text.size() : e + 1;
    out.push_back(text.substr(b, e - b));
    b = e;
  }
  return out;
}

struct Op {
  char kind;  // ' ' kept, '-' removed, '+' added
  std::size_t ai, bi;
};

// The LCS table walk: for files up to kMaxLcsCells (configuration files are small), ties
// taking '-' first.
constexpr std::size_t kMaxLcsCells = std::size_t{4} << 20;
std::vector<Op> lcs_script(const std::vector<std::string>& a, const std::vector<std::string>& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<unsigned>> lcs(n + 1, std::vector<unsigned>(m + 1, 0));
  for (std::size_t i = n; i-- > 0;) {
    for (std::size_t j = m; j-- > 0;) {
      lcs[i][j] = a[i] == b[j] ? lcs[i + 1][j + 1] + 1 : std::max(lcs[i + 1][j], lcs[i][j + 1]);
    }
  }
  std::vector<Op> ops;
  std::size_t i = 0, j = 0;
  while (i < n || j < m) {
    if (i < n && j < m && a[i] == b[j])
      ops.push_back({' ', i++, j++});
    else if (j < m && (i == n || lcs[i][j + 1] > lcs[i + 1][j]))  // ties: '-' first
      ops.push_back({'+', i, j++});
    else
      ops.push_back({'-', i++, j});
  }
  return ops;
}

// Myers' greedy shortest edit script for larger files: time O((N + M) D), memory O(D^2) for
// D changed lines (a large INI with a few changes plans in bounded memory).
std::vector<Op> myers_script(const std::vector<std::string>& a, const std::vector<std::string>& b) {
  const long n = static_cast<long>(a.size()), m = static_cast<long>(b.size());
  std::vector<std::vector<long>> trace;  // V of every d: the furthest x on diagonal k
  std::vector<long> v(3, 0);             // diagonals -d-1 .. d+1 at offset d+1
  long d = 0;
  bool reached = false;
  for (;; ++d) {
    std::vector<long> next(2 * d + 3, 0);
    const auto at = [](std::vector<long>& row, long dd, long k) -> long& {
      return row[static_cast<std::size_t>(k + dd + 1)];
    };
    for (long k = -d; k <= d; k += 2) {
      long x = 0;
      if (d == 0) {
        x = 0;
      } else if (k == -d || (k != d && at(v, d - 1, k - 1) < at(v, d - 1, k + 1))) {
        x = at(v, d - 1, k + 1);  // down: an added line
      } else {
        x = at(v, d - 1, k - 1) + 1;  // right: a removed line
      }
      long y = x - k;
      while (x < n && y < m && a[static_cast<std::size_t>(x)] == b[static_cast<std::size_t>(y)]) {
        ++x;
        ++y;
      }
      at(next, d, k) = x;
      if (x >= n && y >= m) {
        reached = true;
        break;
      }
    }
    trace.push_back(next);
    if (reached) break;
    v = std::move(next);
  }
  std::vector<Op> ops;
  long x = n, y = m;
  for (long dd = d; dd > 0; --dd) {
    const std::vector<long>& prev = trace[static_cast<std::size_t>(dd - 1)];
    const auto prev_at = [&](long k) { return prev[static_cast<std::size_t>(k + dd)]; };
    const long k = x - y;
    const bool down = k == -dd || (k != dd && prev_at(k - 1) < prev_at(k + 1));
    const long pk = down ? k + 1 : k - 1;
    const long px = prev_at(pk), py = px - pk;
    while (x > (down ? px : px + 1) && y > (down ? py + 1 : py)) {
      --x;
      --y;
      ops.push_back({' ', static_cast<std::size_t>(x), static_cast<std::size_t>(y)});
    }
    if (down) {
      --y;
      ops.push_back({'+', static_cast<std::size_t>(x), static_cast<std::size_t>(y)});
    } else {
      --x;
      ops.push_back({'-', static_cast<std::size_t>(x), static_cast<std::size_t>(y)});
    }
  }
  while (x > 0 && y > 0) {
    --x;
    --y;
    ops.push_back({' ', static_cast<std::size_t>(x), static_cast<std::size_t>(y)});
  }
  std::reverse(ops.begin(), ops.end());
  return ops;
}

std::string file_diff(const FileChange& f) {
  const auto a = lines_of(f.before), b = lines_of(f.after);
  const std::vector<Op> ops =
      (a.size() + 1) * (b.size() + 1) <= kMaxLcsCells ? lcs_script(a, b) : myers_script(a, b);
  auto show = [](std::string line) {
    if (line.empty() || line.back() != '\n') return line + "\n\\ No newline at end of file\n";
    return line;
  };
  std::string out =
      fmt::format("--- {}\n+++ {}\n", f.existed ? "a/" + f.path : "/dev/null", "b/" + f.path);
  constexpr std::size_t kContext = 3;
  std::size_t k = 0;
  while (k < ops.size()) {
    if (ops[k].kind == ' ') {
      ++k;
      continue;
    }
    std::size_t start = k >= kContext ? k - kContext : 0;
    while (start < k && ops[start].kind != ' ') ++start;
    std::size_t end = k;
    std::size_t same = 0;
    while (end < ops.size() && same <= 2 * kContext) {
      same = ops[end].kind == ' ' ? same + 1 : 0;
      ++end;
    }
    end = std::min(ops.size(), end - (same > kContext ? same - kContext : 0));
    std::size_t a_count = 0, b_count = 0;
    for (std::size_t q = start; q < end; ++q) {
      a_count += ops[q].kind != '+';
      b_count += ops[q].kind != '-';
    }
    const std::size_t a_start = ops[start].ai + (a_count ? 1 : 0);
    const std::size_t b_start = ops[start].bi + (b_count ? 1 : 0);
    out += fmt::format("@@ -{},{} +{},{} @@\n", a_start, a_count, b_start, b_count);
    for (std::size_t q = start; q < end; ++q) {
      const Op& op = ops[q];
      out += op.kind;
      out += show(op.kind == '+' ? b[op.bi] : a[op.ai]);
    }
    k = end;
  }
  return out;
}

}  // namespace

std::string unified_diff(const Plan& plan) {
  std::string out;
  for (const FileChange& f : plan.files) out += file_diff(f);
  return out;
}

std::string linuxcnc_module_dir() {
  std::string dir = "/usr/lib/linuxcnc/modules";
  std::optional<std::string> conf;
  try {
    conf = read_config_file("/etc/linuxcnc/rtapi.conf");
  } catch (const Error&) {
    return dir;  // unreadable: LinuxCNC's default
  }
  std::istringstream in(conf.value_or(""));
  for (std::string line; std::getline(in, line);) {
    if (!line.starts_with("RTLIB_DIR=")) continue;
    std::string value = line.substr(10);
    if (value.size() >= 2 && (value.front() == '"' || value.front() == '\'') &&
        value.back() == value.front()) {
      value = value.substr(1, value.size() - 2);
    }
    if (!value.empty()) dir = value;
  }
  return dir;
}

namespace {

// Refuses unless the module the plan loads is a file: ENV_NAME's value, else FILE_NAME in
// linuxcnc_module_dir().
void require_module(const char* env_name, const char* file_name, const char* what,
                    PlanSetting without, PlanSettingWords words) {
  const char* chosen = std::getenv(env_name);
  const bool from_env = chosen != nullptr && *chosen != '\0';
  const std::string module =
      from_env ? std::string(chosen) : linuxcnc_module_dir() + "/" + file_name;
  std::error_code ec;
  if (fs::is_regular_file(module, ec)) return;
  throw HalError(fmt::format(
      "the plan loads {} but {} is not there{}, so LinuxCNC could not start this configuration: "
      "install circtest's realtime modules (the circtest package, or cmake's install step as "
      "root), set {} to the {} your run loads (circtest-run's build tree), or {}; nothing changed",
      what, module,
      from_env ? fmt::format(" ({})", env_name)
               : std::string(" (where LinuxCNC's loadrt looks for modules)"),
      env_name, file_name, words(without)));
}

}  // namespace

void require_kins_module(const Plan& plan, PlanSettingWords words) {
  if (plan.needs_kins_module) {
    require_module("CIRCTEST_KINS_MODULE", "circtest_kins.so",
                   "the circtest_kins kinematics (squareness)", PlanSetting::without_squareness,
                   words);
  }
  if (plan.needs_fric_module) {
    require_module("CIRCTEST_FRIC_MODULE", "circfric.so", "circfric (friction compensation)",
                   PlanSetting::without_friction, words);
  }
}

}  // namespace circtest::compensation
