#include "circtest/core/plane.hpp"

#include <cctype>

namespace circtest {

namespace {
bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::toupper(static_cast<unsigned char>(a[i])) !=
        std::toupper(static_cast<unsigned char>(b[i])))
      return false;
  }
  return true;
}
}  // namespace

PlaneAxes plane_axes(Plane plane) noexcept {
  switch (plane) {
    case Plane::XY:
      return {'x', 'y', 'z'};
    case Plane::YZ:
      return {'y', 'z', 'x'};
    case Plane::ZX:
      return {'z', 'x', 'y'};
  }
  return {'x', 'y', 'z'};
}

std::string_view plane_name(Plane plane) noexcept {
  switch (plane) {
    case Plane::XY:
      return "XY";
    case Plane::YZ:
      return "YZ";
    case Plane::ZX:
      return "ZX";
  }
  return "XY";
}

int plane_gcode(Plane plane) noexcept {
  switch (plane) {
    case Plane::XY:
      return 17;
    case Plane::ZX:
      return 18;
    case Plane::YZ:
      return 19;
  }
  return 17;
}

std::optional<Plane> parse_plane(std::string_view text) {
  for (Plane p : {Plane::XY, Plane::YZ, Plane::ZX}) {
    if (iequals(text, plane_name(p))) return p;
  }
  return std::nullopt;
}

std::optional<std::vector<Plane>> parse_plane_list(std::string_view text) {
  std::vector<Plane> planes;
  std::size_t pos = 0;
  while (true) {
    const std::size_t comma = text.find(',', pos);
    std::string_view item =
        text.substr(pos, comma == std::string_view::npos ? text.npos : comma - pos);
    while (!item.empty() && (item.front() == ' ' || item.front() == '\t')) item.remove_prefix(1);
    while (!item.empty() && (item.back() == ' ' || item.back() == '\t')) item.remove_suffix(1);
    const std::optional<Plane> p = parse_plane(item);
    if (!p) return std::nullopt;
    for (Plane q : planes) {
      if (q == *p) return std::nullopt;
    }
    planes.push_back(*p);
    if (comma == std::string_view::npos) break;
    pos = comma + 1;
  }
  return planes;
}

std::string_view direction_name(Direction direction) noexcept {
  return direction == Direction::CCW ? "CCW" : "CW";
}

std::optional<Direction> parse_direction(std::string_view text) {
  if (iequals(text, "CCW")) return Direction::CCW;
  if (iequals(text, "CW")) return Direction::CW;
  return std::nullopt;
}

std::string direction_label(Plane plane, Direction direction) {
  const PlaneAxes axes = plane_axes(plane);
  const char first = static_cast<char>(std::toupper(static_cast<unsigned char>(axes.first)));
  const char second = static_cast<char>(std::toupper(static_cast<unsigned char>(axes.second)));
  return direction == Direction::CCW ? std::string{first, second} : std::string{second, first};
}

}  // namespace circtest
