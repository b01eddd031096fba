#pragma once
// Internals shared by the circle-fit translation units; not installed.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>

#include "circtest/analysis/circle_fit.hpp"

namespace circtest::fit_detail {

// Block length of the blocked compensated sums: long enough to keep the inner loops plain,
// short enough that the plain partial sums stay accurate.
inline constexpr std::size_t kBlock = 256;

// Certificate tolerance of the zone and contact fits, relative to the radius: a point within
// it of a circle is on it.
inline constexpr double kCertTol = 1e-12;

struct Vec2 {
  double x = 0.0;
  double y = 0.0;
};

// Neumaier's variant of Kahan summation: also exact when the addend is larger than the sum.
struct Neumaier {
  double sum = 0.0;
  double comp = 0.0;
  void add(double v) {
    const double t = sum + v;
    if (std::abs(sum) >= std::abs(v)) {
      comp += (sum - t) + v;
    } else {
      comp += (v - t) + sum;
    }
    sum = t;
  }
  double value() const { return sum + comp; }
};

// Throws DataError for arrays of different length or fewer than 3 points.
void check_points(std::span<const double> a, std::span<const double> b, const char* what);

// Compensated mean; throws DataError on non-finite coordinates.
Vec2 mean_point(const double* a, const double* b, std::size_t n);

// Algebraic (Kasa) circle with moments taken relative to `origin`; throws DataError when the
// points are collinear or coincident.
Circle kasa_about(const double* a, const double* b, std::size_t n, Vec2 origin);

}  // namespace circtest::fit_detail
