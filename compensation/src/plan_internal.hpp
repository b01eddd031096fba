#pragma once
// Helpers plan.cpp shares with the other parts of the plan (friction.cpp); not installed.
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "circtest/compensation/config_dir.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/error.hpp"
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

namespace circtest::compensation {

// A value of the diagnosis itself refused by a step (a servo lag no loop can have): plan() tells
// it by its type from what the configuration cannot take, which only skips the step when the
// step was not asked for by name. A data error (exit 5) naming the diagnosis.
class MeasurementError : public DataError {
 public:
  using DataError::DataError;
};

// servo.cpp: FF1 (and P where FF1 alone cannot match) per pid joint of the diagnosis's axes,
// from their measured lags, written where the HAL reads them (an INI key, or a literal setp
// edited in place, into FILES: path -> (existed, content)); stepgen joints get the stepgen
// checks. Returns false when the diagnosis has no per-axis lag for a pid joint (the plan then
// gives the mismatch advice). Throws MeasurementError for a lag no servo loop has, DataError
// naming the HAL or INI file and line where a gain cannot be read or written, or the new lag
// breaks FERROR.
bool plan_servo(IniDocument& ini, const DiagnosisInput& d, const PlanOptions& o, Plan& plan,
                std::map<std::string, std::pair<bool, std::string>>& files);

}  // namespace circtest::compensation
