#include "circtest/session/linuxcnc.hpp"

#include <fmt/format.h>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "circtest/core/error.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/session/process.hpp"

namespace circtest::session {

namespace fs = std::filesystem;

MachineState machine_state() {
  int code = 0;
  const std::string out = program_output({tool_path("circtest-linuxcnc"), "status"}, code);
  if (code != 0) throw HalError("no running LinuxCNC could be reached (see above)");
  MachineState s;
  try {
    const auto j = nlohmann::json::parse(out);
    s.task_state = j.at("task_state").get<std::string>();
    s.estop = j.at("estop").get<bool>();
    s.homed = j.at("homed").get<std::vector<bool>>();
    s.interp_state = j.at("interp_state").get<std::string>();
    s.feed_override = j.at("feed_override").get<double>();
    const auto origin = j.at("work_origin_machine").get<std::vector<double>>();
    for (std::size_t i = 0; i < 3 && i < origin.size(); ++i)
      s.work_origin_machine_mm[i] = origin[i];
    s.ini_filename = j.at("ini_filename").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    throw HalError(std::string("the LinuxCNC link answered what it should not: ") + e.what());
  }
  return s;
}

void require_ready(const MachineState& s, const std::string& ini_path) {
  std::error_code ec;
  const fs::path ours = fs::weakly_canonical(ini_path, ec);
  const fs::path theirs = fs::weakly_canonical(s.ini_filename, ec);
  if (ours != theirs) {
    throw HalError(
        fmt::format("LinuxCNC runs {}, not {}: start this machine, or name the INI "
                    "it runs",
                    s.ini_filename, ini_path));
  }
  if (s.estop || s.task_state == "estop" || s.task_state == "estop-reset") {
    throw HalError("LinuxCNC is in E-stop: release it and switch the machine on");
  }
  if (s.task_state != "on") throw HalError("the machine is off: switch it on");
  std::vector<std::string> not_homed;
  for (std::size_t j = 0; j < s.homed.size(); ++j) {
    if (!s.homed[j]) not_homed.push_back(std::to_string(j));
  }
  if (!not_homed.empty()) {
    throw HalError("the machine is not homed (joint " + join(not_homed, ", ") +
                   "): home it first; soft limits mean nothing before");
  }
  if (s.interp_state != "idle") {
    throw HalError("a program is running (" + s.interp_state + "): wait for it or stop it");
  }
  if (s.feed_override < 0.9995 || s.feed_override > 1.0005) {
    throw HalError(
        fmt::format("feed override at {:.0f} %: set it to 100 % (the test runs at "
                    "the feeds it states)",
                    s.feed_override * 100));
  }
}

void require_circlog(std::size_t channels) {
  int code = 0;
  const std::string out = program_output({"halcmd", "-s", "getp", "circlog.0.channels"}, code);
  if (code != 0) {
    throw HalError(
        "circlog is not loaded in the running LinuxCNC: circtest install, then "
        "restart LinuxCNC");
  }
  const std::string n(trim(out));
  if (n != std::to_string(channels)) {
    throw HalError(
        fmt::format("circlog has {} channels, the INI's [CIRCTEST] COLUMNS {}: "
                    "restart LinuxCNC after install",
                    n, channels));
  }
  const std::string threads = program_output({"halcmd", "-s", "show", "thread"}, code);
  if (code != 0 || threads.find("circlog.0") == std::string::npos) {
    throw HalError("circlog.0 is in no thread: nothing feeds it (addf circlog.0 servo-thread)");
  }
}

}  // namespace circtest::session

namespace circtest::session {

bool clear_markers(int marker_output, int segment_output) {
  int code = 0;
  const std::string enable = program_output({"halcmd", "-s", "getp", "circlog.0.enable"}, code);
  if (code != 0 || trim(enable) != "TRUE") return false;
  if (run_program({tool_path("circtest-linuxcnc"), "markers-off", std::to_string(marker_output),
                   std::to_string(segment_output)}) != 0) {
    throw HalError(
        "the marker output is on (left by an aborted program) and could not be "
        "switched off: M65 P" +
        std::to_string(marker_output) + " by MDI");
  }
  return true;
}

}  // namespace circtest::session
