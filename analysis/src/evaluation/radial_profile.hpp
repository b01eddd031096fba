#pragma once
// Internal: a path's radius as a function of its angle about a centre. The evaluation's H
// and the diagnosis both unwrap the measured angle along a run; this unit is the one copy.
#include <cmath>
#include <cstddef>
#include <span>
#include <vector>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/plane.hpp"

namespace circtest::detail {

// atan(t) by its series to the 11th power: exact in double precision for |t| below
// kAtanSeriesMax (the next term is below 2e-17 of the result) and several times cheaper than
// atan2. Branch-free, so loops over samples vectorise.
inline constexpr double kAtanSeriesMax = 0.05;
inline double atan_series(double t) {
  const double t2 = t * t;
  return t *
         (1.0 - t2 * (1.0 / 3.0 -
                      t2 * (1.0 / 5.0 - t2 * (1.0 / 7.0 - t2 * (1.0 / 9.0 - t2 * (1.0 / 11.0))))));
}

// The signed angle (rad) between two vectors from their cross and dot products: the series
// where it is exact (successive samples, a following lag), else atan2.
inline bool in_series_range(double cross, double dot) {
  return dot > 0.0 && std::abs(cross) < kAtanSeriesMax * dot;
}
inline double turn_angle(double cross, double dot) {
  if (in_series_range(cross, dot)) return atan_series(cross / dot);
  return std::atan2(cross, dot);
}

// Samples whose turn angles are worked out at once (a few pages of stack, in cache).
inline constexpr std::size_t kTurnBlock = 1024;

// out[k] = turn_angle of the vectors from (ca, cb) to samples k and k + 1, for k < count (a
// and b hold count + 1 samples). The same arithmetic as turn_angle on each pair, so the same
// values to the bit; done in two passes so that the first, the series for every pair, is
// vectorised: the few pairs outside the series' range (a gap, a path through the centre) are
// taken again with atan2.
void turn_angles(const double* a, const double* b, double ca, double cb, std::size_t count,
                 double* out);

// Angle about `centre`, unwrapped along the path (successive samples are far less than pi
// apart), and radius; in path order, into arrays the caller holds (a.size() values each).
void path_polar_into(std::span<const double> a, std::span<const double> b, PlanePoint centre,
                     double* angle_rad, double* radius_mm);

// The same samples ordered by increasing angle, the first in [-pi, pi) (a CW path is
// reversed; a path that backs up locally, noise at a reversal, is sorted, equal angles kept
// in path order).
struct AngleRadius {
  double angle_rad;
  double radius_mm;
};
struct RadialProfile {
  std::vector<AngleRadius> points;
  std::size_t size() const { return points.size(); }
};
RadialProfile radial_profile(std::span<const double> a, std::span<const double> b,
                             PlanePoint centre);

// The largest |r_from - r_ref| with r_ref linearly interpolated in angle at each sample of
// `from` that falls inside ref's arc (angles taken modulo 2 pi into it), and the angular
// range those samples cover.
struct ProfileDifference {
  double max_mm = -1.0;
  double at_rad = 0.0;
  double lo_rad = 0.0, hi_rad = 0.0;
  bool any = false;
};
ProfileDifference compare_profiles(const RadialProfile& ref, const RadialProfile& from);

// Both ways round (side by side on up to `threads` threads): the largest difference of the
// two, where it is, and the overlap.
RadialDifference radial_difference(const RadialProfile& p1, const RadialProfile& p2,
                                   unsigned threads = 1);

}  // namespace circtest::detail
