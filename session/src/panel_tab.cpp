#include <fmt/format.h>
#include <algorithm>
#include <filesystem>
#include <sstream>

#include "circtest/core/error.hpp"
#include "circtest/session/install.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace {

// The screen qtvcp runs: its last word that is not an option ("qtvcp -d qtdragon").
std::string qtvcp_screen(const std::vector<std::string>& words) {
  for (auto it = words.rbegin(); it != words.rend() - 1; ++it) {
    if (!it->empty() && it->front() != '-') return *it;
  }
  return "";
}

}  // namespace

PanelTab panel_tab(const IniDocument& ini, const std::string& ini_path) {
  const auto display = ini.find("DISPLAY", "DISPLAY");
  if (!display || words_of(display->value).empty()) {
    throw DataError(ini_path, 0,
                    "[DISPLAY] DISPLAY is not set: the panel is a tab of the machine's screen "
                    "(AXIS, gmoccapy or a qtvcp screen); install without --panel");
  }
  const std::vector<std::string> words = words_of(display->value);
  const std::string program = std::filesystem::path(words.front()).filename().string();
  PanelTab tab;
  if (program == "axis") {
    tab.screen = "AXIS";
    tab.command = "qtvcp -x {XID} circtest";
  } else if (program == "gmoccapy") {
    tab.screen = "gmoccapy";
    tab.command = "qtvcp -x {XID} circtest";
    tab.location = "ntb_user_tabs";
  } else if (program == "qtvcp") {
    tab.screen = qtvcp_screen(words);
    tab.command = "qtvcp circtest";
    tab.location = tab.screen.rfind("qtdragon", 0) == 0 ? "tabWidget_utilities" : "default";
  } else {
    throw DataError(display->file, display->line,
                    fmt::format("DISPLAY = {}: this screen takes no tabs (AXIS, gmoccapy and "
                                "qtvcp screens do): run `qtvcp circtest` beside it, and install "
                                "without --panel",
                                display->value));
  }
  const auto names = ini.get_all("DISPLAY", "EMBED_TAB_NAME");
  for (const IniEntry& name : names) {
    if (name.value == "circtest") {
      throw DataError(name.file, name.line, "a tab named circtest is there already");
    }
  }
  // The screens pair the lines by their order: ours must land at the same index in each list.
  const auto commands = ini.get_all("DISPLAY", "EMBED_TAB_COMMAND");
  const auto locations = ini.get_all("DISPLAY", "EMBED_TAB_LOCATION");
  const bool unpaired = commands.size() != names.size() ||
                        (!tab.location.empty() && locations.size() != names.size());
  if (unpaired) {
    throw DataError(display->file, display->line,
                    fmt::format("[DISPLAY] has {} EMBED_TAB_NAME, {} EMBED_TAB_COMMAND and {} "
                                "EMBED_TAB_LOCATION lines: {} pairs them by their order, so the "
                                "circtest tab would take another tab's line; give each tab its "
                                "{} first",
                                names.size(), commands.size(), locations.size(), tab.screen,
                                tab.location.empty() ? "EMBED_TAB_COMMAND"
                                                     : "EMBED_TAB_COMMAND and EMBED_TAB_LOCATION"));
  }
  return tab;
}

void add_panel_tab(IniDocument& ini, const PanelTab& tab) {
  ini.append("DISPLAY", "EMBED_TAB_NAME", "circtest");
  ini.append("DISPLAY", "EMBED_TAB_COMMAND", tab.command);
  if (!tab.location.empty()) ini.append("DISPLAY", "EMBED_TAB_LOCATION", tab.location);
}

}  // namespace circtest::session
