#pragma once
// The planner's steps and the one context they work on (not installed). A plan is built by
// running steps over a PlanContext: the configuration's texts (the INI document and the other
// files as the plan changes them), the diagnosis, the settings and the plan being built.
// Every step has one signature, void(PlanContext&); make_plan.cpp runs them in order.
#include <array>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "circtest/compensation/config_dir.hpp"
#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"

namespace circtest::compensation {

// The files a plan writes besides the INI's own: path -> (existed, content after).
using PlanFiles = std::map<std::string, std::pair<bool, std::string>>;

// One plane's squareness correction: its plane ("XY"), axes and angle (urad, gain applied).
struct SquarenessChange {
  std::string plane;
  std::array<char, 2> axes;
  double alpha_urad = 0.0;
};

struct PlanContext {
  PlanContext(const std::string& ini_path, const DiagnosisInput& diagnosis,
              const PlanOptions& options);
  // A context for trying a step: the same configuration texts (copies), diagnosis and
  // settings, and an empty plan; merge() takes what it planned.
  PlanContext trial() const;
  // Takes TRIED's configuration texts and adds its plan's lines and files to this plan.
  void merge(PlanContext&& tried);

  // The plane's diagnosis, and the JSON file it was read from (for messages).
  const DiagnosisInput& input() const { return *diagnosis; }
  const Diagnosis& d() const { return diagnosis->diagnosis; }
  const std::string& source() const { return diagnosis->source; }
  bool wants(Correction c) const { return o.only.count(c) > 0; }

  std::string ini_path;
  const DiagnosisInput* diagnosis;  // a test set's steps run once per plane
  const PlanOptions& o;
  IniDocument ini;  // the INI and its includes as the plan changes them
  ConfigDir config;
  double upm = 1.0;  // machine units per mm
  std::string dir;   // the INI's folder, "" for the current one
  Plan plan;
  PlanFiles files;
  // What earlier steps found, for later ones.
  std::vector<SquarenessChange> squareness;  // accepted, written by write_squareness_step
  bool servo_answered = false;               // the servo step planned or explained the gains
  std::size_t changes_before_servo = 0;
  bool friction_answered = false;  // the friction step planned it or said why not

 private:
  PlanContext(const PlanContext&) = default;
};

using PlanStep = void (*)(PlanContext&);

// The steps, in the order make_plan runs them.
void axes_step(PlanContext& c);               // backlash, scale, cyclic (BACKLASH or a table)
void accept_squareness_step(PlanContext& c);  // the plane's squareness, when it passes
void write_squareness_step(PlanContext& c);   // every accepted one into circtest_kins
void servo_step(PlanContext& c);              // FF1 and P (servo.cpp)
void servo_advice_step(PlanContext& c);       // the mismatch advice when servo did not answer
void friction_step(PlanContext& c);           // circfric (friction.cpp)
void spike_advice_step(PlanContext& c);       // the spikes' advice when friction was not planned
void collect_files_step(PlanContext& c);      // every changed file into plan.files

// A value of the diagnosis itself refused by a step (a servo lag no loop can have): told by
// its type from what the configuration cannot take, which only skips the step when the step
// was not asked for by name. A data error (exit 5) naming the diagnosis.
class MeasurementError : public DataError {
 public:
  using DataError::DataError;
};

// servo.cpp: FF1 (and P where FF1 alone cannot match) per pid joint of the diagnosis's axes;
// false when the diagnosis has no usable per-axis lag for a pid joint. Throws
// MeasurementError for a lag no servo loop has, DataError naming the HAL or INI file and line
// where a gain cannot be read or written, or the new lag breaks FERROR.
bool plan_servo(PlanContext& c);
// friction.cpp: [FRICTION_<axis>] and circtest-fric.hal. Throws WiringError (friction.hpp)
// where circfric cannot be wired, DataError naming the diagnosis for a spike it refuses.
void plan_friction(PlanContext& c);

namespace detail {

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
// The name inside CONFIG of a file the plan changes (UnsafePathError outside, a link, not a
// regular file).
std::string target_name(const ConfigDir& config, const std::string& path);
// The text of a file the plan changes (checked inside CONFIG first), "" when absent.
std::string read_target(const ConfigDir& config, const std::string& path, bool& existed);
// The INI's own text, for its SHA-256.
std::string ini_text(const std::string& ini_path);
// One measured value checked against its plausibility bounds; returned when it is to be
// applied, else nullopt with a note (below MIN_ABS, null) or DataError (above MAX_ABS, or
// a standard error above the value) unless the force setting.
// A length (UNIT "mm") is said in the machine's units too: "0.0118 in (0.3 mm)" on an inch
// machine (UNITS_PER_MM 1/25.4); other units as they are.
std::optional<double> accepted(const Measured& m, const std::string& what, double min_abs,
                               double max_abs, const char* unit, const PlanOptions& o,
                               std::vector<std::string>& notes, double units_per_mm = 1.0);
// V in UNIT as the user reads it: a length in mm also in the machine's units when they are
// not mm (see accepted).
std::string quantity_text(double v, const char* unit, double units_per_mm);

}  // namespace detail

}  // namespace circtest::compensation
