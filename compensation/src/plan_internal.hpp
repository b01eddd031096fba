#pragma once
// Helpers plan.cpp shares with the other parts of the plan (friction.cpp); not installed.
#include <string>
#include <vector>

#include "circtest/compensation/config_dir.hpp"
#include "circtest/core/ini.hpp"

namespace circtest::compensation::detail {

// A number as circcomp writes it into a configuration: up to 7 decimals, no trailing zeros.
std::string number_text(double v);
std::string upper(std::string s);
// Machine (joint) units per mm ([TRAJ] LINEAR_UNITS).
double units_per_mm(const IniDocument& ini);
// The joints that move axis LETTER (trivkins / circtest_kins coordinates=).
std::vector<int> joints_of(const IniDocument& ini, char letter);
// The INI's folder, "" for the current one.
std::string ini_dir(const std::string& ini_path);
// A configuration file's text (bounded; a FIFO or folder refused), "" when absent.
std::string slurp_if(const std::string& path, bool& existed);
// The text of a file the plan changes (checked inside CONFIG first), "" when absent.
std::string read_target(const ConfigDir& config, const std::string& path, bool& existed);

}  // namespace circtest::compensation::detail
