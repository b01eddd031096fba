#pragma once
// The numbers and words circgen's program and its messages share (internal to the gcode
// library): positions and feeds as the program writes them, lengths in the user's units.
#include <string>
#include <vector>

#include "circtest/core/plane.hpp"
#include "circtest/gcode/generator.hpp"

namespace circtest::gcode_detail {

inline constexpr double kAngleEpsilonDeg = 1e-9;

inline int axis_index(char axis) {
  return axis - 'x';
}

inline char upper(char axis) {
  return static_cast<char>(axis - 'a' + 'A');
}

// Header numbers: shortest form that survives a round trip, after dropping float noise
// (38.099999999999994 mm from 1.5 in is 38.1).
std::string header_number(double value);
std::string header_list(const std::vector<double>& values);

// A length in the program's units for a message, to the program's digits: "50" or "1.9685",
// and with its unit.
std::string units_number(const CircleTestSpec& spec, double mm);
std::string length_text(const CircleTestSpec& spec, double mm);

// A length or a feed in the program's units for a message, all its digits: "-51.816051714
// mm", "2.04 in", "20 in/min".
std::string units_value(const CircleTestSpec& spec, double mm);
std::string exact_length_text(const CircleTestSpec& spec, double mm);
std::string feed_text(const CircleTestSpec& spec, double mm_per_min);

// A range fixed in mm, and in inch too for an inch program: "0.5..3 mm [0.019685..0.11811 in]".
std::string mm_range_text(const CircleTestSpec& spec, double low_mm, double high_mm);

// Two positions the program would write as one number (4 decimals in mm, 5 in inch).
bool written_equal(const CircleTestSpec& spec, double a_mm, double b_mm);

// An angle in [0, 360).
double normalize_deg(double deg);

// The angle of +Z, the top of the circle, in the plane's angle convention (from the first
// axis toward the second); nullopt for XY, which has no top.
std::optional<double> top_deg(Plane plane);

// Where a run in `direction` starts its lead-in.
double lead_in_start_deg(const CircleTestSpec& spec, Direction direction);

}  // namespace circtest::gcode_detail
