// The polar form of a path (analysis/src/evaluation/radial_profile): angles taken by small steps
// between exact ones must match std::atan2 of every sample, unwrapped, in both directions, across
// the
// +-pi seam, through noise, dwells and gaps.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <numbers>
#include <random>
#include <vector>

#include "radial_profile.hpp"

using namespace circtest;

namespace {

constexpr double kPi = std::numbers::pi;
// Angles of up to a few turns: a few ulp of 4 pi.
constexpr double kAngleTol = 1e-13;

struct Path {
  std::vector<double> a, b;
};

// `turns` turns about (ca, cb) from `start_rad`, CCW for turns > 0, with Gaussian noise on
// the radius; `dwell` copies of every 5000th sample (a stop: identical positions).
Path circle(double ca, double cb, double r, double start_rad, double turns, std::size_t n,
            double noise_mm, std::size_t dwell = 0) {
  Path p;
  std::mt19937_64 rng(42);
  std::normal_distribution<double> gauss(0.0, noise_mm);
  for (std::size_t i = 0; i < n; ++i) {
    const double t =
        start_rad + 2 * kPi * turns * static_cast<double>(i) / static_cast<double>(n - 1);
    const double rr = r + (noise_mm > 0 ? gauss(rng) : 0.0);
    const std::size_t copies = (dwell > 0 && i % 5000 == 0) ? dwell + 1 : 1;
    for (std::size_t k = 0; k < copies; ++k) {
      p.a.push_back(ca + rr * std::cos(t));
      p.b.push_back(cb + rr * std::sin(t));
    }
  }
  return p;
}

// The truth: std::atan2 of every sample, each unwrapped against the one before.
std::vector<double> exact_angles(const Path& p, PlanePoint c) {
  std::vector<double> out;
  for (std::size_t i = 0; i < p.a.size(); ++i) {
    const double ang = std::atan2(p.b[i] - c.b_mm, p.a[i] - c.a_mm);
    out.push_back(i == 0 ? ang : out.back() + std::remainder(ang - out.back(), 2 * kPi));
  }
  return out;
}

struct Polar {
  std::vector<double> angle_rad;
  std::vector<double> radius_mm;
  std::size_t size() const { return angle_rad.size(); }
};

Polar polar_of(const Path& p, PlanePoint c) {
  Polar polar;
  polar.angle_rad.resize(p.a.size());
  polar.radius_mm.resize(p.a.size());
  detail::path_polar_into(p.a, p.b, c, polar.angle_rad.data(), polar.radius_mm.data());
  return polar;
}

double max_angle_error(const Path& p, PlanePoint c) {
  const Polar polar = polar_of(p, c);
  const std::vector<double> truth = exact_angles(p, c);
  EXPECT_EQ(polar.size(), truth.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    worst = std::max(worst, std::abs(polar.angle_rad[i] - truth[i]));
    const double r = std::sqrt(std::pow(p.a[i] - c.a_mm, 2) + std::pow(p.b[i] - c.b_mm, 2));
    EXPECT_NEAR(polar.radius_mm[i], r, 1e-12) << i;
  }
  return worst;
}

}  // namespace

TEST(PathPolar, CcwCircleAcrossTheSeamMatchesAtan2) {
  const PlanePoint c{12.5, -40.0};
  // Starts just below +pi: the seam is crossed at once, then twice more.
  const Path p = circle(c.a_mm, c.b_mm, 75.0, kPi - 1e-4, 2.2, 400'000, 0.0);
  EXPECT_LT(max_angle_error(p, c), kAngleTol);
  const Polar polar = polar_of(p, c);
  EXPECT_NEAR(polar.angle_rad.back() - polar.angle_rad.front(), 2 * kPi * 2.2, 1e-9);
}

TEST(PathPolar, CwNoisyCircleWithDwellsMatchesAtan2) {
  const PlanePoint c{-3.0, 7.0};
  const Path p = circle(c.a_mm, c.b_mm, 10.0, -kPi + 2e-4, -1.7, 300'000, 0.0005, 200);
  EXPECT_LT(max_angle_error(p, c), kAngleTol);
  const Polar polar = polar_of(p, c);
  EXPECT_NEAR(polar.angle_rad.back() - polar.angle_rad.front(), -2 * kPi * 1.7, 1e-3);
}

TEST(PathPolar, LargeStepsAndThePathNearTheCentreMatchAtan2) {
  // 500 samples per turn (steps of 0.7 degrees: beyond the series' range), and a centre
  // off the path's own where some samples pass within 0.01 mm of it.
  const PlanePoint c{0.0, 0.0};
  Path p = circle(0.0, 0.0, 50.0, 0.3, -3.0, 1500, 0.0);
  const Path q = circle(0.0, 0.01, 0.02, -1.0, 1.5, 2000, 0.0);
  p.a.insert(p.a.end(), q.a.begin(), q.a.end());
  p.b.insert(p.b.end(), q.b.begin(), q.b.end());
  EXPECT_LT(max_angle_error(p, c), kAngleTol);
}

TEST(RadialProfile, CwPathIsReversedAndItsAnglesMatchAtan2) {
  const PlanePoint c{1.0, 2.0};
  const Path p = circle(c.a_mm, c.b_mm, 30.0, 0.5, -1.0, 100'000, 0.0);
  const detail::RadialProfile prof = detail::radial_profile(p.a, p.b, c);
  const std::vector<double> truth = exact_angles(p, c);
  ASSERT_EQ(prof.size(), truth.size());
  double worst = 0.0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    worst = std::max(worst, std::abs(prof.points[k].angle_rad - truth[truth.size() - 1 - k]));
    if (k > 0) {
      EXPECT_LE(prof.points[k - 1].angle_rad, prof.points[k].angle_rad);
    }
  }
  EXPECT_LT(worst, kAngleTol);
}
