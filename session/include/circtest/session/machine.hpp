#pragma once
// What a session needs to know of the machine from its INI: which joint moves which axis.
#include <string>
#include <vector>

#include "circtest/core/ini.hpp"

namespace circtest::session {

struct JointAxis {
  int joint = 0;
  char axis = 'X';  // upper case
};

struct MachineAxes {
  std::vector<JointAxis> joints;  // in joint order
};

// The joints of [KINS] JOINTS and their axes: the kinematics' coordinates= (as trivkins maps
// them), else [TRAJ] COORDINATES. Throws ParseError (INI file and line) when JOINTS is missing
// or not a count of 1..16, or the coordinates do not name an axis for each joint.
MachineAxes machine_axes(const IniDocument& ini, const std::string& ini_path);

}  // namespace circtest::session
