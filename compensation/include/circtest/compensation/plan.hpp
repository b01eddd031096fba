#pragma once
// circcomp: a diagnosis written back into a LinuxCNC 2.9 configuration as incremental
// corrections (new = current + gain * measured residual), planned as whole-file contents,
// applied atomically with the originals kept, reverted byte-identical.
#include <cstddef>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/core/setting_words.hpp"

namespace circtest::compensation {

// A setting a refusal asks the user to give. The library names it in plain words; a front end
// words it as its own (circcomp: its options, in compensation/app/main.cpp), so library text
// names no command-line option.
enum class PlanSetting {
  force,               // apply what is implausible, uncertain or of a changed INI
  gain,                // the share of the residual to apply
  record_with_ini,     // how to record a trace whose diagnosis carries the INI's SHA-256
  without_squareness,  // the corrections without squareness (no circtest_kins needed)
  without_friction,    // the corrections without friction compensation (no circfric wiring)
};
using PlanSettingWords = SettingWords<PlanSetting>;
// The library's words: "the force setting", "the gain setting", ...
std::string_view library_setting_words(PlanSetting setting) noexcept;

// The corrections circcomp plans; each is a step of the planner (compensation/src/plan/).
enum class Correction { backlash, scale, squareness, cyclic, friction, servo };
// "backlash", "scale", ...: the correction's name in messages and in a front end's words.
std::string_view correction_name(Correction c) noexcept;
std::optional<Correction> correction_named(std::string_view name) noexcept;
std::vector<Correction> all_corrections();  // in the order above

struct PlanOptions {
  std::set<Correction> only{Correction::backlash, Correction::scale,    Correction::squareness,
                            Correction::cyclic,   Correction::friction, Correction::servo};
  // Friction asked for by name: a configuration circfric cannot be wired into is then refused;
  // when it is only part of the default set, that is a note and the other corrections go on.
  bool friction_requested = false;
  // The same for the servo gains (FF1, P): asked for by name, a HAL whose gains circcomp cannot
  // read or write is refused; else that is a note.
  bool servo_requested = false;
  double gain = 1.0;   // share of the measured residual to apply, (0, 1]
  bool force = false;  // apply implausible or uncertain corrections, or to a changed INI
  PlanSettingWords setting_words = library_setting_words;  // for the refusals' text
};

struct FileChange {
  std::string path;  // as the INI names it (relative to the current folder), for messages
  std::string name;  // relative to the configuration directory (ConfigDir), for the writes
  bool existed = false;
  std::string before;  // empty when !existed
  std::string after;
};

// A value circcomp writes into a HAL command as written (the literal of a setp, a "PIN =
// VALUE" or a sets), not into an INI key: a change of the plan JSON of its own.
struct HalValueChange {
  std::string file;  // the HAL file, as the INI names it
  std::size_t line = 0;
  std::string command;  // the command's words before the value: "setp pid.x.FF1", "sets x-ff1"
  std::string key;      // the gain: FF1, Pgain
  char axis = 0;
  std::string before, after;
};

struct Plan {
  std::string ini_path;
  std::vector<FileChange> files;           // only files whose content changes
  std::vector<std::string> changes;        // one line per correction, for the summary
  std::vector<std::string> advice;         // what circcomp cannot write (servo gains, friction)
  std::vector<std::string> notes;          // what was skipped and why
  std::vector<HalValueChange> hal_values;  // the values written into HAL lines
  bool provenance_checked = false;         // the diagnosis's ini_sha256 matched the INI
  std::string ini_sha256;                  // the INI's SHA-256 as the plan read it
  bool needs_kins_module = false;          // the plan loads the circtest_kins kinematics
  bool needs_fric_module = false;          // the plan loads circfric (friction compensation)
};

// Reads the INI (with its #INCLUDEd files and COMP_FILEs) and builds the plan. Throws
// DataError (exit 5) for an implausible or uncertain correction without options.force, or a
// kinematics whose axes cannot be mapped to joints; UnsafePathError (exit 12) when a file the
// plan changes lies outside the INI's directory, is a symbolic link or not a regular file;
// StaleError (exit 10) when the INI is not the one measured (checked by apply, not by plan:
// see require_fresh).
Plan make_plan(const std::string& ini_path, const DiagnosisInput& diagnosis,
               const PlanOptions& options);
// A test set (read_diagnosis_planes): every plane's corrections in one plan, each axis once
// (from the first plane that has it), the squareness of every plane into circtest_kins.
// Friction is not planned from a set (a note says so; UsageError when it is the only
// correction asked for).
Plan make_plan(const std::string& ini_path, const std::vector<DiagnosisInput>& planes,
               const PlanOptions& options);
// The options' own ranges (the gain: 0 < F <= 1), before any file is read: UsageError.
void check_plan_options(const PlanOptions& options);
// Throws StaleError unless the diagnosis's ini_sha256 is the INI's SHA-256 now (or force).
void require_fresh(const std::string& ini_path, const DiagnosisInput& diagnosis, bool force,
                   PlanSettingWords words = library_setting_words);

// "--- a/FILE\n+++ b/FILE\n@@ ..." for every file of the plan (new files against /dev/null).
std::string unified_diff(const Plan& plan);

// Where LinuxCNC's loadrt finds realtime modules: RTLIB_DIR of /etc/linuxcnc/rtapi.conf, else
// /usr/lib/linuxcnc/modules.
std::string linuxcnc_module_dir();
// The realtime modules a run of the configuration loads: circtest_kins.so (squareness) from
// $CIRCTEST_KINS_MODULE when set (circtest-run loads that file, e.g. the build tree's, beside
// the system modules), circfric.so (friction) from $CIRCTEST_FRIC_MODULE, else each in
// linuxcnc_module_dir(). Throws HalError (exit 7) with the fix spelled out when the plan needs
// a module and that file is not there.
void require_kins_module(const Plan& plan, PlanSettingWords words = library_setting_words);

// Writes the originals and a manifest (manifest.hpp) into <ini dir>/.circcomp/, then every
// file atomically. Every file is checked first (ConfigDir: inside the directory, no link, a
// regular file or absent): a refusal touches nothing. One apply or revert of a configuration
// at a time: each holds .circcomp/lock (flock) while it works; another one meanwhile is
// refused with StaleError (exit 10), and so is a plan whose INI (its SHA-256) or files are no
// longer what it read, checked under the lock (two applies of one diagnosis: one wins).
// AFTER_STEP, when given, is called after every step (a temporary written but not yet renamed
// into place, then the rename) with the step's number from 0 and a description: the crash
// test kills the process there (circcomp-crash-test, tests/compensation).
using StepHook = std::function<void(std::size_t step, const std::string& what)>;
// One apply or revert of a configuration at a time: an exclusive flock on
// <ini dir>/.circcomp/lock, held from construction to destruction (which removes the file, and
// the state folder when nothing else is in it). Another process holding it: StaleError (exit
// 10), nothing changed. Within one process it nests: apply_plan and revert take one, and
// share the hold of an outer one.
class ConfigLock {
 public:
  explicit ConfigLock(const std::string& ini_path);
  ~ConfigLock();
  ConfigLock(const ConfigLock&) = delete;
  ConfigLock& operator=(const ConfigLock&) = delete;

 private:
  std::string root_, path_;
  int fd_ = -1;
};
void apply_plan(const Plan& plan, const StepHook& after_step = {});
struct RevertOptions {
  bool as_found = false;  // back to the state before the first apply, not only the last one
  bool force = false;     // overwrite or remove files changed since circcomp wrote them
};
struct RevertResult {
  bool reverted = false;      // false: nothing to revert
  bool earlier_kept = false;  // earlier applies remain (revert with as_found undoes them)
};
// Restores the state before the last apply (or, with as_found, before the first one)
// byte-identical, created files removed. Every file is checked before any is touched: a file
// that is not what circcomp wrote (edited since) is refused with StaleError (exit 10) unless
// FORCE; a link, FIFO or folder where a file was written, or a manifest naming anything
// outside the directory, with UnsafePathError (exit 12). AFTER_STEP as for apply_plan, after
// each file and after the manifest's removal or rewrite: a revert killed anywhere is finished
// by the next one.
RevertResult revert(const std::string& ini_path, const RevertOptions& options,
                    const StepHook& after_step = {});
// revert() of the last apply; false when there is nothing to revert.
bool revert(const std::string& ini_path, const StepHook& after_step = {});

}  // namespace circtest::compensation
