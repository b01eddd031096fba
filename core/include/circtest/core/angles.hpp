#pragma once
// Degrees and radians: G-code, the standard and the reports speak degrees, <cmath> radians.
#include <numbers>

namespace circtest {

constexpr double deg_to_rad(double deg) {
  return deg * std::numbers::pi / 180.0;
}

constexpr double rad_to_deg(double rad) {
  return rad * 180.0 / std::numbers::pi;
}

}  // namespace circtest
