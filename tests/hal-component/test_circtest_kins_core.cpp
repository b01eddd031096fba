// circtest_kins' core against the analytic model x = jx + xy jy, y = jy + yz jz,
// z = jz + zx jx, and its inverse by an independent solver (Cramer's rule on the 3x3 matrix).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include "circtest_kins_core.hpp"

namespace kins = circtest::kins;

namespace {

kins::JointMap map_of(const char* coordinates) {
  kins::JointMap m;
  int bad = -1;
  EXPECT_EQ(kins::parse_coordinates(coordinates, m, &bad), kins::MapError::none) << coordinates;
  return m;
}

// The model as a matrix, solved by Cramer's rule: an inverse computed another way.
std::array<double, 3> solve_model(const kins::Squareness& s, std::array<double, 3> t) {
  const double m[3][3] = {{1, s.xy, 0}, {0, 1, s.yz}, {s.zx, 0, 1}};
  auto det = [](const double a[3][3]) {
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
           a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  };
  const double d = det(m);
  std::array<double, 3> out{};
  for (int c = 0; c < 3; ++c) {
    double k[3][3];
    for (int r = 0; r < 3; ++r) {
      for (int q = 0; q < 3; ++q) k[r][q] = q == c ? t[r] : m[r][q];
    }
    out[c] = det(k) / d;
  }
  return out;
}

TEST(CircTestKinsCore, CoordinatesMapLikeTrivkins) {
  const kins::JointMap m = map_of("XYZ");
  EXPECT_EQ(m.joints, 3);
  EXPECT_EQ(m.principal_joint[0], 0);
  EXPECT_EQ(m.principal_joint[1], 1);
  EXPECT_EQ(m.principal_joint[2], 2);
  EXPECT_EQ(m.principal_joint[3], -1);

  const kins::JointMap g = map_of("x y yz");  // gantry, blanks and lower case as trivkins
  EXPECT_EQ(g.joints, 4);
  EXPECT_EQ(g.principal_joint[1], 1);
  EXPECT_EQ(g.axis_of_joint[2], 1);
  EXPECT_EQ(g.axis_of_joint[3], 2);

  kins::JointMap bad;
  int at = -1;
  EXPECT_EQ(kins::parse_coordinates("XYQ", bad, &at), kins::MapError::bad_letter);
  EXPECT_EQ(at, 2);
  EXPECT_EQ(kins::parse_coordinates("", bad, &at), kins::MapError::empty);
  EXPECT_EQ(kins::parse_coordinates("XXXXXXXXXXXXXXXXX", bad, &at),
            kins::MapError::too_many_joints);
}

TEST(CircTestKinsCore, ForwardIsTheModel) {
  const kins::JointMap m = map_of("XYZ");
  const kins::Squareness s{100e-6, -40e-6, 250e-6};
  const double j[3] = {120.0, -75.5, 33.25};
  kins::World w;
  kins::forward(s, m, j, w);
  EXPECT_DOUBLE_EQ(w.axis[0], 120.0 + 100e-6 * -75.5);
  EXPECT_DOUBLE_EQ(w.axis[1], -75.5 + -40e-6 * 33.25);
  EXPECT_DOUBLE_EQ(w.axis[2], 33.25 + 250e-6 * 120.0);
}

TEST(CircTestKinsCore, InverseAgreesWithCramerAndRoundTripsOverTheVolume) {
  const kins::JointMap m = map_of("XYZ");
  std::mt19937_64 rng(10);
  std::uniform_real_distribution<double> pos(-1000.0, 1000.0);
  std::uniform_real_distribution<double> ang(-kins::kMaxSquarenessRad, kins::kMaxSquarenessRad);
  double worst_cramer = 0, worst_round = 0;
  for (int i = 0; i < 20000; ++i) {
    const kins::Squareness s{ang(rng), ang(rng), ang(rng)};
    kins::World w;
    for (double& a : w.axis) a = pos(rng);
    double j[3];
    kins::inverse(s, m, w, j);
    const auto ref = solve_model(s, {w.axis[0], w.axis[1], w.axis[2]});
    for (int k = 0; k < 3; ++k) worst_cramer = std::max(worst_cramer, std::fabs(j[k] - ref[k]));
    kins::World back = w;
    for (int k = 0; k < 3; ++k) back.axis[k] = 1e9;  // must be overwritten
    kins::forward(s, m, j, back);
    for (int k = 0; k < 3; ++k) {
      worst_round = std::max(worst_round, std::fabs(back.axis[k] - w.axis[k]));
    }
    // Joints -> world -> joints as well.
    double j2[3];
    kins::inverse(s, m, back, j2);
    for (int k = 0; k < 3; ++k) worst_round = std::max(worst_round, std::fabs(j2[k] - j[k]));
  }
  EXPECT_LT(worst_cramer, 1e-9);  // Cramer's determinants lose a few digits themselves
  EXPECT_LT(worst_round, 1e-12);  // mm, over +-1000 mm
}

TEST(CircTestKinsCore, CompensatesTheSimulatedMachine) {
  // The simulated mill puts the table at M * slides; commanding through inverse() must land
  // the table on the commanded point (what the e2e test shows in LinuxCNC).
  const kins::JointMap m = map_of("XYZ");
  const kins::Squareness s{100e-6, 0, 0};
  kins::World cmd;
  cmd.axis[0] = 75.0;
  cmd.axis[1] = 75.0;
  double j[3];
  kins::inverse(s, m, cmd, j);
  const double table_x = j[0] + 100e-6 * j[1];
  EXPECT_NEAR(table_x, 75.0, 1e-13);
  EXPECT_NEAR(j[0], 75.0 - 100e-6 * 75.0, 1e-13);
}

TEST(CircTestKinsCore, GantryJointsAllFollowTheirAxis) {
  const kins::JointMap m = map_of("XYYZ");
  const kins::Squareness s{1e-3, 2e-4, -3e-4};
  kins::World w;
  w.axis[0] = 10;
  w.axis[1] = 20;
  w.axis[2] = -30;
  double j[4];
  kins::inverse(s, m, w, j);
  EXPECT_EQ(j[1], j[2]);
  kins::World back;
  kins::forward(s, m, j, back);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(back.axis[k], w.axis[k], 1e-12);
}

TEST(CircTestKinsCore, UnmappedAxesDropTheirTermsAndKeepTheirWorldValue) {
  const kins::JointMap m = map_of("XZ");  // a lathe: only zx can act
  const kins::Squareness s{5e-3, 5e-3, 1e-4};
  const kins::Squareness e = kins::effective(s, m);
  EXPECT_EQ(e.xy, 0.0);
  EXPECT_EQ(e.yz, 0.0);
  EXPECT_EQ(e.zx, 1e-4);
  kins::World w;
  w.axis[0] = 40;
  w.axis[1] = 123;  // no Y joint: its world value never enters
  w.axis[2] = -60;
  double j[2];
  kins::inverse(s, m, w, j);
  EXPECT_DOUBLE_EQ(j[0], 40.0);
  EXPECT_DOUBLE_EQ(j[1], -60.0 - 1e-4 * 40.0);
  kins::World back;
  back.axis[1] = 7.0;
  kins::forward(s, m, j, back);
  EXPECT_NEAR(back.axis[0], 40.0, 1e-12);
  EXPECT_EQ(back.axis[1], 7.0);
  EXPECT_NEAR(back.axis[2], -60.0, 1e-12);
}

TEST(CircTestKinsCore, ImplausibleAnglesAreReplacedByZero) {
  bool rejected = false;
  kins::Squareness s = kins::sanitized({1e-4, std::nan(""), 0.02}, &rejected);
  EXPECT_TRUE(rejected);
  EXPECT_EQ(s.xy, 1e-4);
  EXPECT_EQ(s.yz, 0.0);
  EXPECT_EQ(s.zx, 0.0);
  s = kins::sanitized({1e-4, -1e-2, 0}, &rejected);
  EXPECT_FALSE(rejected);
  EXPECT_EQ(s.yz, -1e-2);
}

}  // namespace
