#pragma once
// The pieces of a standalone SVG document that every plot writes (analysis: the polar plot
// and the report's diagnosis bars; history: the trend), once, so that they stay alike.
#include <string>

namespace circtest {

// The opening <svg> element: WIDTH_PX x HEIGHT_PX, the same as its viewBox, sans-serif at
// FONT_SIZE_PX, followed, when WHITE_BACKGROUND, by a white rectangle over the whole document
// (a plot opened on its own, not inside a page). Sizes in fmt's shortest form ("800", "612.5").
std::string svg_open(double width_px, double height_px, int font_size_px, bool white_background);

// Appends "X,Y " (to 0.1 px) to the points of a <polyline> or <polygon>.
void svg_add_point(std::string& points, double x_px, double y_px);

}  // namespace circtest
