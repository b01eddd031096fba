#include "radial_profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include "circtest/analysis/evaluation.hpp"

namespace circtest::detail {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kRadToDeg = 180.0 / kPi;

double wrap_deg(double rad) {
  double d = std::fmod(rad * kRadToDeg, 360.0);
  if (d < 0) d += 360.0;
  return d;
}

}  // namespace

PathPolar path_polar(std::span<const double> a, std::span<const double> b, PlanePoint centre) {
  PathPolar p;
  const std::size_t n = a.size();
  p.angle_rad.resize(n);
  p.radius_mm.resize(n);
  double prev = 0.0;
  double offset = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double da = a[i] - centre.a_mm, db = b[i] - centre.b_mm;
    const double ang = std::atan2(db, da);
    if (i > 0) {
      // Unwrap along the path: successive samples are far less than pi apart.
      double step = ang + offset - prev;
      while (step > kPi) {
        offset -= 2 * kPi;
        step -= 2 * kPi;
      }
      while (step < -kPi) {
        offset += 2 * kPi;
        step += 2 * kPi;
      }
    }
    p.angle_rad[i] = ang + offset;
    p.radius_mm[i] = std::hypot(da, db);
    prev = p.angle_rad[i];
  }
  return p;
}

RadialProfile radial_profile(std::span<const double> a, std::span<const double> b,
                             PlanePoint centre) {
  PathPolar path = path_polar(a, b, centre);
  RadialProfile p{std::move(path.angle_rad), std::move(path.radius_mm)};
  const std::size_t n = p.size();
  if (n > 1 && p.angle_rad.back() < p.angle_rad.front()) {
    std::reverse(p.angle_rad.begin(), p.angle_rad.end());
    std::reverse(p.radius_mm.begin(), p.radius_mm.end());
  }
  if (!std::is_sorted(p.angle_rad.begin(), p.angle_rad.end())) {
    std::vector<std::size_t> idx(n);
    std::iota(idx.begin(), idx.end(), 0);
    std::stable_sort(idx.begin(), idx.end(),
                     [&](std::size_t i, std::size_t j) { return p.angle_rad[i] < p.angle_rad[j]; });
    RadialProfile q;
    q.angle_rad.resize(n);
    q.radius_mm.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      q.angle_rad[i] = p.angle_rad[idx[i]];
      q.radius_mm[i] = p.radius_mm[idx[i]];
    }
    p = std::move(q);
  }
  return p;
}

ProfileDifference compare_profiles(const RadialProfile& ref, const RadialProfile& from) {
  ProfileDifference w;
  const std::size_t n = ref.size();
  if (n < 2) return w;
  const double a0 = ref.angle_rad.front();
  const double a1 = ref.angle_rad.back();
  // `from` is sorted by angle, so its angles taken into ref's arc increase except where they
  // wrap by 2 pi: one forward merge per piece instead of a binary search per sample.
  std::size_t j = 0;  // first ref angle above phi
  double prev_phi = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < from.size(); ++i) {
    const double phi =
        a0 + std::fmod(std::fmod(from.angle_rad[i] - a0, 2 * kPi) + 2 * kPi, 2 * kPi);
    if (phi > a1) continue;  // outside the reference arc
    if (phi < prev_phi) {
      j = static_cast<std::size_t>(
          std::upper_bound(ref.angle_rad.begin(), ref.angle_rad.end(), phi) -
          ref.angle_rad.begin());
    } else {
      while (j < n && ref.angle_rad[j] <= phi) ++j;
    }
    prev_phi = phi;
    const std::size_t k = std::clamp<std::size_t>(j, 1, n - 1);
    const double x0 = ref.angle_rad[k - 1], x1 = ref.angle_rad[k];
    const double t = x1 > x0 ? (phi - x0) / (x1 - x0) : 0.0;
    const double r = ref.radius_mm[k - 1] + t * (ref.radius_mm[k] - ref.radius_mm[k - 1]);
    const double d = std::abs(from.radius_mm[i] - r);
    if (!w.any) {
      w.lo_rad = w.hi_rad = phi;
      w.any = true;
    }
    w.lo_rad = std::min(w.lo_rad, phi);
    w.hi_rad = std::max(w.hi_rad, phi);
    if (d > w.max_mm) {
      w.max_mm = d;
      w.at_rad = phi;
    }
  }
  return w;
}

RadialDifference radial_difference(const RadialProfile& p1, const RadialProfile& p2) {
  const ProfileDifference w12 = compare_profiles(p1, p2);
  const ProfileDifference w21 = compare_profiles(p2, p1);
  RadialDifference out;
  if (!w12.any && !w21.any) return out;
  const ProfileDifference& best = w12.max_mm >= w21.max_mm ? w12 : w21;
  out.max_mm = std::max(0.0, best.max_mm);
  out.at_angle_deg = wrap_deg(best.at_rad);
  const double o12 = w12.any ? w12.hi_rad - w12.lo_rad : 0.0;
  const double o21 = w21.any ? w21.hi_rad - w21.lo_rad : 0.0;
  out.overlap_deg = std::max(o12, o21) * kRadToDeg;
  return out;
}

}  // namespace circtest::detail

namespace circtest {

RadialDifference max_radial_difference(std::span<const double> a1, std::span<const double> b1,
                                       std::span<const double> a2, std::span<const double> b2,
                                       double centre_a_mm, double centre_b_mm) {
  const PlanePoint centre{centre_a_mm, centre_b_mm};
  return detail::radial_difference(detail::radial_profile(a1, b1, centre),
                                   detail::radial_profile(a2, b2, centre));
}

}  // namespace circtest
