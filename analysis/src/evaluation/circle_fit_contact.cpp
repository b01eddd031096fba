// Minimum circumscribed (MCC) and maximum inscribed (MIC) circles; the minimum zone (MZC) is
// circle_fit_zone.cpp.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <utility>
#include <vector>

#include "angle_constants.hpp"
#include "circle_fit_detail.hpp"
#include "circtest/analysis/circle_fit.hpp"
#include "circtest/core/error.hpp"

namespace circtest {
namespace {

using evaluation_detail::kPi;
using evaluation_detail::kTwoPi;
using fit_detail::kCertTol;
using fit_detail::Vec2;

// Minimum circumscribed circle: Welzl's algorithm in its iterative move-to-front form on a
// shuffled copy (expected linear time), in coordinates relative to the mean.

struct Disc {
  Vec2 c;
  double r2 = -1.0;
};

Disc disc2(Vec2 p, Vec2 q) {
  const Vec2 c{0.5 * (p.x + q.x), 0.5 * (p.y + q.y)};
  const double dx = p.x - c.x, dy = p.y - c.y;
  return {c, dx * dx + dy * dy};
}

Disc disc3(Vec2 p, Vec2 q, Vec2 w) {
  const double bx = q.x - p.x, by = q.y - p.y, cx = w.x - p.x, cy = w.y - p.y;
  const double det = 2.0 * (bx * cy - by * cx);
  const double b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
  if (!(std::abs(det) > 1e-14 * (b2 + c2))) {
    // Collinear: the circle on the farthest pair contains the third point.
    Disc best = disc2(p, q);
    for (const Disc& d : {disc2(p, w), disc2(q, w)}) {
      if (d.r2 > best.r2) best = d;
    }
    return best;
  }
  const Vec2 c{p.x + (cy * b2 - by * c2) / det, p.y + (bx * c2 - cx * b2) / det};
  const double dx = p.x - c.x, dy = p.y - c.y;
  return {c, dx * dx + dy * dy};
}

bool outside(const Disc& d, Vec2 p) {
  const double dx = p.x - d.c.x, dy = p.y - d.c.y;
  return dx * dx + dy * dy > d.r2 * (1.0 + 1e-13);
}

// Indices of the points within kCertTol of the circle's radius.
std::vector<std::size_t> on_circle(std::span<const double> a, std::span<const double> b,
                                   const Circle& c) {
  std::vector<std::size_t> out;
  const double tol = kCertTol * c.radius_mm;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double d = std::hypot(a[i] - c.centre_a_mm, b[i] - c.centre_b_mm);
    if (std::abs(d - c.radius_mm) <= tol) out.push_back(i);
  }
  return out;
}

}  // namespace

ContactCircle fit_mcc(std::span<const double> a, std::span<const double> b) {
  fit_detail::check_points(a, b, "fit_mcc");
  const std::size_t n = a.size();
  const Vec2 m = fit_detail::mean_point(a.data(), b.data(), n);
  std::vector<Vec2> p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = {a[i] - m.x, b[i] - m.y};
  // Fixed seed: the result must not depend on the run.
  std::mt19937_64 rng(0x5eedc1cULL);
  std::shuffle(p.begin(), p.end(), rng);
  Disc d{p[0], 0.0};
  for (std::size_t i = 1; i < n; ++i) {
    if (!outside(d, p[i])) continue;
    d = {p[i], 0.0};
    for (std::size_t j = 0; j < i; ++j) {
      if (!outside(d, p[j])) continue;
      d = disc2(p[i], p[j]);
      for (std::size_t k = 0; k < j; ++k) {
        if (outside(d, p[k])) d = disc3(p[i], p[j], p[k]);
      }
    }
  }
  ContactCircle out;
  out.circle = {m.x + d.c.x, m.y + d.c.y, std::sqrt(d.r2)};
  // The radius as the largest distance of any point, so every point is inside by definition.
  double hi2 = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = a[i] - out.circle.centre_a_mm, dy = b[i] - out.circle.centre_b_mm;
    hi2 = std::max(hi2, dx * dx + dy * dy);
  }
  out.circle.radius_mm = std::sqrt(hi2);
  out.contacts = on_circle(a, b, out.circle);
  return out;
}

// Maximum inscribed circle: a monotone walk on the nearest-point Voronoi diagram. From the
// algebraic centre the empty circle grows: the centre moves away from its nearest points
// (along the bisector of the two that bound the largest angular gap) until another point
// touches, and stops where the touching points surround the centre (no gap of pi or more),
// the first-order condition of max_c min_i |p_i - c|. For points along a closed path
// around the centre that local maximum is the largest empty circle inside the path.

MicFit fit_mic(std::span<const double> a, std::span<const double> b) {
  fit_detail::check_points(a, b, "fit_mic");
  const std::size_t n = a.size();
  const Circle start = fit_lsc_algebraic(a, b);
  const Vec2 z{start.centre_a_mm, start.centre_b_mm};
  std::vector<double> x(n), y(n), d2(n);
  for (std::size_t i = 0; i < n; ++i) x[i] = a[i] - z.x, y[i] = b[i] - z.y;
  Vec2 c{0.0, 0.0};
  std::vector<std::size_t> active;
  std::vector<std::pair<double, std::size_t>> ang;
  const std::size_t max_steps = 1000 + 4 * n;
  for (std::size_t step = 0;; ++step) {
    if (step == max_steps) {
      throw Error(ExitCode::internal, "fit_mic: the inscribed-circle walk did not converge");
    }
    double rho2 = INFINITY;
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = x[i] - c.x, dy = y[i] - c.y;
      d2[i] = dx * dx + dy * dy;
      rho2 = std::min(rho2, d2[i]);
    }
    if (!(rho2 > 0.0)) {
      return {std::nullopt, "a point lies on the start centre; no inscribed circle"};
    }
    // d within 1e-12 of rho: d^2 within 2e-12 of rho^2.
    const double act2 = rho2 * (1.0 + 2.0 * kCertTol);
    active.clear();
    ang.clear();
    for (std::size_t i = 0; i < n; ++i) {
      if (d2[i] <= act2) {
        active.push_back(i);
        ang.emplace_back(std::atan2(y[i] - c.y, x[i] - c.x), i);
      }
    }
    std::sort(ang.begin(), ang.end());
    double gap = kTwoPi;
    std::size_t from = 0;  // the gap runs counter-clockwise from ang[from]
    for (std::size_t k = 0; k < ang.size(); ++k) {
      const double next = k + 1 < ang.size() ? ang[k + 1].first : ang[0].first + kTwoPi;
      const double g = next - ang[k].first;
      if (k == 0 || g > gap) gap = g, from = k;
    }
    if (ang.size() == 1) gap = kTwoPi;
    if (ang.size() >= 2 && gap < kPi - 1e-9) {
      ContactCircle out;
      out.circle = {z.x + c.x, z.y + c.y, std::sqrt(rho2)};
      out.contacts = active;
      std::sort(out.contacts.begin(), out.contacts.end());
      return {std::move(out), {}};
    }
    // Move into the middle of the largest gap: away from every touching point, and along
    // the bisector of the two that bound the gap, so they stay equidistant.
    const double heading = ang[from].first + 0.5 * gap;
    const Vec2 v{std::cos(heading), std::sin(heading)};
    const std::size_t pa_i = ang[from].second;
    double best = INFINITY;
    for (std::size_t i = 0; i < n; ++i) {
      if (d2[i] <= act2) continue;
      const double den = 2.0 * (v.x * (x[i] - x[pa_i]) + v.y * (y[i] - y[pa_i]));
      if (den <= 0.0) continue;
      const double t = (d2[i] - d2[pa_i]) / den;
      best = std::min(best, t);
    }
    if (!std::isfinite(best)) {
      return {std::nullopt, "the points do not enclose the centre; no inscribed circle"};
    }
    c = {c.x + best * v.x, c.y + best * v.y};
  }
}

}  // namespace circtest
