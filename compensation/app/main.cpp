// circcomp: writes a circtest diagnosis back into a LinuxCNC configuration. Only option
// parsing lives here; the work is circtest::compensation.
#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>
#include <boost/program_options.hpp>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>

#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/compensation/plan_json.hpp"
#include "circtest/core/cli.hpp"
#include "circtest/core/cli_options.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/version.hpp"

namespace po = boost::program_options;
using namespace circtest;
using namespace circtest::compensation;

namespace {

constexpr const char* kPlanUsage =
    "usage: circcomp plan   --ini MACHINE.ini DIAGNOSIS.json [--only "
    "backlash,scale,squareness,cyclic,friction,servo]\n"
    "                       [--gain F] [--force] [--json]\n";
constexpr const char* kApplyUsage =
    "usage: circcomp apply  --ini MACHINE.ini DIAGNOSIS.json [--only "
    "backlash,scale,squareness,cyclic,friction,servo]\n"
    "                       [--gain F] [--force]\n";
constexpr const char* kRevertUsage =
    "usage: circcomp revert --ini MACHINE.ini [--to last|as-found] [--force]\n";
constexpr const char* kUsage =
    "usage: circcomp plan   --ini MACHINE.ini DIAGNOSIS.json [--only "
    "backlash,scale,squareness,cyclic,friction,servo]\n"
    "                       [--gain F] [--force] [--json]\n"
    "       circcomp apply  --ini MACHINE.ini DIAGNOSIS.json [the same options but --json]\n"
    "       circcomp revert --ini MACHINE.ini [--to last|as-found] [--force]\n";

// circcomp's words for what the library asks the user to give: its options (the library's
// text names none).
std::string_view circcomp_option_words(PlanSetting setting) noexcept {
  switch (setting) {
    case PlanSetting::force:
      return "--force";
    case PlanSetting::gain:
      return "--gain";
    case PlanSetting::record_with_ini:
      return "with circtest-run or circlog-record --ini";
    case PlanSetting::without_squareness:
      return "leave squareness out (--only backlash,scale,cyclic,friction,servo)";
    case PlanSetting::without_friction:
      return "leave friction out (--only backlash,scale,squareness,cyclic,servo)";
  }
  return library_setting_words(setting);
}

void print_summary(const Plan& plan, std::ostream& out) {
  for (const auto& c : plan.changes) out << "# change: " << c << "\n";
  for (const auto& n : plan.notes) out << "# note: " << n << "\n";
  for (const auto& a : plan.advice) out << "# advice: " << a << "\n";
}

// Writes what is in standard output's buffer; false when it cannot (a full disk, /dev/full, a
// closed pipe), with errno's reason in REASON.
bool flush_stdout(std::string& reason) {
  errno = 0;
  std::cout.flush();
  const bool ok = std::cout.good() && std::fflush(stdout) == 0 && std::ferror(stdout) == 0;
  if (!ok) reason = errno != 0 ? std::strerror(errno) : "write failed";
  return ok;
}

// Before a change is committed: what it will do is on standard output, or nothing happens.
void report_before_commit(const std::string& what) {
  std::string reason;
  if (!flush_stdout(reason)) {
    throw IoError("standard output",
                  fmt::format("write failed ({}): {} not started, nothing changed", reason, what));
  }
}

// After a change is committed: a standard output that fails now is no failure of the change.
// Exit 13 (unreported) and stderr say that the change IS made and how to undo it.
int report_after_commit(const std::string& done, const std::string& undo) {
  std::string reason;
  if (flush_stdout(reason)) return 0;
  throw Error(ExitCode::unreported,
              fmt::format("standard output: write failed ({}) after the {}: the change IS made; {}",
                          reason, done, undo));
}

#ifdef CIRCCOMP_CRASH_TEST
// Only in the crash test's own build of this file (tests/compensation: circcomp-crash-test,
// never installed): SIGKILL itself after step K of apply or revert, as a power cut or an OOM
// kill would stop it, so the test sees what such a stop leaves.
StepHook after_step_hook() {
  if (const char* f = std::getenv("CIRCCOMP_FULL_STDOUT_AFTER_STEP")) {
    // Standard output becomes /dev/full after step K: a disk filling during the commit.
    const auto full_step =
        static_cast<std::size_t>(parse_option_index("CIRCCOMP_FULL_STDOUT_AFTER_STEP", f));
    return [full_step](std::size_t step, const std::string&) {
      if (step != full_step) return;
      const int fd = ::open("/dev/full", O_WRONLY);
      if (fd >= 0) ::dup2(fd, STDOUT_FILENO);
    };
  }
  const char* k = std::getenv("CIRCCOMP_KILL_AFTER_STEP");
  if (k == nullptr) return {};
  const auto kill_step =
      static_cast<std::size_t>(parse_option_index("CIRCCOMP_KILL_AFTER_STEP", k));
  return [kill_step](std::size_t step, const std::string& what) {
    if (step != kill_step) return;
    std::cerr << "circcomp: killed after step " << step << " (" << what << ")" << std::endl;
    ::raise(SIGKILL);
  };
}
#else
StepHook after_step_hook() {
  return {};
}
#endif

// The plan; for an apply (CHECKED) also refused as stale when the INI it read is not the one
// measured: another apply committed between the freshness check and the plan (apply_plan
// checks the INI against the plan again under the configuration's lock). A plan that fails
// while the INI is changing under it is refused as stale, not as what the torn read showed.
Plan plan_for(const std::string& ini, const std::vector<DiagnosisInput>& planes,
              const PlanOptions& options, bool checked) {
  const auto changed = [&] {
    return fmt::format(
        "{} changed while circcomp planned (another circcomp apply?): nothing "
        "changed; measure again, or plan again",
        ini);
  };
  try {
    Plan plan = make_plan(ini, planes, options);
    if (checked && !plan.provenance_checked) throw StaleError(changed());
    return plan;
  } catch (const StaleError&) {
    throw;
  } catch (const Error&) {
    if (!checked) throw;
    try {
      require_fresh(ini, planes.front(), false);
    } catch (const StaleError&) {
      throw StaleError(changed());
    }
    throw;
  }
}

int run_revert(const std::string& ini, const std::string& diagnosis, const std::string& to,
               bool force) {
  if (!diagnosis.empty()) throw UsageError("revert takes no diagnosis");
  if (!to.empty() && to != "last" && to != "as-found") {
    throw UsageError("--to: expected last or as-found, got '" + to + "'");
  }
  RevertOptions options;
  options.as_found = to == "as-found";
  options.force = force;
  std::cout << "circcomp: reverting " << ini << "\n";
  report_before_commit("the revert");
  const RevertResult r = revert(ini, options, after_step_hook());
  if (r.reverted) {
    std::cout << "circcomp: reverted " + ini +
                     (options.as_found ? " to the configuration as found before the first apply\n"
                                       : " to the state before the last apply\n");
  } else {
    std::cout << "circcomp: nothing to revert for " + ini + "\n";
  }
  if (r.earlier_kept) {
    std::cout << "circcomp: earlier applies remain; circcomp revert --to as-found --ini " << ini
              << " goes back to the configuration as it was before the first\n";
  }
  return r.reverted ? report_after_commit("revert",
                                          "circcomp apply of the same diagnosis "
                                          "makes it again")
                    : 0;
}

int run(int argc, char** argv) {
  if (argc < 2) throw UsageError(std::string("expected plan, apply or revert\n") + kUsage);
  const std::string command = argv[1];
  if (command == "--help" || command == "-h") {
    std::cout << kUsage;
    return 0;
  }
  if (command == "--version") {
    std::cout << version_line("circcomp") << "\n";
    return 0;
  }
  if (command != "plan" && command != "apply" && command != "revert") {
    throw UsageError("unknown command '" + command + "' (expected plan, apply or revert)");
  }
  std::string ini, diagnosis, only, gain_text = "1", to;
  bool force = false, json = false;
  po::options_description opts;
  opts.add_options()("ini", po::value(&ini))("diagnosis", po::value(&diagnosis))(
      "only", po::value(&only))("gain", po::value(&gain_text))("force", po::bool_switch(&force))(
      "json", po::bool_switch(&json))("to", po::value(&to))("help,h", "");
  po::positional_options_description pos;
  pos.add("diagnosis", 1);
  po::variables_map vm;
  try {
    refuse_option_placeholders(argc, argv);
    po::store(po::command_line_parser(argc - 1, argv + 1).options(opts).positional(pos).run(), vm);
    po::notify(vm);
  } catch (const po::error& e) {
    throw option_usage_error(e, opts);
  }
  if (vm.count("help")) {
    std::cout << (command == "plan" ? kPlanUsage : command == "apply" ? kApplyUsage : kRevertUsage);
    return 0;
  }
  if (ini.empty()) throw UsageError("--ini: expected the machine's LinuxCNC INI file");
  if (json && command != "plan") throw UsageError("--json: only for circcomp plan");
  if (command == "revert") {
    for (const char* option : {"only", "gain"}) {
      if (vm.count(option)) throw UsageError(fmt::format("--{}: only for plan and apply", option));
    }
    return run_revert(ini, diagnosis, to, force);
  }
  if (!to.empty()) throw UsageError("--to: only for revert");
  if (diagnosis.empty()) throw UsageError("expected DIAGNOSIS.json (circana diagnose --json)");
  PlanOptions options;
  options.force = force;
  options.setting_words = circcomp_option_words;
  options.gain = parse_option_number("--gain", gain_text);
  if (!only.empty()) {
    options.only.clear();
    std::istringstream in(only);
    for (std::string w; std::getline(in, w, ',');) {
      const std::optional<Correction> c = correction_named(w);
      if (!c) {
        std::string names;
        const std::vector<Correction> all = all_corrections();
        for (std::size_t i = 0; i < all.size(); ++i) {
          names += std::string(i == 0                ? ""
                               : i + 1 == all.size() ? " or "
                                                     : ", ") +
                   std::string(correction_name(all[i]));
        }
        throw UsageError(fmt::format("--only: expected {}, got '{}'", names, w));
      }
      options.only.insert(*c);
      if (*c == Correction::friction) options.friction_requested = true;
      if (*c == Correction::servo) options.servo_requested = true;
    }
  }
  // A named FIFO without a writer would block the read: a pipe is given as - (or <(...)).
  struct stat st {};
  if (::lstat(diagnosis.c_str(), &st) == 0 && S_ISFIFO(st.st_mode)) {
    throw IoError(diagnosis,
                  "is a FIFO: expected the diagnosis JSON as a regular file (a pipe "
                  "as -)");
  }
  // One plane's diagnosis, or a test set's (one entry per plane).
  const std::vector<DiagnosisInput> planes = read_diagnosis_planes(diagnosis);
  if (command == "apply") require_fresh(ini, planes.front(), force, circcomp_option_words);
  const Plan plan = plan_for(ini, planes, options, command == "apply" && !force);
  if (command == "plan" && json) {
    // The changes as data (circtest.plan/1) for circana report --changes.
    std::cout << json_text(plan_json(plan), 2) << "\n";
    return 0;
  }
  if (command == "plan") {
    std::cout << unified_diff(plan);
    print_summary(plan, std::cout);
    try {
      require_kins_module(plan, circcomp_option_words);
    } catch (const HalError& e) {
      std::cout << "# note: apply will refuse (exit 7): " << e.what() << "\n";
    }
    if (!plan.provenance_checked) {
      std::cout << "# note: the diagnosis's ini_sha256 does not match " << ini
                << " now: apply will refuse (exit 10) without --force\n";
    }
    return 0;
  }
  if (plan.files.empty()) {
    print_summary(plan, std::cout);
    std::cout << "circcomp: nothing to change in " << ini << "\n";
    return 0;
  }
  require_kins_module(plan, circcomp_option_words);
  // What the apply does is on standard output before it starts; the line after it says it
  // is done (exit 13 when only that line cannot be written: the change is made).
  print_summary(plan, std::cout);
  for (const auto& f : plan.files) {
    std::cout << "circcomp: " << (f.existed ? "changing " : "creating ") << f.path << "\n";
  }
  report_before_commit("the apply");
  apply_plan(plan, after_step_hook());
  std::cout << "circcomp: applied; originals kept; undo with: circcomp revert --ini " << ini
            << "\n";
  return report_after_commit("apply", "undo it with: circcomp revert --ini " + ini);
}

}  // namespace

int main(int argc, char** argv) {
  return run_cli("circcomp", [&] { return run(argc, argv); });
}
