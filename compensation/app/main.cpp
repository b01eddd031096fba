// circcomp: writes a circtest diagnosis back into a LinuxCNC configuration. Only option
// parsing lives here: the options become a CirccompRequest run by app/commands.cpp.
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>
#include <boost/program_options.hpp>

#include <csignal>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>

#include "circtest/circcomp/commands.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/cli.hpp"
#include "circtest/core/cli_options.hpp"
#include "circtest/core/error.hpp"
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

#ifdef CIRCCOMP_CRASH_TEST
// Only in the crash test's own build of this file (tests/compensation: circcomp-crash-test,
// never installed): SIGKILL itself after step K of apply or revert (CIRCCOMP_KILL_AFTER_STEP),
// as a power cut or an OOM kill would stop it, so the test sees what such a stop leaves; or
// standard output turned into /dev/full after step K (CIRCCOMP_FULL_STDOUT_AFTER_STEP).
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
    if (!diagnosis.empty()) throw UsageError("revert takes no diagnosis");
    if (!to.empty() && to != "last" && to != "as-found") {
      throw UsageError("--to: expected last or as-found, got '" + to + "'");
    }
    CirccompRequest request;
    request.command = CirccompCommand::revert;
    request.ini = ini;
    request.revert.as_found = to == "as-found";
    request.revert.force = force;
    request.words = circcomp_option_words;
    request.after_step = after_step_hook();
    return run_circcomp(request);
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
  CirccompRequest request;
  request.command = command == "plan" ? CirccompCommand::plan : CirccompCommand::apply;
  request.ini = ini;
  request.diagnosis = diagnosis;
  request.plan_options = options;
  request.json = json;
  request.words = circcomp_option_words;
  request.after_step = after_step_hook();
  return run_circcomp(request);
}

}  // namespace

int main(int argc, char** argv) {
  return run_cli("circcomp", [&] { return run(argc, argv); });
}
