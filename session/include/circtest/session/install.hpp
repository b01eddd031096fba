#pragma once
// `circtest install`: circlog wired into a LinuxCNC configuration. The channels are found in
// the configuration's HAL files (each joint's motor-pos-cmd and the signal that feeds its
// motor-pos-fb), written into a HAL file of their own (circtest.hal) that the INI loads after
// the machine's HALFILEs, with the column names in [CIRCTEST] COLUMNS. The change is a
// circcomp plan: shown as a diff, applied with circcomp's guarantees (only inside the
// configuration folder, originals kept in .circcomp/, undone byte-identical by uninstall or
// circcomp revert).
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "circtest/compensation/plan.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/setting_words.hpp"

namespace circtest::session {

// The settings an install refusal asks for; the front end words them (its options).
enum class InstallSetting {
  feedback_pin,    // the pin that measures a joint's position
  command_pin,     // the pin that holds a joint's commanded position
  instrument_pin,  // an external instrument's pin
};
using InstallSettingWords = SettingWords<InstallSetting>;
std::string_view library_setting_words(InstallSetting setting) noexcept;

// The HAL file the install writes, in the configuration folder.
inline constexpr std::string_view kSessionHalFile = "circtest.hal";
// The channel of the servo thread's period: motion.servo.last-period (u32: the time between
// the last two runs of motion's controller, in CPU clocks in LinuxCNC 2.9, in ns later) made a
// float by LinuxCNC's conv_u32_float, loaded under this instance name.
inline constexpr std::string_view kServoPeriodColumn = "servo_period";
inline constexpr std::string_view kServoPeriodConv = "circtest-servo-period";

struct InstallRequest {
  std::string ini_path;
  std::map<int, std::string> feedback_pins;  // joint -> pin, where the HAL does not say
  std::map<int, std::string> command_pins;   // joint -> pin
  // column name (x, y, z: the table position an instrument measures) -> pin
  std::vector<std::pair<std::string, std::string>> instrument_pins;
  bool panel = false;  // also the circtest QtVCP panel as a tab of the screen (panel_tab)
  InstallSettingWords words = library_setting_words;
};

// The circtest QtVCP panel (docs/panel.md) as a tab of the machine's screen: the
// [DISPLAY] EMBED_TAB_* lines for the screen that DISPLAY names.
struct PanelTab {
  std::string screen;    // "AXIS", "gmoccapy", or the qtvcp screen ("qtdragon")
  std::string command;   // EMBED_TAB_COMMAND
  std::string location;  // EMBED_TAB_LOCATION; empty for AXIS, which reads none
};
// Throws DataError (with the INI's file and line) for a screen that takes no tabs, a tab
// named circtest already there, and EMBED_TAB_* lists of different lengths (the screens pair
// them by order).
PanelTab panel_tab(const IniDocument& ini, const std::string& ini_path);
// Appends the tab's lines to [DISPLAY], each after the last line of its key.
void add_panel_tab(IniDocument& ini, const PanelTab& tab);

// One circlog channel: its column, the signal it joins (or the pin it links to a new signal)
// and what it is.
struct InstallChannel {
  std::string column;
  std::string signal;
  std::string pin;  // a pin put on the new signal `signal`; empty when the signal exists
  std::string what;
};

struct InstallPlan {
  compensation::Plan plan;  // the files and their new text
  std::vector<InstallChannel> channels;
  std::vector<std::string> notes;  // stepper feedback, joints left out, ...
  int marker_output = 0;           // motion.digital-out-NN for circlog.0.enable
  int segment_output = 0;          // motion.analog-out-NN for circlog.0.segment
  // The u32 signal on motion.servo.last-period that feeds the conv_u32_float of the
  // servo_period channel (a new signal when the pin is on none); empty: the period is not
  // logged (a note says why).
  std::string servo_period_signal;
};

// Reads the INI and its HAL files and plans the install. Throws DataError when circlog is
// already loaded, a joint's command or feedback cannot be found (the message names the
// setting that gives it), or there is no free motion output for the markers; IoError/
// ParseError for files that cannot be read.
InstallPlan plan_install(const InstallRequest& request);

// Applies the plan (compensation::apply_plan: originals kept, the manifest written first).
void apply_install(const InstallPlan& plan);

// Undoes the install byte-identical (compensation::revert of the last apply) when the last
// apply recorded for the configuration is the install. Throws DataError when another apply
// (circcomp's corrections) came after it, naming the revert that must come first; returns
// false when nothing is installed.
bool uninstall(const std::string& ini_path);

// The text of the HAL file for the channels (loadrt, addf, the nets, the markers).
std::string session_hal_text(const InstallPlan& plan, const std::string& thread);

}  // namespace circtest::session
