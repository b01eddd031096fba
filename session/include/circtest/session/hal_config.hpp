#pragma once
// The HAL wiring of a LinuxCNC configuration as its [HAL] HALFILEs write it, read as text:
// which pins each signal joins (`net`, `linksp`, `linkps`), which modules are loaded and which
// functions each thread runs. Enough to find a joint's command and feedback signals without
// starting HAL; halcmd stays the judge of what actually loads.
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "circtest/core/ini.hpp"

namespace circtest::session {

// Where a HAL line is, for messages: "machine.hal:12".
struct HalPlace {
  std::string file;
  std::size_t line = 0;
  std::string text() const { return file + ":" + std::to_string(line); }
};

struct HalPinOnSignal {
  std::string pin;
  bool writer = false;  // before "=>" or after "<=": the pin that drives the signal
  HalPlace place;
};

struct HalWiring {
  // signal -> its pins, in file order
  std::map<std::string, std::vector<HalPinOnSignal>> signals;
  // pin -> its signal
  std::map<std::string, std::string> signal_of_pin;
  // module name -> where it is loaded (the first loadrt)
  std::map<std::string, HalPlace> loaded;
  // module name -> the words after its name on that loadrt line ("num_dio=4", ...)
  std::map<std::string, std::vector<std::string>> load_args;
  // function -> its thread (addf)
  std::map<std::string, std::string> thread_of_function;
  // the HALFILE names read, in order, and those that could not be read as HAL text (a .tcl
  // file, a file of LinuxCNC's library outside the configuration folder)
  std::vector<std::string> files_read;
  std::vector<std::string> files_not_read;
  // the writer of SIGNAL, or the first pin that is not a joint or pid input when no line
  // gives a direction; nullopt for an unknown signal
  std::optional<std::string> source_of(const std::string& signal) const;
};

// [SECTION]KEY in a HAL line replaced by the INI's value, as `halcmd -i INI` does; a reference
// to a key the INI does not have stays as it is.
std::string substitute_ini_values(const std::string& line, const IniDocument& ini);

// Parses one HAL file's TEXT (named SOURCE in messages) into WIRING.
void read_hal_text(const std::string& text, const std::string& source, const IniDocument& ini,
                   HalWiring& wiring);

// Every [HAL] HALFILE of the INI (relative to the INI's folder), in order.
HalWiring read_hal_wiring(const IniDocument& ini, const std::string& config_dir);

}  // namespace circtest::session
