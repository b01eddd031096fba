// Where LinuxCNC loads realtime modules from, and the check that the modules a plan loads
// (circtest_kins, circfric) are there.
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string>

#include "circtest/compensation/config_dir.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/error.hpp"

namespace circtest::compensation {

namespace fs = std::filesystem;

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
