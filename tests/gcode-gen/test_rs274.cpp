// Every circgen variant through LinuxCNC's real interpreter (rs274 -g): the canonical calls
// it prints are checked against geometry computed here from the variant's own numbers.
// The safe program structure: test_rs274_structure.cpp; test sets: test_rs274_set.cpp; the
// grid of leads and arcs: test_rs274_grid.cpp (one test program).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "circtest/core/plane.hpp"
#include "rs274_variants.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

TEST_P(Rs274Variant, InterpreterAcceptsAndArcsMatchTheTest) {
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
    // A ballbar goes back to the lead-in start of a sweep outside the circle, after its
    // feed-out; every other arc is on the test circle.
    const double r = std::abs(m.radius_start() - v.radius) > tol && is_ballbar(v)
                         ? v.radius + feed_in(v)
                         : v.radius;
    EXPECT_NEAR(m.radius_start(), r, tol) << m.source_line;
    EXPECT_NEAR(m.radius_end(), r, tol) << m.source_line;
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

INSTANTIATE_TEST_SUITE_P(Variants, Rs274Variant, ::testing::ValuesIn(variants()),
                         [](const ::testing::TestParamInfo<Variant>& p) { return p.param.name; });

// The acceptance case, spelled out.
TEST(Rs274Default, CcwThenCwFullCircleOfRadius75AtF300) {
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
