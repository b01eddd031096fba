#pragma once
// Test helpers for circgen: running processes in a scratch folder, and reading the canonical
// calls that LinuxCNC's rs274 prints for a program.
#include <array>
#include <map>
#include <string>
#include <vector>

#include "scratch.hpp"

namespace circtest::testing {

// circgen with these arguments; SOURCE_DATE_EPOCH fixed so the output is reproducible.
CommandResult run_circgen(const std::vector<std::string>& args);

// One motion of the canonical output, with the synchronized outputs in effect during it.
struct CanonMotion {
  enum Kind { traverse, linear, arc } kind = linear;
  int source_line = 0;            // line in the canon file
  std::array<double, 3> start{};  // x, y, z in program units
  std::array<double, 3> end{};
  std::array<double, 3> centre{};  // arcs only; the normal coordinate is the arc's end
  char first = 'x', second = 'y';  // the arc's in-plane axes, as ARC_FEED orders them
  int rotation = 0;                // ARC_FEED's turn count, signed
  double feed = 0.0;               // SET_FEED_RATE in effect
  bool feed_override = true;       // DISABLE/ENABLE_FEED_OVERRIDE in effect
  std::string control_mode;        // SET_MOTION_CONTROL_MODE in effect, e.g. CANON_EXACT_PATH
  std::map<int, bool> bits;        // motion digital outputs during the move
  std::map<int, double> values;    // motion analog outputs during the move
  double sweep_deg() const;        // signed, + from `first` toward `second`
  double start_angle_deg() const;  // in [0, 360), from `first` toward `second`
  double radius_start() const;
  double radius_end() const;
};

// One canonical call in program order, placed among the motions.
struct CanonCall {
  std::string name;
  std::string args;                // the text between the parentheses
  std::size_t motions_before = 0;  // motions that precede this call
};

struct CanonProgram {
  std::string units;  // "mm" or "inch" (last USE_LENGTH_UNITS)
  std::vector<CanonMotion> motions;
  std::vector<std::string> calls;   // every call name in order, for sequence checks
  std::vector<CanonCall> call_log;  // the same calls with their arguments and position
  bool ended = false;               // PROGRAM_END seen
};

// Parses rs274's canon output (saicanon's ECHO format: "  N N..... NAME(args)").
CanonProgram parse_canon(const std::string& text);

struct Rs274Result {
  int exit_code = -1;
  std::string output;  // stdout + stderr
  CanonProgram canon;
};

// Runs `rs274 -g` on a program in a fresh scratch HOME; throws if rs274 is missing.
Rs274Result run_rs274(const std::string& program_text);

bool rs274_available();

}  // namespace circtest::testing
