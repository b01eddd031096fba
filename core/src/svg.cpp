#include "circtest/core/svg.hpp"

#include <fmt/format.h>

#include <iterator>

namespace circtest {

std::string svg_open(double width_px, double height_px, int font_size_px, bool white_background) {
  std::string s = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" "
      "viewBox=\"0 0 {0} {1}\" font-family=\"sans-serif\" font-size=\"{2}\">\n",
      width_px, height_px, font_size_px);
  if (white_background) s += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  return s;
}

void svg_add_point(std::string& points, double x_px, double y_px) {
  fmt::format_to(std::back_inserter(points), "{:.1f},{:.1f} ", x_px, y_px);
}

}  // namespace circtest
