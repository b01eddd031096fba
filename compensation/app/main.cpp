// circcomp: writes a circtest diagnosis back into a LinuxCNC configuration. Only option
// parsing lives here; the work is circtest::compensation.
#include <boost/program_options.hpp>
#include <csignal>
#include <cstdlib>
#include <iostream>
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

constexpr const char* kUsage =
    "usage: circcomp plan   --ini MACHINE.ini DIAGNOSIS.json [--only "
    "backlash,scale,squareness,cyclic,friction,servo]\n"
    "                       [--gain F] [--force] [--json]\n"
    "       circcomp apply  --ini MACHINE.ini DIAGNOSIS.json [the same options]\n"
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

#ifdef CIRCCOMP_CRASH_TEST
// Only in the crash test's own build of this file (tests/compensation: circcomp-crash-test,
// never installed): SIGKILL itself after step K of apply or revert, as a power cut or an OOM
// kill would stop it, so the test sees what such a stop leaves.
StepHook after_step_hook() {
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

int run_revert(const std::string& ini, const std::string& diagnosis, const std::string& to,
               bool force) {
  if (!diagnosis.empty()) throw UsageError("revert takes no diagnosis");
  if (!to.empty() && to != "last" && to != "as-found") {
    throw UsageError("--to: expected last or as-found, got '" + to + "'");
  }
  RevertOptions options;
  options.as_found = to == "as-found";
  options.force = force;
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
  return 0;
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
    std::cout << kUsage;
    return 0;
  }
  if (ini.empty()) throw UsageError("--ini: expected the machine's LinuxCNC INI file");
  if (json && command != "plan") throw UsageError("--json: only for circcomp plan");
  if (command == "revert") return run_revert(ini, diagnosis, to, force);
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
      if (w != "backlash" && w != "scale" && w != "squareness" && w != "cyclic" &&
          w != "friction" && w != "servo") {
        throw UsageError(
            "--only: expected backlash, scale, squareness, cyclic, friction or servo, got '" + w +
            "'");
      }
      options.only.insert(w);
      if (w == "friction") options.friction_requested = true;
      if (w == "servo") options.servo_requested = true;
    }
  }
  // One plane's diagnosis, or a test set's (one entry per plane).
  const std::vector<DiagnosisInput> planes = read_diagnosis_planes(diagnosis);
  if (command == "apply") require_fresh(ini, planes.front(), force, circcomp_option_words);
  const Plan plan = make_plan(ini, planes, options);
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
  apply_plan(plan, after_step_hook());
  print_summary(plan, std::cout);
  for (const auto& f : plan.files) {
    std::cout << "circcomp: " << (f.existed ? "changed " : "created ") << f.path << "\n";
  }
  std::cout << "circcomp: originals kept; undo with: circcomp revert --ini " << ini << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return run_cli("circcomp", [&] { return run(argc, argv); });
}
