#pragma once
// Internals of the instrument-file import shared by its translation units; not installed.
#include <numbers>
#include <string>
#include <string_view>

namespace circtest::import_detail {

inline constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// A title field as a --columns name ("Angle (deg)" -> "angle_deg"); "" when it does not say
// what the column holds.
std::string title_column_name(std::string_view field);

}  // namespace circtest::import_detail
