// Every circgen variant through LinuxCNC's real interpreter (rs274 -g): the canonical calls
// it prints are checked against geometry computed here from the variant's own numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "circtest/core/plane.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

struct Variant {
  std::string name;
  std::vector<std::string> args;
  Plane plane;
  double radius;                 // program units
  std::array<double, 3> centre;  // program units
  std::vector<double> feeds;     // program units per minute
  std::vector<Direction> directions;
  double arc_deg = 360.0;
  double start_deg = 0.0;
  double lead_deg = 10.0;
  std::string units = "mm";
  int marker = 0;
  int segment = 0;
};

const Direction CCW = Direction::CCW;
const Direction CW = Direction::CW;

std::vector<Variant> variants() {
  return {
      {"default_xy", {"--d", "150", "--f", "300"}, Plane::XY, 75, {0, 0, 0}, {300}, {CCW, CW}},
      {"xy_ccw_centre_start_safe",
       {"--d", "80", "--f", "1000", "--dir", "ccw", "--centre", "10,-20,5", "--start", "30",
        "--safe-z", "50"},
       Plane::XY,
       40,
       {10, -20, 5},
       {1000},
       {CCW},
       360,
       30},
      {"xy_cw", {"--f", "600", "--dir", "cw", "--r", "50"}, Plane::XY, 50, {0, 0, 0}, {600}, {CW}},
      {"yz_both",
       {"--plane", "YZ", "--d", "100", "--f", "500", "--centre", "0,50,-30"},
       Plane::YZ,
       50,
       {0, 50, -30},
       {500},
       {CCW, CW}},
      {"zx_both_safe",
       {"--plane", "ZX", "--d", "100", "--f", "500", "--centre", "5,0,-40", "--safe-z", "20"},
       Plane::ZX,
       50,
       {5, 0, -40},
       {500},
       {CCW, CW}},
      {"zx_partial_180",
       {"--plane", "zx", "--d", "120", "--f", "400", "--arc", "180", "--lead", "20"},
       Plane::ZX,
       60,
       {0, 0, 0},
       {400},
       {CCW, CW},
       180,
       0,
       20},
      {"yz_partial_90_cw_sweep",
       {"--plane", "YZ", "--d", "100", "--arc", "90", "--start", "45", "--dir", "cw", "--feeds",
        "100,200"},
       Plane::YZ,
       50,
       {0, 0, 0},
       {100, 200},
       {CW},
       90,
       45},
      {"xy_sweep_dwell",
       {"--d", "50", "--feeds", "200,500,1000", "--lead", "30", "--dwell", "0.2"},
       Plane::XY,
       25,
       {0, 0, 0},
       {200, 500, 1000},
       {CCW, CW},
       360,
       0,
       30},
      {"xy_partial_270_ccw_sweep_outputs",
       {"--d", "60", "--arc", "270", "--start", "90", "--dir", "ccw", "--feeds", "300,600",
        "--marker", "2", "--segment-out", "3"},
       Plane::XY,
       30,
       {0, 0, 0},
       {300, 600},
       {CCW},
       270,
       90,
       10,
       "mm",
       2,
       3},
      {"inch",
       {"--inch", "--d", "4", "--f", "20", "--centre", "1,2,0.5", "--safe-z", "1.5"},
       Plane::XY,
       2,
       {1, 2, 0.5},
       {20},
       {CCW, CW},
       360,
       0,
       10,
       "inch"},
      {"inch_zx_partial",
       {"--inch", "--plane", "ZX", "--d", "3", "--f", "15", "--arc", "120", "--start", "-30"},
       Plane::ZX,
       1.5,
       {0, 0, 0},
       {15},
       {CCW, CW},
       120,
       330,
       10,
       "inch"},
      {"annex_c",
       {"--d", "125", "--ref-d", "100", "--ref-f", "500"},
       Plane::XY,
       62.5,
       {0, 0, 0},
       {559},
       {CCW, CW}},
  };
}

double wrap360(double deg) {
  double r = std::fmod(deg, 360.0);
  if (r < 0) r += 360.0;
  return r;
}

double angle_diff(double a, double b) {
  const double d = wrap360(a - b);
  return std::min(d, 360.0 - d);
}

class gcode_Rs274Variant : public ::testing::TestWithParam<Variant> {};

TEST_P(gcode_Rs274Variant, InterpreterAcceptsAndArcsMatchTheTest) {
  if (!rs274_available()) GTEST_SKIP() << "rs274 not installed (linuxcnc-uspace)";
  const Variant& v = GetParam();
  const CommandResult gen = run_circgen(v.args);
  ASSERT_EQ(gen.exit_code, 0) << gen.err;
  ASSERT_TRUE(gen.err.empty()) << gen.err;
  const Rs274Result rs = run_rs274(gen.out);
  ASSERT_EQ(rs.exit_code, 0) << rs.output << "\n" << gen.out;
  const CanonProgram& canon = rs.canon;
  ASSERT_TRUE(canon.ended);
  EXPECT_EQ(canon.units, v.units);

  const double tol = v.units == "mm" ? 2e-3 : 1e-4;  // a few units of the last written digit
  const PlaneAxes axes = plane_axes(v.plane);

  // The runs the test asks for, in order: for each feed, the directions as given.
  struct Expected {
    Direction direction;
    double feed;
  };
  std::vector<Expected> expected;
  for (double f : v.feeds)
    for (Direction d : v.directions) expected.push_back({d, f});

  std::vector<std::size_t> measured;
  for (std::size_t i = 0; i < canon.motions.size(); ++i) {
    const auto it = canon.motions[i].bits.find(v.marker);
    if (it != canon.motions[i].bits.end() && it->second) measured.push_back(i);
  }
  ASSERT_EQ(measured.size(), expected.size());
  const auto count = [&](const std::string& call) {
    return std::count(canon.calls.begin(), canon.calls.end(), call);
  };
  EXPECT_EQ(count("SET_MOTION_OUTPUT_BIT"), static_cast<long>(expected.size()));
  EXPECT_EQ(count("CLEAR_MOTION_OUTPUT_BIT"), static_cast<long>(expected.size()));

  for (std::size_t k = 0; k < measured.size(); ++k) {
    SCOPED_TRACE("measured run " + std::to_string(k + 1));
    const std::size_t i = measured[k];
    const CanonMotion& m = canon.motions[i];
    ASSERT_EQ(m.kind, CanonMotion::arc) << "canon line " << m.source_line;
    // The interpreter's rotation sense is about (first, second); core's CCW goes from the
    // plane's first axis toward its second, so they must be the same pair.
    EXPECT_EQ(m.first, axes.first);
    EXPECT_EQ(m.second, axes.second);
    EXPECT_NEAR(m.radius_start(), v.radius, tol);
    EXPECT_NEAR(m.radius_end(), v.radius, tol);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(m.centre[a], v.centre[a], tol);
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(m.start[axes.normal - 'x'], v.centre[axes.normal - 'x'], tol);
    EXPECT_NEAR(m.feed, expected[k].feed, 1e-9);
    const double sign = expected[k].direction == Direction::CCW ? 1.0 : -1.0;
    EXPECT_NEAR(m.sweep_deg(), sign * v.arc_deg, 0.01);
    const double start =
        expected[k].direction == Direction::CCW ? v.start_deg : v.start_deg + v.arc_deg;
    EXPECT_LT(angle_diff(m.start_angle_deg(), start), 0.01);
    EXPECT_NEAR(m.values.at(v.segment), static_cast<double>(k + 1), 1e-9);

    // The marker is set exactly around this arc: off on the moves before and after, and
    // those are the lead arcs, tangent and in the same sense, so the feed is reached.
    ASSERT_GT(i, 0u);
    ASSERT_LT(i + 1, canon.motions.size());
    for (const CanonMotion* lead : {&canon.motions[i - 1], &canon.motions[i + 1]}) {
      EXPECT_FALSE(lead->bits.at(v.marker)) << "canon line " << lead->source_line;
      EXPECT_NEAR(lead->values.at(v.segment), 0.0, 1e-9);
      ASSERT_EQ(lead->kind, CanonMotion::arc);
      EXPECT_NEAR(lead->sweep_deg(), sign * v.lead_deg, 0.01);
      EXPECT_NEAR(lead->radius_start(), v.radius, tol);
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(lead->centre[a], v.centre[a], tol);
    }
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(canon.motions[i - 1].end[a], m.start[a], 1e-9);
      EXPECT_NEAR(canon.motions[i + 1].start[a], m.end[a], 1e-9);
    }
  }

  // Outside the measured arcs the id is 0 and the marker off; every arc stays on the test
  // circle and, for a partial arc, inside the lead-extended range (away from what made the
  // arc partial).
  const double range_low = v.start_deg - v.lead_deg;
  const double range_high = v.start_deg + v.arc_deg + v.lead_deg;
  for (std::size_t i = 0; i < canon.motions.size(); ++i) {
    const CanonMotion& m = canon.motions[i];
    if (std::find(measured.begin(), measured.end(), i) == measured.end()) {
      EXPECT_FALSE(m.bits.count(v.marker) && m.bits.at(v.marker)) << m.source_line;
      EXPECT_TRUE(!m.values.count(v.segment) || m.values.at(v.segment) == 0.0) << m.source_line;
    }
    if (m.kind != CanonMotion::arc) continue;
    EXPECT_NEAR(m.radius_start(), v.radius, tol) << m.source_line;
    EXPECT_NEAR(m.radius_end(), v.radius, tol) << m.source_line;
    if (v.arc_deg < 360.0) {
      const double s = m.start_angle_deg();
      const double e = s + m.sweep_deg();
      for (double a : {s, e, (s + e) / 2}) {
        const double rel = wrap360(a - range_low + 0.005) - 0.005;
        EXPECT_LE(rel, range_high - range_low + 0.01) << "canon line " << m.source_line;
      }
      EXPECT_LE(std::abs(m.sweep_deg()), range_high - range_low + 0.01);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Variants, gcode_Rs274Variant, ::testing::ValuesIn(variants()),
                         [](const ::testing::TestParamInfo<Variant>& p) { return p.param.name; });

// The acceptance case, spelled out.
TEST(gcode_Rs274Default, CcwThenCwFullCircleOfRadius75AtF300) {
  if (!rs274_available()) GTEST_SKIP() << "rs274 not installed (linuxcnc-uspace)";
  const CommandResult gen = run_circgen({"--d", "150", "--f", "300"});
  ASSERT_EQ(gen.exit_code, 0);
  const Rs274Result rs = run_rs274(gen.out);
  ASSERT_EQ(rs.exit_code, 0) << rs.output;
  std::vector<CanonMotion> marked;
  for (const auto& m : rs.canon.motions)
    if (m.bits.count(0) && m.bits.at(0)) marked.push_back(m);
  ASSERT_EQ(marked.size(), 2u);
  EXPECT_EQ(marked[0].rotation, 1);
  EXPECT_EQ(marked[1].rotation, -1);
  for (const auto& m : marked) {
    EXPECT_NEAR(m.radius_start(), 75.0, 1e-9);
    EXPECT_NEAR(std::abs(m.sweep_deg()), 360.0, 1e-9);
    EXPECT_DOUBLE_EQ(m.feed, 300.0);
  }
}

}  // namespace
}  // namespace circtest::testing
