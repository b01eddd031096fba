#pragma once
// Pi and degrees per radian for the evaluation's files, defined once: the unity build compiles
// several of them as one translation unit.
#include <numbers>

namespace circtest::evaluation_detail {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;
inline constexpr double kRadToDeg = 180.0 / kPi;

}  // namespace circtest::evaluation_detail
