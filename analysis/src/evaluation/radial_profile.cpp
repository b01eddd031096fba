#include "radial_profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "angle_constants.hpp"
#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/memory.hpp"
#include "circtest/core/parallel.hpp"

namespace circtest::detail {

namespace {

using evaluation_detail::kPi;
using evaluation_detail::kRadToDeg;

double wrap_deg(double rad) {
  double d = std::fmod(rad * kRadToDeg, 360.0);
  if (d < 0) d += 360.0;
  return d;
}

}  // namespace

// Out of line: so vectorised once here, whatever the caller's loop around it.
void turn_angles(const double* a, const double* b, double ca, double cb, std::size_t count,
                 double* out) {
  const auto cross_dot = [&](std::size_t k) {
    const double pa = a[k] - ca, pb = b[k] - cb, qa = a[k + 1] - ca, qb = b[k + 1] - cb;
    return std::pair{pa * qb - pb * qa, pa * qa + pb * qb};
  };
  double far = 0.0;  // a count; as a double, so that the loop vectorises with it
  for (std::size_t k = 0; k < count; ++k) {
    const auto [cross, dot] = cross_dot(k);
    far += in_series_range(cross, dot) ? 0.0 : 1.0;
    out[k] = atan_series(cross / dot);
  }
  if (far == 0.0) return;
  for (std::size_t k = 0; k < count; ++k) {
    const auto [cross, dot] = cross_dot(k);
    if (!in_series_range(cross, dot)) out[k] = std::atan2(cross, dot);
  }
}

namespace {

// Unwraps atan2's angle along a path: successive samples are far less than pi apart.
class Unwrapper {
 public:
  double next(double ang) {
    if (started_) {
      double step = ang + offset_ - prev_;
      while (step > kPi) {
        offset_ -= 2 * kPi;
        step -= 2 * kPi;
      }
      while (step < -kPi) {
        offset_ += 2 * kPi;
        step += 2 * kPi;
      }
    }
    started_ = true;
    prev_ = ang + offset_;
    return prev_;
  }
  // next(ang) against `prev` instead of the last angle returned (a running angle kept outside).
  double next_after(double ang, double prev) {
    prev_ = prev;
    return next(ang);
  }

 private:
  double prev_ = 0.0;
  double offset_ = 0.0;
  bool started_ = false;
};

// Samples between two exact angles. A sum of this many small steps stays within a few ulp of
// the exact angle (the steps are added to a small running total, then once to the base).
constexpr std::size_t kExactEvery = 64;

// emit(i, angle_rad, radius_mm) for every sample in path order, the angle unwrapped along the
// path. atan2 every kExactEvery samples; in between, the step from the previous sample is
// turn_angle of the pair (atan's series for the tiny steps of a sampled path; atan2 of the pair
// for a large step: a gap, a path through the centre). A block's steps and radii are worked
// out first, vectorised (turn_angles), then summed in path order.
template <class Emit>
void polar_walk(std::span<const double> a, std::span<const double> b, PlanePoint centre,
                Emit&& emit) {
  const std::size_t n = a.size();
  const double ca = centre.a_mm, cb = centre.b_mm;
  Unwrapper unwrap;
  double base = 0.0, since = 0.0;
  double turn[kExactEvery], radius[kExactEvery];
  for (std::size_t i0 = 0; i0 < n; i0 += kExactEvery) {
    const std::size_t m = std::min(kExactEvery, n - i0);
    const double* pa = a.data() + i0;
    const double* pb = b.data() + i0;
    for (std::size_t k = 0; k < m; ++k) {
      const double da = pa[k] - ca, db = pb[k] - cb;
      radius[k] = std::sqrt(da * da + db * db);
    }
    if (m > 1) turn_angles(pa, pb, ca, cb, m - 1, turn);
    // Unwrapped against the running angle, as the exact angle of every sample would be.
    base = unwrap.next_after(std::atan2(pb[0] - cb, pa[0] - ca), base + since);
    since = 0.0;
    emit(i0, base, radius[0]);
    for (std::size_t k = 1; k < m; ++k) {
      since += turn[k - 1];
      emit(i0 + k, base + since, radius[k]);
    }
  }
}

}  // namespace

namespace {

// Stable insertion sort by angle: linear on a path that backs up only here and there. Gives
// up (false) once the moves pass `budget`, leaving a permutation of the input.
bool insertion_sort(std::vector<AngleRadius>& p, std::size_t budget) {
  std::size_t moves = 0;
  for (std::size_t i = 1; i < p.size(); ++i) {
    if (!(p[i].angle_rad < p[i - 1].angle_rad)) continue;
    const AngleRadius v = p[i];
    std::size_t j = i;
    while (j > 0 && v.angle_rad < p[j - 1].angle_rad) {
      p[j] = p[j - 1];
      --j;
      if (++moves > budget) {
        p[j] = v;
        return false;
      }
    }
    p[j] = v;
  }
  return true;
}

}  // namespace

// sqrt instead of std::hypot below: coordinates in mm about a centre near the data neither
// overflow nor underflow when squared, and hypot costs several times more.
void path_polar_into(std::span<const double> a, std::span<const double> b, PlanePoint centre,
                     double* angle_rad, double* radius_mm) {
  polar_walk(a, b, centre, [&](std::size_t i, double angle, double radius) {
    angle_rad[i] = angle;
    radius_mm[i] = radius;
  });
}

RadialProfile radial_profile(std::span<const double> a, std::span<const double> b,
                             PlanePoint centre) {
  RadialProfile p;
  const std::size_t n = a.size();
  reserve_huge(p.points, n);
  polar_walk(a, b, centre, [&](std::size_t, double angle_rad, double radius_mm) {
    p.points.push_back({angle_rad, radius_mm});
  });
  auto& v = p.points;
  if (n > 1 && v.back().angle_rad < v.front().angle_rad) std::reverse(v.begin(), v.end());
  const auto by_angle = [](const AngleRadius& x, const AngleRadius& y) {
    return x.angle_rad < y.angle_rad;
  };
  if (!insertion_sort(v, 8 * n + 1024)) std::stable_sort(v.begin(), v.end(), by_angle);
  return p;
}

ProfileDifference compare_profiles(const RadialProfile& ref_profile,
                                   const RadialProfile& from_profile) {
  const std::vector<AngleRadius>& ref = ref_profile.points;
  const std::vector<AngleRadius>& from = from_profile.points;
  ProfileDifference w;
  const std::size_t n = ref.size();
  if (n < 2 || from.empty()) return w;
  const double a0 = ref.front().angle_rad;
  const double a1 = ref.back().angle_rad;
  // `from` is sorted by angle, so its angles taken into ref's arc increase except where they
  // wrap by 2 pi: one forward merge per piece instead of a binary search per sample.
  std::size_t j = 0;  // first ref angle above phi
  double prev_phi = std::numeric_limits<double>::infinity();
  // phi = a0 + (f - a0) mod 2 pi. `from` ascends, so the count of turns taken off only grows:
  // kept here instead of two fmod per sample (the costliest part of this loop).
  double turns = std::floor((from.front().angle_rad - a0) / (2 * kPi));
  for (const AngleRadius& f : from) {
    double rel = f.angle_rad - a0 - turns * (2 * kPi);
    while (rel >= 2 * kPi) {
      turns += 1.0;
      rel = f.angle_rad - a0 - turns * (2 * kPi);
    }
    // Rounding can leave rel a hair below 0 where the turns just changed.
    const double phi = a0 + std::max(rel, 0.0);
    if (phi > a1) continue;  // outside the reference arc
    if (phi < prev_phi) {
      j = static_cast<std::size_t>(
          std::upper_bound(ref.begin(), ref.end(), phi,
                           [](double x, const AngleRadius& y) { return x < y.angle_rad; }) -
          ref.begin());
    } else {
      while (j < n && ref[j].angle_rad <= phi) ++j;
    }
    prev_phi = phi;
    const std::size_t k = std::clamp<std::size_t>(j, 1, n - 1);
    const double x0 = ref[k - 1].angle_rad, x1 = ref[k].angle_rad;
    const double t = x1 > x0 ? (phi - x0) / (x1 - x0) : 0.0;
    const double r = ref[k - 1].radius_mm + t * (ref[k].radius_mm - ref[k - 1].radius_mm);
    const double d = std::abs(f.radius_mm - r);
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

RadialDifference radial_difference(const RadialProfile& p1, const RadialProfile& p2,
                                   unsigned threads) {
  ProfileDifference w12, w21;
  run_tasks(2, threads, [&](std::size_t k) {
    if (k == 0) {
      w12 = compare_profiles(p1, p2);
    } else {
      w21 = compare_profiles(p2, p1);
    }
  });
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
