// The INI's numbers and names as the planner reads them: numbers written, units per mm, the
// joints of an axis, the INI's folder.
#include <fmt/format.h>

#include <cctype>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "context.hpp"

namespace circtest::compensation::detail {

namespace fs = std::filesystem;

// Units per mm outside 0.001..1000 are no unit a machine uses (they size a table's loops).
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

// The INI's folder, "" for the current one (so paths in messages stay as the user wrote them).
std::string ini_dir(const std::string& ini_path) {
  return fs::path(ini_path).parent_path().string();
}

}  // namespace circtest::compensation::detail
