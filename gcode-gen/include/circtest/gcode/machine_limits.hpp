#pragma once
// The machine limits circgen checks a test against, read from a LinuxCNC 2.9 INI file.
#include <array>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/gcode/generator.hpp"
#include "circtest/gcode/parameter_file.hpp"

namespace circtest {

class IniDocument;

struct AxisLimits {
  char axis = 'x';
  bool present =
      false;  // in [TRAJ] COORDINATES (or kinematics coordinates=), or an [AXIS_<L>] section
  std::optional<double> min_limit_mm;
  std::optional<double> max_limit_mm;
  std::optional<double> max_velocity_mm_per_s;
  std::optional<double> max_acceleration_mm_per_s2;
};

// The motion module's synchronized output counts, from the HAL file line that loads it.
struct MotionOutputs {
  int num_dio = 4;  // motmod's default in LinuxCNC 2.9
  int num_aio = 4;
  std::string where;  // "file:line" of the loadrt, for messages
};

struct MachineLimits {
  std::string source;                                       // the INI file, for messages
  double mm_per_machine_unit = 1.0;                         // from [TRAJ] LINEAR_UNITS
  std::array<AxisLimits, 3> axes{};                         // x, y, z
  std::optional<double> max_linear_velocity_mm_per_s;       // [TRAJ] MAX_LINEAR_VELOCITY
  std::optional<double> max_linear_acceleration_mm_per_s2;  // [TRAJ] MAX_LINEAR_ACCELERATION
  std::vector<std::string> hal_files;           // every [HAL] HALFILE, in order, as written
  std::map<std::string, std::string> values;    // "SECTION/KEY" -> first value, for HAL [S]K
  std::optional<MotionOutputs> motion_outputs;  // when a HAL file loads the motion module
  // [RS274NGC] PARAMETER_FILE beside the INI (LinuxCNC runs in the INI's folder), else
  // LinuxCNC's default rs274ngc.var there; empty for an INI parsed from text.
  std::string parameter_file;
  // [RS274NGC] DISABLE_G92_PERSISTENCE as LinuxCNC 2.9 reads it: 1 clears G92 at start-up,
  // 0 or no key keeps it; any other value is refused (ParseError): LinuxCNC 2.9 ignores it,
  // later versions read yes/true/on as 1.
  G92Persistence g92_persistence = G92Persistence::kept;
};

// Reads the keys circgen needs as LinuxCNC 2.9 reads them (core IniDocument: #INCLUDE,
// continuation lines, first occurrence wins). Throws IoError (also for an INI or HAL file that
// is not a regular file: a FIFO would never end), or ParseError naming file:line
// for a limit that is no number or a LINEAR_UNITS LinuxCNC would not accept.
MachineLimits read_machine_limits(const std::string& path);
MachineLimits machine_limits_from(const IniDocument& ini);
MachineLimits parse_machine_limits(const std::string& text, const std::string& source);

// The motion module's loadrt line in one HAL file: `loadrt [EMCMOT]EMCMOT ...` or `loadrt
// motmod ...`, with num_dio=/num_aio= (literal or [SECTION]KEY from the INI; missing: 4).
// Handles comments and backslash continuations. nullopt when the file does not load it;
// ParseError (file:line) for a count that is not a whole number.
std::optional<MotionOutputs> find_motion_outputs(const std::string& hal_text,
                                                 const std::string& source,
                                                 const MachineLimits& ini);

// Throws LimitError naming the INI limit the test would violate: a position outside
// MIN_LIMIT/MAX_LIMIT (work offset origin added), a feed above MAX_VELOCITY, a centripetal
// acceleration V^2/R that LinuxCNC's planner would not allow on the arc, or a lead-in too
// short to reach the feed. Throws ParseError (line 0) when an axis of the test has no section.
// Returns the names of the checks made, for the header. The settings a refusal names are
// worded by `words` (circgen: its options).
std::vector<std::string> check_against_machine(const CircleTestSpec& spec,
                                               const MachineLimits& limits,
                                               const std::array<double, 3>& work_offset_mm,
                                               SpecWords words = library_spec_words);

}  // namespace circtest
