// What a service engineer signs: every clause 6 item and 4.4 condition in the text report
// ("not recorded" when unknown), the channels evaluated named in every output, and a feed
// sweep reported per feed in the text and the plot.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <regex>
#include <string>

#include "circtest/analysis/plot.hpp"
#include "circtest/analysis/report.hpp"
#include "machine_sim.hpp"

using namespace circtest;

namespace {

// Two CCW/CW pairs at two feeds one after the other, as circgen's feed sweep records them.
Trace feed_sweep(double feed1, double feed2) {
  sim::MachineModel m;
  m.x.kv_per_s = 30.0;
  m.y.kv_per_s = 30.0;
  m.x.backlash_mm = 0.008;
  sim::CircleProgram p;
  p.radius_mm = 50.0;
  p.feed_mm_per_min = feed1;
  Trace t = sim::simulate(m, p);
  p.feed_mm_per_min = feed2;
  const Trace t2 = sim::simulate(m, p);
  const double t0 = t.column("t")->back() + 0.5;
  const std::size_t ti = t.column_index("t").value(), si = t.column_index("segment").value();
  std::uint32_t line = t.line_of_row.back();
  for (std::size_t r = 0; r < t2.rows(); ++r) {
    for (std::size_t c = 0; c < t.columns.size(); ++c) {
      double v = t2.values[c][r];
      if (c == ti) v += t0;
      if (c == si && v != 0) v += 2;
      t.values[c].push_back(v);
    }
    t.line_of_row.push_back(++line);
  }
  return t;
}

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (auto p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

}  // namespace

TEST(ReportConditions, EveryClause6ItemIsPrintedAndUnknownOnesSaySo) {
  Trace trace = sim::simulate({}, {});
  trace.metadata.set("instrument", "grid encoder KGM 182, SN 77");
  trace.metadata.set("channel.x", "table X, grid encoder");
  trace.metadata.set("tool_length_mm", "120");  // an unknown key is shown as it is
  EvaluationOptions o;
  o.conditions = {{"machine", "VMC-3"}, {"operator", "A. Sato"}, {"instrument", "ballbar QC20"}};
  const Evaluation ev = evaluate(trace, o);
  const std::string text = text_report(ev);
  auto line = [&text](const std::string& title) {
    const auto p = text.find("  " + title + ":");
    EXPECT_NE(p, std::string::npos) << title << " missing in\n" << text;
    if (p == std::string::npos) return std::string();
    const auto colon = text.find(':', p);
    const auto eol = text.find('\n', p);
    const auto b = text.find_first_not_of(' ', colon + 1);
    return text.substr(b, eol - b);
  };
  EXPECT_EQ(line("Machine"), "VMC-3");
  EXPECT_EQ(line("Operator"), "A. Sato");
  EXPECT_EQ(line("Instrument"), "ballbar QC20");  // the option overrides the trace
  EXPECT_EQ(line("Date"), "not recorded");
  EXPECT_EQ(line("Machine serial"), "not recorded");
  EXPECT_EQ(line("Location"), "not recorded");
  EXPECT_EQ(line("Notes"), "not recorded");
  EXPECT_EQ(line("Channels evaluated"), "x, y (x: table X, grid encoder)");
  EXPECT_EQ(line("Machine temperature"), "not recorded");
  EXPECT_EQ(line("Instrument temperature"), "not recorded");
  EXPECT_EQ(line("Air temperature"), "not recorded");
  EXPECT_EQ(line("Compensations in use"), "not recorded");
  EXPECT_EQ(line("Axes not under test"), "not recorded");
  EXPECT_EQ(line("Tool-side offset (mm)"), "not recorded");
  EXPECT_EQ(line("Workpiece-side offset (mm)"), "not recorded");
  EXPECT_EQ(line("Diameter"), "150.0000 mm (radius 75.0000 mm, from metadata)");
  EXPECT_EQ(line("Axes"), "X, Y (plane XY)");
  EXPECT_EQ(line("tool_length_mm"), "120");
  EXPECT_EQ(count(text, "  Instrument:"), 1u);

  const auto j = to_json(ev);
  EXPECT_EQ(j["channels"], nlohmann::ordered_json::array({"x", "y"}));
  EXPECT_EQ(j["conditions"]["instrument"], "ballbar QC20");
  EXPECT_EQ(j["conditions"]["machine"], "VMC-3");
}

TEST(ReportConditions, TheChannelsEvaluatedAreNamedInEveryOutput) {
  const Trace trace = sim::simulate({}, {});
  EvaluationOptions o;
  o.column_a = "x_cmd";
  o.column_b = "y_cmd";
  const Evaluation ev = evaluate(trace, o);
  EXPECT_NE(text_report(ev).find("Channels evaluated:         x_cmd, y_cmd\n"), std::string::npos);
  EXPECT_EQ(to_json(ev)["channels"], nlohmann::ordered_json::array({"x_cmd", "y_cmd"}));
  EXPECT_NE(svg_plot(ev, trace).find("channels evaluated x_cmd, y_cmd"), std::string::npos);
}

TEST(ReportConditions, AFeedSweepReportsEachHWithItsFeedAndThePlotKeepsEveryRun) {
  const Trace trace = feed_sweep(500.0, 2000.0);
  const Evaluation ev = evaluate(trace, {});
  ASSERT_EQ(ev.runs.size(), 4u);
  ASSERT_EQ(ev.hysteresis.size(), 2u);
  const std::string text = text_report(ev);
  // The feeds are measured from the time column: the simulator's are exact to 0.5 %.
  std::smatch m;
  const std::regex h_line(R"(H_XY = [0-9.]+ um  at ([0-9]+) mm/min)");
  std::vector<double> feeds;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), h_line);
       it != std::sregex_iterator(); ++it) {
    feeds.push_back(std::stod((*it)[1]));
  }
  ASSERT_EQ(feeds.size(), 2u) << text;
  EXPECT_NEAR(feeds[0], 500.0, 2.5);
  EXPECT_NEAR(feeds[1], 2000.0, 10.0);

  const std::string svg = svg_plot(ev, trace);
  EXPECT_EQ(count(svg, "class=\"run\""), 4u);
  EXPECT_EQ(count(svg, "<circle class=\"start\""), 4u);
  EXPECT_EQ(count(svg, "class=\"direction\""), 4u);
  for (int run = 1; run <= 4; ++run) {
    EXPECT_NE(svg.find(fmt::format(">run {} ", run)), std::string::npos) << run;
  }
  EXPECT_EQ(count(svg, ">H_XY = "), 2u);
  // Every legend line lies inside the drawing.
  ASSERT_TRUE(std::regex_search(svg, m, std::regex(R"re(height="([0-9.]+)")re")));
  const double height = std::stod(m[1]);
  double last_y = 0;
  const std::regex y_attr(R"re(class="legend" x="10" y="([0-9.]+)")re");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), y_attr); it != std::sregex_iterator();
       ++it) {
    last_y = std::max(last_y, std::stod((*it)[1]));
  }
  EXPECT_GT(last_y, 0);
  EXPECT_LT(last_y, height);
}

TEST(ReportConditions, AFixedScaleIsUsedAndStated) {
  const Trace trace = sim::simulate({}, {});
  const Evaluation ev = evaluate(trace, {});
  PlotOptions po;
  po.mm_per_division = 0.005;
  const std::string svg = svg_plot(ev, trace, po);
  EXPECT_NE(svg.find("1 division = 5 um (fixed)"), std::string::npos);
  // Ring j of the grid sits j divisions from the reference circle: 0.15 size / 4 px each.
  const double ring = 0.30 * po.size_px, div_px = 0.15 * po.size_px / 4;
  EXPECT_NE(svg.find(fmt::format("r=\"{:.2f}\"", ring + div_px)), std::string::npos);
}
