#pragma once
// Planes, directions and the direction labels of ISO 230-4 clause 3.7.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace circtest {

enum class Plane { XY, YZ, ZX };

// A point in the plane under test: its two coordinates in clause 3.7 axis order (XY: x, y;
// YZ: y, z; ZX: z, x), mm. Centres of circles and set-ups.
struct PlanePoint {
  double a_mm = 0.0;
  double b_mm = 0.0;
  friend bool operator==(const PlanePoint&, const PlanePoint&) = default;
};
enum class Direction { CCW, CW };

// The two axes of a plane in the order of its positive rotation (XY: x then y; YZ: y then z;
// ZX: z then x), and the axis normal to it. Lowercase letters, as trace columns name them.
struct PlaneAxes {
  char first;
  char second;
  char normal;
};

PlaneAxes plane_axes(Plane plane) noexcept;
std::string_view plane_name(Plane plane) noexcept;        // "XY", "YZ", "ZX"
int plane_gcode(Plane plane) noexcept;                    // 17, 19, 18
std::optional<Plane> parse_plane(std::string_view text);  // case-insensitive "XY" | "YZ" | "ZX"
// A test set's planes in program order ("XY,YZ,ZX", the trace's `plane` metadata of a set):
// one or more planes separated by commas, blanks around them allowed, none twice; nullopt
// for anything else (an empty item, an unknown plane, a repeated one).
std::optional<std::vector<Plane>> parse_plane_list(std::string_view text);

std::string_view direction_name(Direction direction) noexcept;  // "CCW", "CW"
std::optional<Direction> parse_direction(std::string_view text);

// Clause 3.7 label: the axes in the order of motion, from the positive part of the first
// toward the positive part of the second. XY plane: CCW -> "XY", CW -> "YX".
std::string direction_label(Plane plane, Direction direction);

}  // namespace circtest
