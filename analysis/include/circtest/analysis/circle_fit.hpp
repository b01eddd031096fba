#pragma once
// Circle fits on planar point sets: least-squares (LSC), minimum zone (MZC), minimum
// circumscribed (MCC) and maximum inscribed (MIC). Coordinates in mm; (a, b) are the two
// plane axes in clause 3.7 order. Numerically robust for small relative deviations
// (1e-7 of the radius) and centres far from the origin.
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace circtest {

struct Circle {
  double centre_a_mm = 0.0;
  double centre_b_mm = 0.0;
  double radius_mm = 0.0;
};

struct RadialRange {
  double min_mm = 0.0;  // smallest distance of a point from the centre
  double max_mm = 0.0;  // largest distance
  double width_mm() const { return max_mm - min_mm; }
};

// Distances of all points from a centre: min and max.
RadialRange radial_range(std::span<const double> a, std::span<const double> b, double centre_a_mm,
                         double centre_b_mm);

// Geometric least-squares circle: minimises sum (|p_i - c| - r)^2 (Gauss-Newton / LM started
// from the algebraic fit). Needs at least 3 non-collinear points; throws circtest::Error
// (ExitCode::data) otherwise.
Circle fit_lsc(std::span<const double> a, std::span<const double> b);
// The LSC of two point sets together (two runs), without joining them into one copy; its
// passes over the points shared out over up to `threads` threads (the same result for any
// count).
Circle fit_lsc(std::span<const double> a1, std::span<const double> b1, std::span<const double> a2,
               std::span<const double> b2, unsigned threads = 1);

// Algebraic (Kasa) fit; exposed for tests and as the starting guess.
Circle fit_lsc_algebraic(std::span<const double> a, std::span<const double> b);

// Minimum-zone circles: the centre that minimises max|p_i - c| - min|p_i - c|.
struct MinimumZone {
  double centre_a_mm = 0.0;
  double centre_b_mm = 0.0;
  double inner_radius_mm = 0.0;
  double outer_radius_mm = 0.0;
  double zone_width_mm = 0.0;
  double mean_radius_mm() const { return 0.5 * (inner_radius_mm + outer_radius_mm); }
  // Certificate of optimality: the contact points (indices into the input) on the outer and
  // inner circle, at most 4 in all, for which the optimality condition holds: the outward unit
  // vectors of the outer contacts and the inward unit vectors of the inner contacts have the
  // origin in their convex hull (equivalently outer/inner contacts alternate around the
  // centre). `certified` is true only when that was checked on the final centre and every
  // input point lies within the zone (to a tolerance of 1e-12 of the radius, plus 4 machine
  // epsilons of the centre's largest coordinate: a small circle far from the origin cannot be
  // resolved finer). The multipliers put weight 1/2 on each side (outer weights sum to 1/2,
  // inner to 1/2), so sum outer w u - sum inner w u = 0 is the first-order condition. With
  // exactly three distinct points (zone 0) one point is both the outer and the inner contact.
  std::vector<std::size_t> outer_contacts;
  std::vector<std::size_t> inner_contacts;
  std::vector<double> multipliers;  // convex weights of the contacts (outer first, then inner)
  bool certified = false;
};
MinimumZone fit_mzc(std::span<const double> a, std::span<const double> b);

// Minimum circumscribed circle (smallest circle containing every point) and maximum
// inscribed circle (largest circle containing no point, centre inside the point cloud's
// hull); both with their contact point indices.
struct ContactCircle {
  Circle circle;
  std::vector<std::size_t> contacts;
};
ContactCircle fit_mcc(std::span<const double> a, std::span<const double> b);
// The MIC, or none when the points do not surround a centre: an arc of 180 deg or less is a
// normal test, not an error, so the answer is an optional with the reason beside it. Unusable
// input (fewer than 3 points, collinear) still throws DataError, as for the other fits.
struct MicFit {
  std::optional<ContactCircle> mic;
  std::string why_none;  // set when `mic` is empty
};
MicFit fit_mic(std::span<const double> a, std::span<const double> b);

}  // namespace circtest
