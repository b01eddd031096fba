#pragma once
// circcomp's friction compensation: circfric(9) parameters from the reversal spikes of a
// diagnosis, wired by a HAL file of its own (circtest-fric.hal, the last [HAL] HALFILE) that
// splices circfric between motion's position command and the pid or stepgen reading it. The
// values live in the INI ([FRICTION_<axis>] AMPLITUDE, AMPLITUDE_MAX, DECAY_MS, SPIKE_MM), so
// a refinement changes only INI values.
#include <cstddef>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "circtest/compensation/config_dir.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"

namespace circtest::compensation {

inline constexpr const char* kFrictionHalFile = "circtest-fric.hal";
// A spike below this is not compensated: smaller ones are within what a circle resolves of a
// transient, and a pulse tuned to them would mostly add noise.
inline constexpr double kMinFrictionSpikeMm = 0.002;
// A measured spike above this is implausible for friction (refused without the force setting).
inline constexpr double kMaxFrictionSpikeMm = 0.1;
// Step 2 runs when the residual spike exceeds this share of the first measured one.
inline constexpr double kFrictionRefineShare = 0.3;
// circfric's plain pulse starts at the reversal. Through a loop that lags (FF1 0: 1/Kv, about
// 33 ms) it reaches the table when the table sticks; a loop that follows within a few ms (FF1
// about 1, a stepgen) passes it before the stick, which on the simulated servo machine peaks
// 60 ms after the reversal: there the plain pulse left 98 % of X's spike and raised G
// (12.6 -> 15.3 um). Below this measured lag (ms) an axis whose spike peaks after the
// reversal gets circfric's rising pulse (RISE_MS), and one whose spike peaks at the reversal
// no pulse (a note says so).
inline constexpr double kFrictionMinLagMs = 5.0;
// The rising pulse peaks at this share of the time from the reversal to the spike's peak: it
// must push the stuck drive before the spike has grown. On the drive model of sim-servo
// (FF1 1, D100..D300, F500..F3000, X and Y friction) 0.4 left 16..29 % of the spike with the
// amplitude at the spike's height; 0.3 and 0.25 left up to 47 % and 64 % at the higher feeds.
inline constexpr double kFrictionRisePeakShare = 0.4;

// The configuration's HAL cannot take circfric where circcomp splices it (no pid or stepgen
// reads the joint's position command, two do, no motion-controller in a thread, circfric
// loaded already, a signal of circcomp's wiring taken, circtest-fric.hal not circcomp's): a
// data error (exit 5) naming the HAL file and line. plan() tells it from the measurement's
// refusals by its type: when friction was not asked for by name, a configuration it cannot
// wire keeps every other correction.
class WiringError : public DataError {
 public:
  using DataError::DataError;
};

// Where a HAL command stands.
struct HalPlace {
  std::string file;
  std::size_t line = 0;
  bool ini_halcmd = false;  // a [HAL] HALCMD entry of the INI (FILE:LINE is the INI's line)
};

// What circcomp needs to know of a configuration's HAL files (the .hal ones, read in load
// order with [SECTION]KEY words replaced from the INI): the signals and their pins, the pins
// set by setp, and each thread's functions in order after every addf and delf.
struct HalWiring {
  struct Signal {
    std::set<std::string> pins;
    HalPlace place;  // the first net or link naming it
  };
  std::map<std::string, Signal> signals;
  std::map<std::string, std::string> pin_signal;  // pin -> signal
  std::map<std::string, HalPlace> setp;  // pin -> the last setp (or "PIN = VALUE") naming it
  std::map<std::string, HalPlace> sets;  // signal -> the last sets naming it
  std::map<std::string, std::vector<std::string>> threads;  // thread -> functions
  std::map<std::string, HalPlace> addf;                     // function -> its addf
  std::vector<std::string> pid_instances;                   // from loadrt pid
  std::optional<HalPlace> loads_circfric;                   // a loadrt circfric of its own
  std::vector<std::string> read;                            // the files read
  std::vector<std::string> unread;                          // HALFILEs not read (.tcl, LIB:)
};

// Reads the configuration's HAL files ([HAL] HALFILE) as halcmd would run them, skipping SKIP
// (circcomp's own file); with AND_LATER also what LinuxCNC runs after them: the [HAL] HALCMD
// entries, then [HAL] POSTGUI_HALFILE. Throws ParseError (file, line) for a command with too
// few words.
HalWiring read_hal_wiring(const IniDocument& ini, const std::string& skip, bool and_later = false);
HalWiring parse_hal_text(const std::string& text, const std::string& file, const IniDocument& ini,
                         HalWiring wiring = {});

}  // namespace circtest::compensation
