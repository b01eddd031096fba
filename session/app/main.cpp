// circtest: the guided circular test on the user's running LinuxCNC. Only option parsing lives
// here; the work is circtest::session.
#include <boost/program_options.hpp>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "circtest/core/cli.hpp"
#include "circtest/core/cli_options.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/version.hpp"
#include "circtest/session/commands.hpp"

namespace po = boost::program_options;
using namespace circtest;
using namespace circtest::session;

namespace {

constexpr const char* kUsage =
    "usage: circtest install   --ini MACHINE.ini [--yes] [--feedback JOINT=PIN]...\n"
    "                          [--command JOINT=PIN]... [--instrument NAME=PIN]... [--panel]\n"
    "       circtest uninstall --ini MACHINE.ini\n"
    "       circtest run    --ini MACHINE.ini [--d MM] [--f F | --feeds F1,F2,...]\n"
    "                       [--plane XY|YZ|ZX|XY,YZ,ZX] [--centre X,Y,Z] [--clearance P]\n"
    "                       [--start] [--yes] [--timeout S] [--limits H=MM,G=MM,F=MM]\n"
    "       circtest verify --ini MACHINE.ini [--start] [--timeout S] [--limits ...]\n";

std::string_view install_option_words(InstallSetting setting) noexcept {
  switch (setting) {
    case InstallSetting::feedback_pin:
      return "--feedback JOINT=PIN";
    case InstallSetting::command_pin:
      return "--command JOINT=PIN";
    case InstallSetting::instrument_pin:
      return "--instrument NAME=PIN";
  }
  return library_setting_words(setting);
}

std::pair<std::string, std::string> split_assignment(const std::string& option,
                                                     const std::string& value) {
  const auto eq = value.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == value.size()) {
    throw UsageError(option + ": expected NAME=PIN, got '" + value + "'");
  }
  return {value.substr(0, eq), value.substr(eq + 1)};
}

std::map<int, std::string> joint_pins(const std::string& option,
                                      const std::vector<std::string>& values) {
  std::map<int, std::string> pins;
  for (const std::string& v : values) {
    const auto [joint, pin] = split_assignment(option, v);
    const int j = parse_option_index(option, joint);
    if (!pins.emplace(j, pin).second) {
      throw UsageError(option + ": joint " + joint + " is given twice");
    }
  }
  return pins;
}

// run or verify, and what the operator does next in circtest's words.
int run_or_verify(const std::string& command, const RunRequest& request, const Console& console) {
  if (command == "verify" && console.yes) throw UsageError("--yes: verify applies nothing");
  const RunOutcome outcome =
      command == "run" ? run_session(request, console) : verify_session(request, console);
  if (outcome.applied) {
    std::cout << "circtest: then: circtest verify --ini " << request.ini_path
              << (request.start ? " --start" : "") << "\n";
  }
  if (outcome.worse) {
    std::cout << "circtest: revert them with: circcomp revert --ini " << request.ini_path
              << " (and restart LinuxCNC)\n";
  }
  if (!outcome.session_dir.empty()) {
    std::cout << "circtest: session folder " << outcome.session_dir << "\n";
  }
  return outcome.exit_code;
}

int run(int argc, char** argv) {
  if (argc < 2) throw UsageError(std::string("expected a command\n") + kUsage);
  const std::string command = argv[1];
  if (command == "--help" || command == "-h") {
    std::cout << kUsage;
    return 0;
  }
  if (command == "--version") {
    std::cout << version_line("circtest") << "\n";
    return 0;
  }
  if (command != "install" && command != "uninstall" && command != "run" && command != "verify") {
    throw UsageError("unknown command '" + command +
                     "' (expected install, uninstall, run or verify)");
  }
  std::string ini, d_text, f_text, timeout_text;
  bool yes = false, start = false, panel = false;
  std::vector<std::string> feedback, commanded, instruments;
  RunRequest run_request;
  po::options_description opts;
  opts.add_options()("ini", po::value(&ini))("yes", po::bool_switch(&yes))(
      "feedback", po::value(&feedback))("command", po::value(&commanded))(
      "instrument", po::value(&instruments))("d", po::value(&d_text))("f", po::value(&f_text))(
      "feeds", po::value(&run_request.program.feeds_mm_per_min))(
      "plane", po::value(&run_request.program.planes))("centre",
                                                       po::value(&run_request.program.centre_mm))(
      "clearance", po::value(&run_request.program.clearance_mm))("start", po::bool_switch(&start))(
      "panel", po::bool_switch(&panel))("timeout", po::value(&timeout_text))(
      "limits", po::value(&run_request.limits))("help,h", "");
  po::variables_map vm;
  try {
    refuse_option_placeholders(argc, argv);
    po::store(po::command_line_parser(argc - 1, argv + 1).options(opts).run(), vm);
    po::notify(vm);
  } catch (const po::error& e) {
    throw option_usage_error(e, opts);
  }
  if (vm.count("help")) {
    std::cout << kUsage;
    return 0;
  }
  if (ini.empty()) throw UsageError("--ini: expected the machine's LinuxCNC INI file");
  if (panel && command != "install") throw UsageError("--panel is install's option");
  Console console;
  console.yes = yes;
  if (command == "run" || command == "verify") {
    if (!feedback.empty() || !commanded.empty() || !instruments.empty()) {
      throw UsageError("--feedback, --command and --instrument are install's options");
    }
    if (vm.count("limits") && run_request.limits.empty()) {
      throw UsageError("--limits: expected H=MM,G=MM,F=MM (circana report's --limits)");
    }
    run_request.ini_path = ini;
    run_request.start = start;
    if (!d_text.empty()) run_request.program.diameter_mm = parse_option_number("--d", d_text);
    if (!f_text.empty()) run_request.program.feed_mm_per_min = parse_option_number("--f", f_text);
    if (!timeout_text.empty())
      run_request.timeout_s = parse_option_number("--timeout", timeout_text);
    return run_or_verify(command, run_request, console);
  }
  if (!d_text.empty() || !f_text.empty() || start || !timeout_text.empty() ||
      !run_request.program.feeds_mm_per_min.empty() || !run_request.program.planes.empty() ||
      vm.count("limits")) {
    throw UsageError(
        "the program's options (--d, --f, --feeds, --plane, --start, --timeout, --limits) are "
        "run's and verify's");
  }
  if (command == "uninstall") {
    if (!feedback.empty() || !commanded.empty() || !instruments.empty()) {
      throw UsageError("uninstall takes only --ini");
    }
    return uninstall_command(ini, console);
  }
  InstallRequest request;
  request.ini_path = ini;
  request.feedback_pins = joint_pins("--feedback", feedback);
  request.command_pins = joint_pins("--command", commanded);
  for (const std::string& v : instruments) {
    request.instrument_pins.push_back(split_assignment("--instrument", v));
  }
  request.panel = panel;
  request.words = install_option_words;
  return install_command(request, console);
}

}  // namespace

int main(int argc, char** argv) {
  return run_cli("circtest", [&] { return run(argc, argv); });
}
