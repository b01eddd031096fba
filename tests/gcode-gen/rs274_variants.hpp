#pragma once
// The circgen variants the rs274 tests run through LinuxCNC's real interpreter, what each
// variant's options imply (clearance, feed-in, approach feed), and the angle helpers the
// rs274 tests share (test_rs274.cpp and its _structure, _set and _grid parts: one program).
#include <gtest/gtest.h>

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "circtest/core/plane.hpp"
#include "circtest/gcode/generator.hpp"

namespace circtest::testing {

struct Variant {
  std::string name;
  std::vector<std::string> args;
  Plane plane;
  double radius;                 // program units
  std::array<double, 3> centre;  // program units
  std::vector<double> feeds;     // program units per minute
  std::vector<Direction> directions;
  double arc_deg = 360.0;
  double start_deg = 0.0;
  double lead_deg = 10.0;
  std::string units = "mm";
  int marker = 0;
  int segment = 0;
};

// The encoder programs and the ballbar's, the grid's and the offsets' ones, in that order.
std::vector<Variant> variants();

// The value of an option in the variant's arguments, if given.
std::optional<std::string> arg(const Variant& v, const std::string& name);
bool is_ballbar(const Variant& v);
// The ballbar's feed-in in program units: 1.5 mm unless --feed-in says otherwise.
double feed_in(const Variant& v);
// --approach-feed, or min(200 mm/min, half the lowest feed), in program units.
double approach_feed(const Variant& v);
// --clearance (or --safe-z) in program units; a ballbar's default 50 mm beyond the centre.
std::optional<double> clearance(const Variant& v);

double wrap360(double deg);             // in [0, 360)
double angle_diff(double a, double b);  // the smaller angle between two directions, deg
bool moved(double from, double to);     // by more than 1e-9

// Each variant's program through rs274 (test_rs274.cpp, test_rs274_structure.cpp).
class Rs274Variant : public ::testing::TestWithParam<Variant> {};

}  // namespace circtest::testing
