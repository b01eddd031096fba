// Squareness: the planes' angles into [CIRCTEST_COMP], the kinematics swapped for
// circtest_kins (same arguments, also a literal "loadrt trivkins" of a HAL file) and
// circtest-comp.hal, added as the last [HAL] HALFILE, setting its pins from the INI.
#include <fmt/format.h>

#include <filesystem>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "context.hpp"

namespace circtest::compensation {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// Below this nothing is written; beyond the maximum the correction is more likely a mistake.
constexpr double kMinSquarenessUrad = 0.5;
constexpr double kMaxSquarenessUrad = 1000.0;

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
                         PlanFiles& files) {
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

// The plane's squareness correction when it passes its checks.
std::optional<SquarenessChange> accepted_squareness(PlanContext& c) {
  std::optional<double> v;
  try {
    v = accepted(c.d().squareness_urad,
                 fmt::format("{}/{} squareness", c.d().axes[0], c.d().axes[1]), kMinSquarenessUrad,
                 kMaxSquarenessUrad, "urad", c.o, c.plan.notes);
  } catch (const DataError& e) {
    throw DataError(c.source(), 0, e.detail());
  }
  if (!v) return std::nullopt;
  return SquarenessChange{std::string(plane_name(c.d().plane)), c.d().axes, c.o.gain * *v};
}

}  // namespace

void accept_squareness_step(PlanContext& c) {
  if (!c.wants(Correction::squareness)) return;
  if (const auto change = accepted_squareness(c)) c.squareness.push_back(*change);
}

void write_squareness_step(PlanContext& c) {
  if (!c.wants(Correction::squareness) || c.squareness.empty()) return;
  plan_squareness_set(c.ini, c.config, c.squareness, c.plan, c.files);
  c.plan.needs_kins_module = true;
}

}  // namespace circtest::compensation
