#include <gtest/gtest.h>

#include "circtest/core/plane.hpp"

using namespace circtest;

TEST(Plane, LabelsFollowClause37) {
  EXPECT_EQ(direction_label(Plane::XY, Direction::CCW), "XY");
  EXPECT_EQ(direction_label(Plane::XY, Direction::CW), "YX");
  EXPECT_EQ(direction_label(Plane::YZ, Direction::CCW), "YZ");
  EXPECT_EQ(direction_label(Plane::YZ, Direction::CW), "ZY");
  EXPECT_EQ(direction_label(Plane::ZX, Direction::CCW), "ZX");
  EXPECT_EQ(direction_label(Plane::ZX, Direction::CW), "XZ");
}

TEST(Plane, GCodesAndParsing) {
  EXPECT_EQ(plane_gcode(Plane::XY), 17);
  EXPECT_EQ(plane_gcode(Plane::ZX), 18);
  EXPECT_EQ(plane_gcode(Plane::YZ), 19);
  EXPECT_EQ(parse_plane("zx"), Plane::ZX);
  EXPECT_FALSE(parse_plane("XZ").has_value());
  EXPECT_EQ(parse_direction("cw"), Direction::CW);
}
