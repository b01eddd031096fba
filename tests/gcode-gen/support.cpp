#include "support.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace circtest::testing {

CommandResult run_circgen(const std::vector<std::string>& args) {
  std::vector<std::string> argv{CIRCGEN_EXE};
  argv.insert(argv.end(), args.begin(), args.end());
  return run_command(argv, {"SOURCE_DATE_EPOCH=1700000000"});
}

namespace {

int axis_index(char axis) {
  return axis - 'x';
}

std::vector<std::string> split_args(const std::string& text) {
  std::vector<std::string> out;
  std::string current;
  for (char c : text) {
    if (c == ',' || c == ' ') {
      if (!current.empty()) out.push_back(current), current.clear();
    } else {
      current += c;
    }
  }
  if (!current.empty()) out.push_back(current);
  return out;
}

double num(const std::vector<std::string>& args, std::size_t i) {
  return std::stod(args.at(i));
}

double angle_deg(double a, double b) {
  return std::atan2(b, a) * 180.0 / std::numbers::pi;
}

}  // namespace

double CanonMotion::sweep_deg() const {
  const int f = axis_index(first), s = axis_index(second);
  const double a0 = angle_deg(start[f] - centre[f], start[s] - centre[s]);
  const double a1 = angle_deg(end[f] - centre[f], end[s] - centre[s]);
  // rs274 semantics: |rotation| - 1 full turns plus the angle to the end point, a full
  // turn when the end point is the start point.
  double partial = rotation > 0 ? a1 - a0 : a0 - a1;
  partial = std::fmod(partial + 720.0, 360.0);
  if (partial < 1e-6 || partial > 360.0 - 1e-6) partial = 360.0;
  const double turns = partial + 360.0 * (std::abs(rotation) - 1);
  return rotation > 0 ? turns : -turns;
}

double CanonMotion::start_angle_deg() const {
  const int f = axis_index(first), s = axis_index(second);
  double a = angle_deg(start[f] - centre[f], start[s] - centre[s]);
  if (a < 0) a += 360.0;
  if (a >= 360.0 - 1e-9) a = 0.0;
  return a;
}

double CanonMotion::radius_start() const {
  const int f = axis_index(first), s = axis_index(second);
  return std::hypot(start[f] - centre[f], start[s] - centre[s]);
}

double CanonMotion::radius_end() const {
  const int f = axis_index(first), s = axis_index(second);
  return std::hypot(end[f] - centre[f], end[s] - centre[s]);
}

CanonProgram parse_canon(const std::string& text) {
  CanonProgram program;
  std::array<double, 3> position{0.0, 0.0, 0.0};
  char first = 'x', second = 'y', normal = 'z';
  double feed = 0.0;
  bool feed_override = true;
  std::string control_mode;
  std::array<double, 3> work_offset{0.0, 0.0, 0.0}, tool_offset{0.0, 0.0, 0.0};
  std::map<int, bool> bits, pending_bits;
  std::map<int, double> values, pending_values;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto dots = line.find("N.....");
    const auto open = line.find('(', dots);
    const auto close = line.rfind(')');
    if (dots == std::string::npos || open == std::string::npos || close == std::string::npos) {
      continue;
    }
    const std::string name = line.substr(dots + 7, open - dots - 7);
    program.calls.push_back(name);
    program.call_log.push_back(
        {name, line.substr(open + 1, close - open - 1), program.motions.size()});
    if (name == "COMMENT" || name == "MESSAGE") continue;
    const auto args = split_args(line.substr(open + 1, close - open - 1));
    auto motion = [&](CanonMotion::Kind kind, const std::array<double, 3>& end) {
      // Synchronized outputs queued since the last move take effect as this one starts.
      for (auto& [k, v] : pending_bits) bits[k] = v;
      for (auto& [k, v] : pending_values) values[k] = v;
      pending_bits.clear(), pending_values.clear();
      CanonMotion m;
      m.kind = kind;
      m.source_line = line_no;
      m.start = position;
      m.end = end;
      m.first = first, m.second = second;
      m.feed = feed;
      m.feed_override = feed_override;
      m.control_mode = control_mode;
      m.bits = bits, m.values = values;
      position = end;
      return m;
    };
    if (name == "USE_LENGTH_UNITS") {
      program.units = args.at(0) == "CANON_UNITS_INCHES" ? "inch" : "mm";
    } else if (name == "SELECT_PLANE") {
      // saicanon.cc: ARC_FEED's first/second axes are X/Y, Y/Z and Z/X for the three planes.
      if (args.at(0) == "CANON_PLANE_XY") first = 'x', second = 'y', normal = 'z';
      if (args.at(0) == "CANON_PLANE_YZ") first = 'y', second = 'z', normal = 'x';
      if (args.at(0) == "CANON_PLANE_XZ") first = 'z', second = 'x', normal = 'y';
    } else if (name == "SET_G5X_OFFSET" || name == "USE_TOOL_LENGTH_OFFSET") {
      // A new work or tool offset moves nothing: the axes stay where they are, so the
      // current point moves in the program frame by the change of the offset.
      const std::size_t first_arg = name == "SET_G5X_OFFSET" ? 1 : 0;
      auto& old = name == "SET_G5X_OFFSET" ? work_offset : tool_offset;
      for (int i = 0; i < 3; ++i) {
        const double now = num(args, first_arg + static_cast<std::size_t>(i));
        position[static_cast<std::size_t>(i)] += old[static_cast<std::size_t>(i)] - now;
        old[static_cast<std::size_t>(i)] = now;
      }
    } else if (name == "DISABLE_FEED_OVERRIDE") {
      feed_override = false;
    } else if (name == "ENABLE_FEED_OVERRIDE") {
      feed_override = true;
    } else if (name == "SET_MOTION_CONTROL_MODE") {
      control_mode = args.at(0);
    } else if (name == "SET_FEED_RATE") {
      feed = num(args, 0);
    } else if (name == "STRAIGHT_FEED" || name == "STRAIGHT_TRAVERSE") {
      program.motions.push_back(
          motion(name == "STRAIGHT_FEED" ? CanonMotion::linear : CanonMotion::traverse,
                 {num(args, 0), num(args, 1), num(args, 2)}));
    } else if (name == "ARC_FEED") {
      std::array<double, 3> end{};
      end[axis_index(first)] = num(args, 0);
      end[axis_index(second)] = num(args, 1);
      end[axis_index(normal)] = num(args, 5);
      CanonMotion m = motion(CanonMotion::arc, end);
      m.centre[axis_index(first)] = num(args, 2);
      m.centre[axis_index(second)] = num(args, 3);
      m.centre[axis_index(normal)] = num(args, 5);
      m.rotation = std::stoi(args.at(4));
      program.motions.push_back(m);
    } else if (name == "SET_MOTION_OUTPUT_BIT") {
      pending_bits[std::stoi(args.at(0))] = true;
    } else if (name == "CLEAR_MOTION_OUTPUT_BIT") {
      pending_bits[std::stoi(args.at(0))] = false;
    } else if (name == "SET_MOTION_OUTPUT_VALUE") {
      pending_values[std::stoi(args.at(0))] = num(args, 1);
    } else if (name == "SET_AUX_OUTPUT_BIT") {
      bits[std::stoi(args.at(0))] = true;
    } else if (name == "CLEAR_AUX_OUTPUT_BIT") {
      bits[std::stoi(args.at(0))] = false;
    } else if (name == "SET_AUX_OUTPUT_VALUE") {
      values[std::stoi(args.at(0))] = num(args, 1);
    } else if (name == "PROGRAM_END") {
      program.ended = true;
    }
  }
  return program;
}

bool rs274_available() {
  return ::access(CIRCTEST_RS274, X_OK) == 0;
}

Rs274Result run_rs274(const std::string& program_text) {
  if (!rs274_available()) throw std::runtime_error(std::string("no rs274 at ") + CIRCTEST_RS274);
  ScratchDir home;
  spit(home.file("prog.ngc"), program_text);
  // rs274 writes $HOME/.rs274 and friends: keep it out of the real home.
  const CommandResult r =
      run_command({CIRCTEST_RS274, "-g", home.file("prog.ngc"), home.file("out.canon")},
                  {"HOME=" + home.path()});
  Rs274Result result;
  result.exit_code = r.exit_code;
  result.output = r.out + r.err;
  if (std::filesystem::exists(home.file("out.canon"))) {
    result.canon = parse_canon(slurp(home.file("out.canon")));
  }
  return result;
}

}  // namespace circtest::testing
