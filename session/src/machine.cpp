#include "circtest/session/machine.hpp"

#include <fmt/format.h>
#include <cctype>
#include <sstream>

#include "circtest/core/error.hpp"

namespace circtest::session {

namespace {

// "XYZ" from "trivkins coordinates=XYZ", or from "X Y Z"; upper case, blanks dropped.
std::string letters_of(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (std::isalpha(static_cast<unsigned char>(c))) {
      out += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    }
  }
  return out;
}

}  // namespace

MachineAxes machine_axes(const IniDocument& ini, const std::string& ini_path) {
  const auto joints_entry = ini.find("KINS", "JOINTS");
  if (!joints_entry) throw ParseError(ini_path, 0, "expected [KINS] JOINTS");
  int count = 0;
  try {
    std::size_t used = 0;
    count = std::stoi(joints_entry->value, &used);
    if (used != joints_entry->value.size()) count = 0;
  } catch (const std::exception&) {
    count = 0;
  }
  if (count < 1 || count > 16) {
    throw ParseError(joints_entry->file, joints_entry->line,
                     "[KINS] JOINTS: expected a count of 1..16, got '" + joints_entry->value + "'");
  }
  std::string letters;
  if (const auto kins = ini.get("KINS", "KINEMATICS")) {
    std::istringstream in(*kins);
    for (std::string w; in >> w;) {
      if (w.rfind("coordinates=", 0) == 0) letters = letters_of(w.substr(12));
    }
  }
  if (letters.empty()) letters = letters_of(ini.get("TRAJ", "COORDINATES").value_or(""));
  if (static_cast<int>(letters.size()) < count) {
    throw ParseError(ini_path, 0,
                     fmt::format("[KINS] JOINTS = {} but the coordinates ('{}') name {} axes: "
                                 "expected one per joint",
                                 count, letters, letters.size()));
  }
  MachineAxes axes;
  for (int j = 0; j < count; ++j) axes.joints.push_back({j, letters[static_cast<std::size_t>(j)]});
  return axes;
}

}  // namespace circtest::session
