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

// The diagnosis panel: every identified source with its value, one bar per contribution in
// rank order with lengths in proportion to their G, and the plot itself unchanged beside it.
TEST(Plot, DiagnosisPanelListsTheSourcesAndScalesTheBars) {
  sim::MachineModel m;
  m.x.backlash_mm = 0.012;
  m.x.kv_per_s = 30;
  m.y.kv_per_s = 33;
  m.squareness_rad = 60e-6;
  sim::CircleProgram p;
  p.start_deg = 45.0;
  const Trace trace = sim::simulate(m, p);
  const Evaluation ev = evaluate(trace, {});
  const Diagnosis d = diagnose(trace, ev);
  PlotOptions po;
  const std::string plain = svg_plot(ev, trace, po);
  po.diagnosis = &d;
  const std::string svg = svg_plot(ev, trace, po);
  EXPECT_EQ(plain.find("class=\"diagnosis\""), std::string::npos);
  ASSERT_NE(svg.find("class=\"diagnosis\""), std::string::npos);
  EXPECT_NE(svg.find("X backlash 12.0 um (+ end 12.0, - end 12.0)"), std::string::npos) << svg;
  EXPECT_NE(svg.find("squareness +60.0 urad"), std::string::npos);
  EXPECT_NE(svg.find("servo mismatch: X lags Y by 3.03"), std::string::npos);
  // The polar plot's paths are the same with and without the panel.
  auto polylines = [](const std::string& s) {
    // Plain search: std::regex recurses per character and overflows the stack on a path.
    std::string all;
    for (std::size_t at = s.find("<polyline"); at != std::string::npos;
         at = s.find("<polyline", at + 1)) {
      all += s.substr(at, s.find("/>", at) - at);
    }
    return all;
  };
  EXPECT_EQ(polylines(svg), polylines(plain));
  // Bars: one per contribution, ranked, widths in proportion to G.
  std::vector<double> widths;
  const std::string rect = "<rect class=\"contribution\"";
  for (std::size_t at = svg.find(rect); at != std::string::npos; at = svg.find(rect, at + 1)) {
    const std::size_t w = svg.find("width=\"", at) + 7;
    widths.push_back(std::stod(svg.substr(w, svg.find('"', w) - w)));
  }
  ASSERT_EQ(widths.size(), d.contributions.size());
  ASSERT_GE(widths.size(), 3u);
  for (std::size_t k = 1; k < widths.size(); ++k) {
    EXPECT_LE(widths[k], widths[k - 1]);
    EXPECT_NEAR(widths[k] / widths[0], d.contributions[k].g_mm / d.contributions[0].g_mm, 0.01);
  }
}
