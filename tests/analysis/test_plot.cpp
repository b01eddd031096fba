// The plot states its magnification truthfully and keeps the peaks of the path.
#include <gtest/gtest.h>

#include <cmath>
#include <regex>
#include <sstream>

#include "circtest/analysis/plot.hpp"
#include "machine_sim.hpp"

using namespace circtest;

TEST(Plot, DrawnDeviationsMatchThePathAtTheStatedScale) {
  sim::MachineModel m;
  m.x.backlash_mm = 0.012;
  m.squareness_rad = 60e-6;
  const Trace trace = sim::simulate(m, {});
  const Evaluation ev = evaluate(trace, {});
  PlotOptions po;
  const std::string svg = svg_plot(ev, trace, po);

  std::smatch mm;
  const std::string legend = svg.substr(svg.find("Deviations from"));
  ASSERT_TRUE(std::regex_search(legend, mm, std::regex(R"(radius ([0-9.]+) mm\))")));
  const double ref_radius = std::stod(mm[1]);
  ASSERT_TRUE(std::regex_search(
      legend, mm, std::regex(R"(magnified x([0-9]+): 1 division = ([0-9.e+-]+) um)")));
  const double magnification = std::stod(mm[1]);
  const double ring_px = 0.30 * po.size_px;
  const double px_per_mm = magnification * ring_px / ref_radius;

  // The largest deviation of the CCW run about the common centre, computed here.
  const Circle c = ev.hysteresis.front().common_lsc;
  const auto& x = *trace.column("x");
  const auto& y = *trace.column("y");
  double truth = 0.0;
  for (std::size_t i = ev.runs[0].run.begin; i < ev.runs[0].run.end; ++i) {
    truth = std::max(
        truth, std::abs(std::hypot(x[i] - c.centre_a_mm, y[i] - c.centre_b_mm) - c.radius_mm));
  }

  // (std::regex recurses per character: no use on a long attribute.)
  const std::string tag = "<polyline points=\"";
  const auto start = svg.find(tag);
  ASSERT_NE(start, std::string::npos);
  const auto stop = svg.find('"', start + tag.size());
  std::istringstream pts(svg.substr(start + tag.size(), stop - start - tag.size()));
  const double centre_px = po.size_px / 2.0;
  double drawn = 0.0;
  std::size_t n = 0;
  std::string pair;
  while (pts >> pair) {
    const auto comma = pair.find(',');
    const double px = std::stod(pair.substr(0, comma)), py = std::stod(pair.substr(comma + 1));
    const double dev_mm = (std::hypot(px - centre_px, py - centre_px) - ring_px) / px_per_mm;
    drawn = std::max(drawn, std::abs(dev_mm));
    ++n;
  }
  EXPECT_LE(n, po.max_points_per_run + 2);
  EXPECT_GT(n, po.max_points_per_run / 2);
  // 0.1 px of rounding in the SVG coordinates.
  EXPECT_NEAR(drawn, truth, 0.1 / px_per_mm + 0.002 * truth);
}
