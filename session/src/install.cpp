#include "circtest/session/install.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <optional>
#include <set>

#include "circtest/compensation/config_dir.hpp"
#include "circtest/compensation/manifest.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/session/hal_config.hpp"
#include "circtest/session/machine.hpp"

namespace circtest::session {

namespace fs = std::filesystem;

std::string_view library_setting_words(InstallSetting setting) noexcept {
  switch (setting) {
    case InstallSetting::feedback_pin:
      return "the feedback pin setting";
    case InstallSetting::command_pin:
      return "the command pin setting";
    case InstallSetting::instrument_pin:
      return "the instrument pin setting";
  }
  return "a setting";
}

namespace {

constexpr std::size_t kMaxChannels = 16;  // circlog's channels= limit
// The u32 signal install puts on motion.servo.last-period when the configuration has none.
constexpr std::string_view kNewPeriodSignal = "circtest-last-period";

// What feeds a joint's feedback, from the pin that writes its signal.
std::string feedback_kind(const std::string& source, const std::string& signal,
                          const HalWiring& wiring, int joint, std::vector<std::string>& notes) {
  const std::string cmd_pin = fmt::format("joint.{}.motor-pos-cmd", joint);
  const auto it = wiring.signals.find(signal);
  const bool looped =
      source == cmd_pin || (it != wiring.signals.end() &&
                            std::any_of(it->second.begin(), it->second.end(),
                                        [&](const HalPinOnSignal& p) { return p.pin == cmd_pin; }));
  if (looped) {
    notes.push_back(fmt::format(
        "joint {}: its feedback is its command looped back (no encoder): the feedback channel "
        "shows no error of the machine",
        joint));
    return "command looped back";
  }
  if (source.find("stepgen") != std::string::npos) {
    notes.push_back(fmt::format(
        "joint {}: a stepper: its feedback ({}) is the step count stepgen has sent, not a "
        "measured position; only an instrument channel sees the table",
        joint, source));
    return "step count (" + source + ")";
  }
  if (source.find("encoder") != std::string::npos) return "encoder (" + source + ")";
  return source;
}

// The channel of one joint's pin: the signal the configuration has, the user's pin, or a new
// signal on the joint's own pin (a command pin on no signal).
std::optional<InstallChannel> find_channel(const HalWiring& wiring, const std::string& joint_pin,
                                           const std::string& given, const std::string& column,
                                           const std::string& new_signal) {
  const std::string pin = given.empty() ? joint_pin : given;
  if (const auto s = wiring.signal_of_pin.find(pin); s != wiring.signal_of_pin.end()) {
    return InstallChannel{column, s->second, "", ""};
  }
  if (!given.empty()) return InstallChannel{column, new_signal, given, ""};
  return std::nullopt;
}

// The lowest motion output NN (below COUNT) that no signal uses.
int free_output(const HalWiring& wiring, const char* kind, int count) {
  for (int n = 0; n < count; ++n) {
    if (!wiring.signal_of_pin.count(fmt::format("motion.{}-{:02d}", kind, n))) return n;
  }
  return -1;
}

// num_dio / num_aio of the motmod loadrt line (LinuxCNC's default 4).
int motion_io_count(const HalWiring& wiring, const std::string& key) {
  const auto it = wiring.load_args.find("motmod");
  if (it == wiring.load_args.end()) return 4;
  for (const std::string& a : it->second) {
    if (a.rfind(key + "=", 0) == 0) {
      try {
        return std::stoi(a.substr(key.size() + 1));
      } catch (const std::exception&) {
        return 4;
      }
    }
  }
  return 4;
}

std::vector<JointAxis> linear_joints(const MachineAxes& axes, std::vector<std::string>& notes) {
  std::vector<JointAxis> out;
  std::set<char> seen;
  for (const JointAxis& j : axes.joints) {
    if (j.axis != 'X' && j.axis != 'Y' && j.axis != 'Z') continue;
    if (!seen.insert(j.axis).second) {
      notes.push_back(
          fmt::format("joint {}: a second joint of axis {} is not logged", j.joint, j.axis));
      continue;
    }
    out.push_back(j);
  }
  return out;
}

void add_instruments(const InstallRequest& request, const HalWiring& wiring, InstallPlan& plan) {
  for (const auto& [name, pin] : request.instrument_pins) {
    if (name.empty() || pin.empty()) {
      throw UsageError(
          fmt::format("{}: expected NAME=PIN", request.words(InstallSetting::instrument_pin)));
    }
    for (const InstallChannel& c : plan.channels) {
      if (c.column == name) {
        throw UsageError(fmt::format("{}: the column {} is given twice",
                                     request.words(InstallSetting::instrument_pin), name));
      }
    }
    auto ch = find_channel(wiring, "", pin, name, "circtest-" + name);
    ch->what = "instrument " + pin;
    plan.channels.push_back(*ch);
  }
}

// The servo thread's period as a channel, through LinuxCNC's conv_u32_float loaded under a
// name of its own; left out with a note when the configuration loads conv_u32_float itself
// (a second loadrt of a module fails in LinuxCNC, and with it the start).
void add_servo_period(const HalWiring& wiring, InstallPlan& plan) {
  if (const auto it = wiring.loaded.find("conv_u32_float"); it != wiring.loaded.end()) {
    plan.notes.push_back(fmt::format(
        "{} loads conv_u32_float already (a second loadrt of it would stop LinuxCNC's start): "
        "the servo thread's period (motion.servo.last-period) is not logged, so a run with late "
        "servo periods is not detected",
        it->second.text()));
    return;
  }
  if (plan.channels.size() >= kMaxChannels) {
    plan.notes.push_back(fmt::format(
        "{} channels already: the servo thread's period is not logged (circlog logs at most {})",
        plan.channels.size(), kMaxChannels));
    return;
  }
  const std::string pin = "motion.servo.last-period";
  const auto signal = wiring.signal_of_pin.find(pin);
  plan.servo_period_signal =
      signal == wiring.signal_of_pin.end() ? std::string(kNewPeriodSignal) : signal->second;
  plan.channels.push_back({std::string(kServoPeriodColumn), "circtest-servo-period-float",
                           std::string(kServoPeriodConv) + ".out",
                           "the servo thread's period (" + pin + " through conv_u32_float)"});
}

}  // namespace

std::string session_hal_text(const InstallPlan& plan, const std::string& thread) {
  std::string text =
      "# circlog for the circular test, written by `circtest install` (docs/session.md).\n"
      "# Loaded after the machine's HAL files; `circtest uninstall` removes it again.\n"
      "# Column names for circlog-record: [CIRCTEST] COLUMNS in the INI.\n";
  text += fmt::format("loadrt circlog channels={}\n", plan.channels.size());
  if (!plan.servo_period_signal.empty()) {
    const std::string_view conv = kServoPeriodConv;
    text +=
        "# The servo thread's period (u32: CPU clocks in LinuxCNC 2.9, ns later) as a float for "
        "circlog,\n# in the same period.\n";
    text += fmt::format("loadrt conv_u32_float names={}\naddf {} {}\n", conv, conv, thread);
    // A signal of the configuration's on the pin is joined as it is; else one of its own.
    text += fmt::format(
        "net {}{} => {}.in\n", plan.servo_period_signal,
        plan.servo_period_signal == kNewPeriodSignal ? " motion.servo.last-period" : "", conv);
  }
  text += "# Last in the servo thread: the command and the feedback of the same period.\n";
  text += fmt::format("addf circlog.0 {}\n\n", thread);
  for (std::size_t i = 0; i < plan.channels.size(); ++i) {
    const InstallChannel& c = plan.channels[i];
    text += fmt::format("# {}: {}\n", c.column, c.what);
    if (c.pin.empty()) {
      text += fmt::format("net {} => circlog.0.in-{:02d}\n", c.signal, i);
    } else {
      text += fmt::format("net {} {} => circlog.0.in-{:02d}\n", c.signal, c.pin, i);
    }
  }
  text +=
      "\n# The program's markers (circgen: M62/M63 P, M67 E): record while on, the run number.\n";
  text += fmt::format("net circtest-marker motion.digital-out-{:02d} => circlog.0.enable\n",
                      plan.marker_output);
  text += fmt::format("net circtest-segment motion.analog-out-{:02d} => circlog.0.segment\n",
                      plan.segment_output);
  return text;
}

InstallPlan plan_install(const InstallRequest& request) {
  const IniDocument ini = IniDocument::load(request.ini_path);
  const compensation::ConfigDir dir(request.ini_path);
  const HalWiring wiring = read_hal_wiring(ini, dir.root());
  if (const auto it = wiring.loaded.find("circlog"); it != wiring.loaded.end()) {
    throw DataError(it->second.file, it->second.line,
                    "circlog is already loaded here: the configuration is wired already "
                    "(uninstall, or record with circlog-record as it is)");
  }
  InstallPlan plan;
  const MachineAxes axes = machine_axes(ini, request.ini_path);
  const int num_dio = motion_io_count(wiring, "num_dio");
  const int num_aio = motion_io_count(wiring, "num_aio");
  const std::vector<JointAxis> joints = linear_joints(axes, plan.notes);
  const std::string files =
      wiring.files_read.empty() ? "no HAL file" : join(wiring.files_read, ", ");
  std::vector<InstallChannel> fb;
  for (const JointAxis& j : joints) {
    const std::string col(1, static_cast<char>(std::tolower(j.axis)));
    const auto given_cmd = request.command_pins.find(j.joint);
    auto cmd = find_channel(wiring, fmt::format("joint.{}.motor-pos-cmd", j.joint),
                            given_cmd == request.command_pins.end() ? "" : given_cmd->second,
                            col + "_cmd", "circtest-" + col + "-cmd");
    if (!cmd) {
      // The joint's own output pin, on a signal of its own.
      cmd = InstallChannel{col + "_cmd", "circtest-" + col + "-cmd",
                           fmt::format("joint.{}.motor-pos-cmd", j.joint), ""};
    }
    cmd->what = fmt::format("joint {} commanded position", j.joint);
    plan.channels.push_back(*cmd);
    const auto given_fb = request.feedback_pins.find(j.joint);
    const std::string fb_given = given_fb == request.feedback_pins.end() ? "" : given_fb->second;
    auto f = find_channel(wiring, fmt::format("joint.{}.motor-pos-fb", j.joint), fb_given,
                          col + "_fb", "circtest-" + col + "-fb");
    if (!f) {
      throw DataError(request.ini_path, 0,
                      fmt::format("joint {} ({}): joint.{}.motor-pos-fb is on no signal in {}{}; "
                                  "name the pin that measures it: {} for joint {}",
                                  j.joint, j.axis, j.joint, files,
                                  wiring.files_not_read.empty()
                                      ? ""
                                      : " (not read: " + join(wiring.files_not_read, ", ") + ")",
                                  request.words(InstallSetting::feedback_pin), j.joint));
    }
    const std::string source =
        f->pin.empty() ? wiring.source_of(f->signal).value_or(f->signal) : f->pin;
    f->what = fmt::format("joint {} feedback: {}", j.joint,
                          feedback_kind(source, f->signal, wiring, j.joint, plan.notes));
    fb.push_back(*f);
  }
  plan.channels.insert(plan.channels.end(), fb.begin(), fb.end());
  add_instruments(request, wiring, plan);
  add_servo_period(wiring, plan);
  if (plan.channels.size() > kMaxChannels) {
    throw DataError(
        request.ini_path, 0,
        fmt::format("{} channels: circlog logs at most {}", plan.channels.size(), kMaxChannels));
  }
  plan.marker_output = free_output(wiring, "digital-out", num_dio);
  plan.segment_output = free_output(wiring, "analog-out", num_aio);
  if (plan.marker_output < 0 || plan.segment_output < 0) {
    throw DataError(request.ini_path, 0,
                    fmt::format("every motion digital output (num_dio={}) or analog output "
                                "(num_aio={}) is in use: raise num_dio/num_aio on the motmod "
                                "loadrt line so that circtest has one of each for its markers",
                                num_dio, num_aio));
  }
  const auto thread = wiring.thread_of_function.find("motion-controller");
  const std::string thread_name =
      thread == wiring.thread_of_function.end() ? "servo-thread" : thread->second;

  const std::string hal_name(kSessionHalFile);
  if (dir.read(hal_name)) {
    throw DataError(dir.path(hal_name), 0,
                    "exists already: move it away (circtest install writes this file)");
  }
  IniDocument edited = IniDocument::load(request.ini_path);
  edited.append("HAL", "HALFILE", hal_name);
  std::vector<std::string> columns;
  for (const InstallChannel& c : plan.channels) columns.push_back(c.column);
  edited.set("CIRCTEST", "COLUMNS", join(columns, ","));
  edited.set("CIRCTEST", "MARKER_OUTPUT", std::to_string(plan.marker_output));
  edited.set("CIRCTEST", "SEGMENT_OUTPUT", std::to_string(plan.segment_output));
  if (request.panel) {
    const PanelTab tab = panel_tab(edited, request.ini_path);
    add_panel_tab(edited, tab);
    plan.notes.push_back(fmt::format(
        "the circtest panel: a tab of {} ([DISPLAY] EMBED_TAB_*, docs/panel.md), after the restart",
        tab.screen));
  }

  plan.plan.ini_path = request.ini_path;
  for (std::size_t i = 0; i < edited.file_count(); ++i) {
    if (!edited.file_modified(i)) continue;
    const auto name = dir.name_of(edited.file_path(i));
    if (!name) {
      throw UnsafePathError(edited.file_path(i), "outside the configuration folder " + dir.root() +
                                                     ": circtest changes nothing there");
    }
    plan.plan.files.push_back(
        {edited.file_path(i), *name, true, dir.read(*name).value_or(""), edited.render_file(i)});
  }
  plan.plan.files.push_back({(fs::path(request.ini_path).parent_path() / hal_name).string(),
                             hal_name, false, "", session_hal_text(plan, thread_name)});
  return plan;
}

void apply_install(const InstallPlan& plan) {
  compensation::apply_plan(plan.plan);
}

bool uninstall(const std::string& ini_path) {
  const compensation::ConfigDir dir(ini_path);
  const auto text = dir.read(".circcomp/manifest");
  if (!text) return false;
  const compensation::Manifest m =
      compensation::parse_manifest(*text, dir.path(".circcomp/manifest"), dir);
  const auto is_ours = [](const compensation::ManifestEntry& e) {
    return e.name == kSessionHalFile && !e.existed;
  };
  if (std::none_of(m.last.begin(), m.last.end(), is_ours)) {
    if (std::any_of(m.found.begin(), m.found.end(), is_ours)) {
      throw DataError(ini_path, 0,
                      "circcomp applied corrections after circtest install: undo them first "
                      "(circcomp revert --ini " +
                          ini_path + "), then uninstall");
    }
    return false;
  }
  return compensation::revert(ini_path, compensation::RevertOptions{}).reverted;
}

}  // namespace circtest::session
