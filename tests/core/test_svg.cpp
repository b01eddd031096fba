// The shared SVG pieces: the exact text every plot's document starts with (the plots' own
// tests compare whole documents; these pin the pieces' form).
#include "circtest/core/svg.hpp"

#include <gtest/gtest.h>

#include <string>

using circtest::svg_add_point;
using circtest::svg_open;

TEST(Svg, OpenGivesTheSizeAsViewBoxAndTheFont) {
  EXPECT_EQ(svg_open(800, 612.5, 11, false),
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"800\" height=\"612.5\" "
            "viewBox=\"0 0 800 612.5\" font-family=\"sans-serif\" font-size=\"11\">\n");
  EXPECT_EQ(svg_open(640, 480, 12, true),
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"640\" height=\"480\" "
            "viewBox=\"0 0 640 480\" font-family=\"sans-serif\" font-size=\"12\">\n"
            "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
}

TEST(Svg, PointsAreAppendedToATenthOfAPixel) {
  std::string points;
  svg_add_point(points, 1.0, -2.25);
  svg_add_point(points, 123.456, 0.04);
  EXPECT_EQ(points, "1.0,-2.2 123.5,0.0 ");
}
