// Minimum-zone (MZC) circle (the minimum circumscribed and maximum inscribed circles are
// circle_fit_contact.cpp).
//
// MZC: an exact exchange (Remez-type) algorithm on a 4-point reference. Linearised about a
// centre, d_i(c) ~ d_i(c0) - u_i . (c - c0) is a trigonometric polynomial of degree 1 in the
// point's angle, a Haar system, so the minimax solution is levelled on 4 points whose
// roles alternate outer/inner around the centre. For a reference the exact (nonlinear)
// levelled centre is the intersection of the perpendicular bisectors of the two outer and the
// two inner points: a 2x2 linear solve. The worst violator is then swapped in for the
// neighbour of the same role, which keeps the alternation; the level grows until no point
// lies outside the zone. Large inputs are solved on a subsample first (recursively); a full
// pass over all points then collects the few candidates near the extreme radii and the
// violators, and the exact solve on candidates is repeated until a full pass finds none.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "angle_constants.hpp"
#include "circle_fit_detail.hpp"
#include "circtest/analysis/circle_fit.hpp"
#include "circtest/core/error.hpp"

namespace circtest {
namespace {

using evaluation_detail::kTwoPi;
using fit_detail::Vec2;

// Inputs up to this size are solved directly (every point is a candidate).
constexpr std::size_t kBaseSize = 4096;
// Subsample stride of the recursion: one point per 64 touches one cache line per point and
// keeps the subsample gather at about 1/8 of a full pass.
constexpr std::size_t kStride = 64;
// Exchange tolerance relative to the radius: far above rounding (1e-16) so that ties in
// degenerate data cannot make the exchange cycle, far below the 1e-12 of the certificate.
constexpr double kSolveTol = 1e-13;
using fit_detail::kCertTol;

// Distances about a centre stored as a double carry the rounding of that centre, half an ulp
// of its coordinates: for small circles far from the origin that, not the radius, bounds
// what any check can resolve.
double resolution(double cx, double cy) {
  return 4.0 * std::numeric_limits<double>::epsilon() * std::max(std::abs(cx), std::abs(cy));
}

double wrap_angle(double t) {
  t = std::fmod(t, kTwoPi);
  return t < 0.0 ? t + kTwoPi : t;
}

// Candidate points relative to a local origin near the centre (keeps |p|^2 small and exact
// differences for centres far from the coordinate origin), with their indices in the level.
struct Candidates {
  std::vector<double> x, y;
  std::vector<std::size_t> idx;
  std::size_t size() const { return idx.size(); }
  void clear() {
    x.clear();
    y.clear();
    idx.clear();
  }
  void push(double px, double py, std::size_t i) {
    x.push_back(px);
    y.push_back(py);
    idx.push_back(i);
  }
};

// Reference positions (into the candidates), counter-clockwise, roles outer, inner, outer,
// inner.
using Reference = std::array<std::size_t, 4>;

struct ZoneSolve {
  Vec2 c;  // relative to the candidates' origin
  double r_out = 0.0;
  double r_in = 0.0;
  Reference ref{};
};

// Centre equidistant from o1, o2 and from i1, i2: the crossing of the two perpendicular
// bisectors, solved relative to the outer midpoint so that no term carries |p|^2.
bool bisector_centre(Vec2 o1, Vec2 o2, Vec2 i1, Vec2 i2, Vec2& c) {
  const Vec2 n1{o2.x - o1.x, o2.y - o1.y};
  const Vec2 n2{i2.x - i1.x, i2.y - i1.y};
  const Vec2 m1{0.5 * (o1.x + o2.x), 0.5 * (o1.y + o2.y)};
  const Vec2 m2{0.5 * (i1.x + i2.x), 0.5 * (i1.y + i2.y)};
  const double det = n1.x * n2.y - n1.y * n2.x;
  const double norm = std::hypot(n1.x, n1.y) * std::hypot(n2.x, n2.y);
  if (!(std::abs(det) > 1e-14 * norm)) return false;
  // Unknown y = c - m1 with n1.y = 0 and n2.y = n2.(m2 - m1).
  const double rhs = n2.x * (m2.x - m1.x) + n2.y * (m2.y - m1.y);
  c = {m1.x - rhs * n1.y / det, m1.y + rhs * n1.x / det};
  return std::isfinite(c.x) && std::isfinite(c.y);
}

// An alternating start reference about centre c: the farthest and the nearest point, then
// the best outer/inner pair in the arc that lets the four alternate.
bool initial_reference(const Candidates& cd, Vec2 c, Reference& ref) {
  const std::size_t m = cd.size();
  if (m < 4) return false;
  std::vector<double> d2(m), th(m);
  std::vector<std::size_t> order(m);
  std::size_t o1 = 0, i1 = 0;
  for (std::size_t k = 0; k < m; ++k) {
    const double dx = cd.x[k] - c.x, dy = cd.y[k] - c.y;
    d2[k] = dx * dx + dy * dy;
    th[k] = std::atan2(dy, dx);
    order[k] = k;
    if (d2[k] > d2[o1]) o1 = k;
    if (d2[k] < d2[i1]) i1 = k;
  }
  if (o1 == i1) i1 = (o1 + 1) % m;
  std::sort(order.begin(), order.end(),
            [&](std::size_t p, std::size_t q) { return th[p] < th[q]; });
  std::size_t po = 0, pi = 0;
  for (std::size_t k = 0; k < m; ++k) {
    if (order[k] == o1) po = k;
    if (order[k] == i1) pi = k;
  }
  auto same = [&](std::size_t p, std::size_t q) {
    return cd.x[p] == cd.x[q] && cd.y[p] == cd.y[q];
  };
  double best = -INFINITY;
  // Option 1, ccw order o1, i1, o2, i2: o2 then i2 in the arc from i1 round to o1.
  {
    bool have = false;
    std::size_t run = 0;
    for (std::size_t s = (pi + 1) % m; s != po; s = (s + 1) % m) {
      const std::size_t k = order[s];
      if (have && !same(k, i1) && d2[run] - d2[k] > best) {
        best = d2[run] - d2[k];
        ref = {o1, i1, run, k};
      }
      if (!same(k, o1) && (!have || d2[k] > d2[run])) run = k, have = true;
    }
  }
  // Option 2, ccw order o1, i2, o2, i1: i2 then o2 in the arc from o1 round to i1.
  {
    bool have = false;
    std::size_t run = 0;
    for (std::size_t s = (po + 1) % m; s != pi; s = (s + 1) % m) {
      const std::size_t k = order[s];
      if (have && !same(k, o1) && d2[k] - d2[run] > best) {
        best = d2[k] - d2[run];
        ref = {o1, run, k, i1};
      }
      if (!same(k, i1) && (!have || d2[k] < d2[run])) run = k, have = true;
    }
  }
  if (best > -INFINITY) return true;
  // Tiny or clustered inputs: four consecutive points in angle, roles alternating.
  ref = {order[po], order[(po + 1) % m], order[(po + 2) % m], order[(po + 3) % m]};
  return true;
}

// Exchange iterations on the candidates from a start reference about c0.
bool exchange(const Candidates& cd, Vec2 c0, ZoneSolve& out) {
  Reference ref{};
  if (!initial_reference(cd, c0, ref)) return false;
  const std::size_t m = cd.size();
  const double* x = cd.x.data();
  const double* y = cd.y.data();
  auto pt = [&](std::size_t k) { return Vec2{x[k], y[k]}; };
  const std::size_t max_iter = 100 + 4 * m;
  for (std::size_t iter = 0; iter < max_iter; ++iter) {
    Vec2 c;
    if (!bisector_centre(pt(ref[0]), pt(ref[2]), pt(ref[1]), pt(ref[3]), c)) return false;
    const double ro = 0.5 * (std::hypot(x[ref[0]] - c.x, y[ref[0]] - c.y) +
                             std::hypot(x[ref[2]] - c.x, y[ref[2]] - c.y));
    const double ri = 0.5 * (std::hypot(x[ref[1]] - c.x, y[ref[1]] - c.y) +
                             std::hypot(x[ref[3]] - c.x, y[ref[3]] - c.y));
    if (ro < ri) {
      // The roles are upside down (a poor start on nearly perfect data): swap them by
      // rotating the reference one place, which keeps it counter-clockwise.
      ref = {ref[1], ref[2], ref[3], ref[0]};
      continue;
    }
    const double ro2 = ro * ro, ri2 = ri * ri;
    const double inv_o = 0.5 / ro, inv_i = ri > 0.0 ? 0.5 / ri : 0.0;
    // (d^2 - R^2) / 2R equals d - R to first order in the zone over the radius, which
    // is all the ranking and the tolerance need; it spares a sqrt per point.
    double worst = 0.0;
    std::size_t v = m;
    bool v_outer = false;
    for (std::size_t k = 0; k < m; ++k) {
      const double dx = x[k] - c.x, dy = y[k] - c.y;
      const double d2 = dx * dx + dy * dy;
      const double so = (d2 - ro2) * inv_o;
      const double si = (ri2 - d2) * inv_i;
      if (so > worst) worst = so, v = k, v_outer = true;
      if (si > worst) worst = si, v = k, v_outer = false;
    }
    if (v == m || worst <= kSolveTol * ro) {
      out.c = c;
      out.r_out = ro;
      out.r_in = ri;
      out.ref = ref;
      return true;
    }
    double delta[4];
    const double t0 = std::atan2(y[ref[0]] - c.y, x[ref[0]] - c.x);
    for (int j = 0; j < 4; ++j) {
      delta[j] = j == 0 ? 0.0 : wrap_angle(std::atan2(y[ref[j]] - c.y, x[ref[j]] - c.x) - t0);
    }
    if (!(delta[1] < delta[2] && delta[2] < delta[3])) return false;  // alternation lost
    const double dv = wrap_angle(std::atan2(y[v] - c.y, x[v] - c.x) - t0);
    int slot = 3;
    while (slot > 0 && dv < delta[slot]) --slot;
    const int next = (slot + 1) % 4;
    const bool slot_outer = slot % 2 == 0;
    ref[slot_outer == v_outer ? slot : next] = v;
  }
  return false;
}

// Zone about c over the candidates: widest and narrowest radius and where they are.
ZoneSolve zone_about(const Candidates& cd, Vec2 c) {
  ZoneSolve z;
  z.c = c;
  z.r_in = INFINITY;
  std::size_t io = 0, ii = 0;
  for (std::size_t k = 0; k < cd.size(); ++k) {
    const double d = std::hypot(cd.x[k] - c.x, cd.y[k] - c.y);
    if (d > z.r_out) z.r_out = d, io = k;
    if (d < z.r_in) z.r_in = d, ii = k;
  }
  z.ref = {io, ii, io, ii};
  return z;
}

// The fallback when the exchange cannot keep an alternating reference (a gross outlier
// makes the optimum degenerate: one far point against a flat valley of centres). A compass
// search on the zone width itself: it only ever accepts a narrower zone and halves its step
// otherwise, so it ends in a bounded number of passes. Its answer goes through the same
// certificate as the exchange's (fit_mzc); an uncertified one is reported as such.
ZoneSolve compass_search(const Candidates& cd, Vec2 c0) {
  ZoneSolve best = zone_about(cd, c0);
  const double scale = best.r_out + std::hypot(c0.x, c0.y);
  double step = std::max(best.r_out - best.r_in, 1e-9 * scale);
  const double floor = 1e-15 * scale;
  static constexpr double kDiag = 0.70710678118654752;
  static constexpr Vec2 kDirs[8] = {{1, 0},           {0, 1},         {-1, 0},
                                    {0, -1},          {kDiag, kDiag}, {-kDiag, kDiag},
                                    {-kDiag, -kDiag}, {kDiag, -kDiag}};
  for (int iter = 0; iter < 4000 && step > floor; ++iter) {
    bool moved = false;
    for (const Vec2& d : kDirs) {
      const ZoneSolve z = zone_about(cd, {best.c.x + step * d.x, best.c.y + step * d.y});
      if (z.r_out - z.r_in < best.r_out - best.r_in) best = z, moved = true;
    }
    if (!moved) step *= 0.5;
  }
  return best;
}

// Exact MZC of the candidates, starting about c0; retries from the latest centre with a new
// start reference if the exchange loses its alternation, then from the compass search's
// centre, and keeps whichever zone is narrower.
ZoneSolve solve_candidates(const Candidates& cd, Vec2 c0) {
  ZoneSolve s;
  for (int attempt = 0; attempt < 4; ++attempt) {
    if (exchange(cd, c0, s)) return s;
    c0 = s.c;
  }
  const ZoneSolve fallback = compass_search(cd, c0);
  if (exchange(cd, fallback.c, s) && s.r_out - s.r_in <= fallback.r_out - fallback.r_in) return s;
  return fallback;
}

struct LevelResult {
  Vec2 c;  // absolute
  double r_out = 0.0;
  double r_in = 0.0;
  std::array<std::size_t, 4> ref{};  // indices into the level's points
  double shift = 0.0;                // how far this level moved the centre it started from
  bool three_points = false;         // exactly three distinct points: zero zone, no reference
  double hi2 = -1.0;                 // extreme squared radii of all points about c, when the
  double lo2 = -1.0;                 // level's last pass measured them (not for the base)
};

// Three distinct points (possibly repeated): the circle through them, zone width zero.
bool three_distinct(const double* a, const double* b, std::size_t n, LevelResult& out) {
  std::size_t u[3];
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    bool seen = false;
    for (std::size_t k = 0; k < count; ++k) seen = seen || (a[u[k]] == a[i] && b[u[k]] == b[i]);
    if (seen) continue;
    if (count == 3) return false;
    u[count++] = i;
  }
  if (count < 3) throw DataError("", 0, "fit_mzc: fewer than 3 distinct points");
  const double bx = a[u[1]] - a[u[0]], by = b[u[1]] - b[u[0]];
  const double cx = a[u[2]] - a[u[0]], cy = b[u[2]] - b[u[0]];
  const double det = 2.0 * (bx * cy - by * cx);
  if (!(std::abs(det) > 1e-14 * (bx * bx + by * by + cx * cx + cy * cy))) {
    throw DataError("", 0, "circle fit: the points are collinear or coincident");
  }
  const double b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
  out.c = {a[u[0]] + (cy * b2 - by * c2) / det, b[u[0]] + (bx * c2 - cx * b2) / det};
  out.r_out = out.r_in = std::hypot(a[u[0]] - out.c.x, b[u[0]] - out.c.y);
  out.ref = {u[0], u[0], u[0], u[0]};
  out.three_points = true;
  return true;
}

LevelResult solve_base(const double* a, const double* b, std::size_t n) {
  LevelResult res;
  if (three_distinct(a, b, n, res)) return res;
  const Vec2 mean = fit_detail::mean_point(a, b, n);
  const Circle start = fit_detail::kasa_about(a, b, n, mean);
  const Vec2 z{start.centre_a_mm, start.centre_b_mm};
  Candidates cd;
  cd.x.reserve(n), cd.y.reserve(n), cd.idx.reserve(n);
  for (std::size_t i = 0; i < n; ++i) cd.push(a[i] - z.x, b[i] - z.y, i);
  const ZoneSolve s = solve_candidates(cd, Vec2{0.0, 0.0});
  res.c = {z.x + s.c.x, z.y + s.c.y};
  res.r_out = s.r_out;
  res.r_in = s.r_in;
  for (int j = 0; j < 4; ++j) res.ref[j] = cd.idx[s.ref[j]];
  res.shift = std::hypot(s.c.x, s.c.y);
  return res;
}

LevelResult solve_level(const double* a, const double* b, std::size_t n) {
  if (n <= kBaseSize) return solve_base(a, b, n);
  // Every kStride-th point: spread evenly over the path, so the subsample's zone is close.
  const std::size_t ns = (n + kStride - 1) / kStride;
  std::vector<double> sa(ns), sb(ns);
  for (std::size_t k = 0; k < ns; ++k) sa[k] = a[k * kStride], sb[k] = b[k * kStride];
  LevelResult sub;
  try {
    sub = solve_level(sa.data(), sb.data(), ns);
  } catch (const DataError&) {
    return solve_base(a, b, n);  // a degenerate subsample (e.g. collinear) of valid data
  }
  if (sub.three_points) return solve_base(a, b, n);

  LevelResult res;
  res.c = sub.c;
  res.r_out = sub.r_out;
  res.r_in = sub.r_in;
  for (int j = 0; j < 4; ++j) res.ref[j] = sub.ref[j] * kStride;
  const Vec2 start = res.c;
  // Band half-width for candidates: the centre still moves by about as much as it moved on
  // the level below, and moving it by d changes every radius by at most d. A fraction of the
  // zone caps it: right above the base level the shift is from the algebraic start and would
  // make every point a candidate; too narrow a band costs a pass, never correctness.
  const double cap = 0.01 * (res.r_out - res.r_in);
  double margin = std::min(4.0 * sub.shift, cap) + kSolveTol * res.r_out;
  std::vector<std::size_t> keep;  // candidates accumulate over passes, so no exchange repeats
  Candidates cd;
  double buf[fit_detail::kBlock];
  constexpr int kMaxPasses = 64;
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    const double cx = res.c.x, cy = res.c.y;
    const double tol = kSolveTol * res.r_out + resolution(cx, cy);
    const double band_hi = std::max(0.0, res.r_out - margin);
    const double hi_c = band_hi * band_hi;
    const double lo_c = (res.r_in + margin) * (res.r_in + margin);
    const std::size_t before = keep.size();
    double hi2 = 0.0, lo2 = INFINITY;
    // Blocks: the squared radii and their extremes in a plain (vectorisable) loop; only a
    // block that reaches into the band is scanned again for candidates.
    for (std::size_t start_i = 0; start_i < n; start_i += fit_detail::kBlock) {
      const std::size_t len = std::min(fit_detail::kBlock, n - start_i);
      const double* ba = a + start_i;
      const double* bb = b + start_i;
      double bhi = 0.0, blo = INFINITY;
      for (std::size_t k = 0; k < len; ++k) {
        const double dx = ba[k] - cx;
        const double dy = bb[k] - cy;
        const double d2 = dx * dx + dy * dy;
        buf[k] = d2;
        bhi = bhi > d2 ? bhi : d2;
        blo = blo < d2 ? blo : d2;
      }
      hi2 = std::max(hi2, bhi);
      lo2 = std::min(lo2, blo);
      if (bhi >= hi_c || blo <= lo_c) [[unlikely]] {
        for (std::size_t k = 0; k < len; ++k) {
          if (buf[k] >= hi_c || buf[k] <= lo_c) keep.push_back(start_i + k);
        }
      }
    }
    if (!std::isfinite(hi2)) {
      throw DataError("", 0, "fit_mzc: a coordinate is not a finite number");
    }
    const double hi_v = (res.r_out + tol) * (res.r_out + tol);
    const double lo_v = std::max(0.0, res.r_in - tol) * std::max(0.0, res.r_in - tol);
    // The last pass keeps the zone it measured about its centre: a valid zone of every point
    // that the certificate then judges, rather than no answer at all.
    if ((hi2 <= hi_v && lo2 >= lo_v) || pass + 1 == kMaxPasses) {
      res.shift = std::hypot(res.c.x - start.x, res.c.y - start.y);
      res.hi2 = hi2;
      res.lo2 = lo2;
      return res;
    }
    std::inplace_merge(keep.begin(), keep.begin() + static_cast<std::ptrdiff_t>(before),
                       keep.end());
    keep.erase(std::unique(keep.begin(), keep.end()), keep.end());
    cd.clear();
    for (std::size_t i : keep) cd.push(a[i] - cx, b[i] - cy, i);
    const ZoneSolve s = solve_candidates(cd, Vec2{0.0, 0.0});
    res.c = {cx + s.c.x, cy + s.c.y};
    res.r_out = s.r_out;
    res.r_in = s.r_in;
    for (int j = 0; j < 4; ++j) res.ref[j] = cd.idx[s.ref[j]];
    margin = std::min(4.0 * std::hypot(s.c.x, s.c.y), cap) + kSolveTol * res.r_out;
  }
  return res;  // not reached: the last pass returns
}

// First-order optimality at c for any active sets: the outward unit vectors of the points on
// the outer circle and those of the points on the inner circle share a point of their convex
// hulls. By Caratheodory in the plane some 1+1, 1+2, 2+1, 2+2, 1+3 or 3+1 of them then do.
// Used when the 4-point reference of the exchange does not certify (degenerate optima, the
// compass fallback); fills the contacts and multipliers when it holds.
bool general_certificate(const double* pa, const double* pb, std::size_t n, Vec2 c, double r_out,
                         double r_in, double tol, MinimumZone& z) {
  constexpr std::size_t kCap = 12;
  constexpr double kEps = 1e-9;
  std::vector<std::pair<double, std::size_t>> outer, inner;
  for (std::size_t i = 0; i < n; ++i) {
    const double d = std::hypot(pa[i] - c.x, pb[i] - c.y);
    if (d >= r_out - tol) outer.emplace_back(r_out - d, i);
    if (d <= r_in + tol) inner.emplace_back(d - r_in, i);
  }
  for (auto* v : {&outer, &inner}) {
    std::sort(v->begin(), v->end());
    if (v->size() > kCap) v->resize(kCap);
  }
  auto unit = [&](std::size_t i) {
    const double d = std::hypot(pa[i] - c.x, pb[i] - c.y);
    return d > 0.0 ? Vec2{(pa[i] - c.x) / d, (pb[i] - c.y) / d} : Vec2{0.0, 0.0};
  };
  std::vector<Vec2> uo, ui;
  for (const auto& o : outer) uo.push_back(unit(o.second));
  for (const auto& o : inner) ui.push_back(unit(o.second));
  auto accept = [&](const std::vector<std::size_t>& os, const std::vector<double>& ow,
                    const std::vector<std::size_t>& is, const std::vector<double>& iw) {
    z.outer_contacts.clear();
    z.inner_contacts.clear();
    z.multipliers.clear();
    for (std::size_t k : os) z.outer_contacts.push_back(outer[k].second);
    for (std::size_t k : is) z.inner_contacts.push_back(inner[k].second);
    for (double w : ow) z.multipliers.push_back(0.5 * w);
    for (double w : iw) z.multipliers.push_back(0.5 * w);
    return true;
  };
  // p on segment ab within kEps: the parameter t of the nearest point.
  auto on_segment = [](Vec2 p, Vec2 a, Vec2 b, double& t) {
    const Vec2 e{b.x - a.x, b.y - a.y};
    const double l2 = e.x * e.x + e.y * e.y;
    t = l2 > 0.0 ? std::clamp(((p.x - a.x) * e.x + (p.y - a.y) * e.y) / l2, 0.0, 1.0) : 0.0;
    return std::hypot(a.x + t * e.x - p.x, a.y + t * e.y - p.y) <= kEps;
  };
  // p in triangle abc: barycentric weights.
  auto in_triangle = [](Vec2 p, Vec2 a, Vec2 b, Vec2 q, double w[3]) {
    const double det = (b.y - q.y) * (a.x - q.x) + (q.x - b.x) * (a.y - q.y);
    if (std::abs(det) < 1e-14) return false;
    w[0] = ((b.y - q.y) * (p.x - q.x) + (q.x - b.x) * (p.y - q.y)) / det;
    w[1] = ((q.y - a.y) * (p.x - q.x) + (a.x - q.x) * (p.y - q.y)) / det;
    w[2] = 1.0 - w[0] - w[1];
    return w[0] >= -kEps && w[1] >= -kEps && w[2] >= -kEps;
  };
  const std::size_t no = uo.size(), ni = ui.size();
  for (std::size_t a = 0; a < no; ++a) {
    for (std::size_t b = 0; b < ni; ++b) {
      if (std::hypot(uo[a].x - ui[b].x, uo[a].y - ui[b].y) <= kEps) {
        return accept({a}, {1.0}, {b}, {1.0});
      }
    }
  }
  double t = 0.0;
  for (std::size_t a = 0; a < no; ++a) {
    for (std::size_t b = 0; b < ni; ++b) {
      for (std::size_t b2 = b + 1; b2 < ni; ++b2) {
        if (on_segment(uo[a], ui[b], ui[b2], t)) return accept({a}, {1.0}, {b, b2}, {1 - t, t});
      }
    }
  }
  for (std::size_t b = 0; b < ni; ++b) {
    for (std::size_t a = 0; a < no; ++a) {
      for (std::size_t a2 = a + 1; a2 < no; ++a2) {
        if (on_segment(ui[b], uo[a], uo[a2], t)) return accept({a, a2}, {1 - t, t}, {b}, {1.0});
      }
    }
  }
  for (std::size_t a = 0; a < no; ++a) {
    for (std::size_t a2 = a + 1; a2 < no; ++a2) {
      for (std::size_t b = 0; b < ni; ++b) {
        for (std::size_t b2 = b + 1; b2 < ni; ++b2) {
          const Vec2 e{uo[a2].x - uo[a].x, uo[a2].y - uo[a].y};
          const Vec2 f{ui[b2].x - ui[b].x, ui[b2].y - ui[b].y};
          const Vec2 g{ui[b].x - uo[a].x, ui[b].y - uo[a].y};
          const double det = -e.x * f.y + e.y * f.x;
          if (det == 0.0) continue;
          const double s = (-g.x * f.y + g.y * f.x) / det;
          const double u = (e.x * g.y - e.y * g.x) / det;
          if (s >= -kEps && s <= 1 + kEps && u >= -kEps && u <= 1 + kEps) {
            const double sc = std::clamp(s, 0.0, 1.0), uc = std::clamp(u, 0.0, 1.0);
            return accept({a, a2}, {1 - sc, sc}, {b, b2}, {1 - uc, uc});
          }
        }
      }
    }
  }
  double w[3];
  for (std::size_t a = 0; a < no; ++a) {
    for (std::size_t b = 0; b < ni; ++b) {
      for (std::size_t b2 = b + 1; b2 < ni; ++b2) {
        for (std::size_t b3 = b2 + 1; b3 < ni; ++b3) {
          if (in_triangle(uo[a], ui[b], ui[b2], ui[b3], w)) {
            return accept({a}, {1.0}, {b, b2, b3}, {w[0], w[1], w[2]});
          }
        }
      }
    }
  }
  for (std::size_t b = 0; b < ni; ++b) {
    for (std::size_t a = 0; a < no; ++a) {
      for (std::size_t a2 = a + 1; a2 < no; ++a2) {
        for (std::size_t a3 = a2 + 1; a3 < no; ++a3) {
          if (in_triangle(ui[b], uo[a], uo[a2], uo[a3], w)) {
            return accept({a, a2, a3}, {w[0], w[1], w[2]}, {b}, {1.0});
          }
        }
      }
    }
  }
  return false;
}

}  // namespace

MinimumZone fit_mzc(std::span<const double> a, std::span<const double> b) {
  fit_detail::check_points(a, b, "fit_mzc");
  const std::size_t n = a.size();
  const double* pa = a.data();
  const double* pb = b.data();
  const LevelResult lr = solve_level(pa, pb, n);

  // The zone about the final centre, measured on every point (by the last verifying pass of
  // the candidate loop, or here), not taken from the reference points.
  double lo2 = lr.lo2, hi2 = lr.hi2;
  if (hi2 < 0.0) {
    lo2 = INFINITY;
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = pa[i] - lr.c.x, dy = pb[i] - lr.c.y;
      const double d2 = dx * dx + dy * dy;
      lo2 = std::min(lo2, d2);
      hi2 = std::max(hi2, d2);
    }
  }
  if (!std::isfinite(hi2)) throw DataError("", 0, "fit_mzc: a coordinate is not a finite number");
  MinimumZone z;
  z.centre_a_mm = lr.c.x;
  z.centre_b_mm = lr.c.y;
  z.outer_radius_mm = std::sqrt(hi2);
  z.inner_radius_mm = std::sqrt(lo2);
  z.zone_width_mm = z.outer_radius_mm - z.inner_radius_mm;
  const double tol = kCertTol * z.outer_radius_mm + resolution(lr.c.x, lr.c.y);
  auto dist = [&](std::size_t i) { return std::hypot(pa[i] - lr.c.x, pb[i] - lr.c.y); };

  if (lr.three_points) {
    // Every point on one circle: the zone width 0 is the global minimum. One point serves as
    // both an outer and an inner contact, whose unit vectors cancel with equal weights.
    z.outer_contacts = {lr.ref[0]};
    z.inner_contacts = {lr.ref[0]};
    z.multipliers = {0.5, 0.5};
    z.certified = z.zone_width_mm <= tol;
    return z;
  }
  const std::size_t o1 = lr.ref[0], i1 = lr.ref[1], o2 = lr.ref[2], i2 = lr.ref[3];
  z.outer_contacts = {o1, o2};
  z.inner_contacts = {i1, i2};
  auto unit = [&](std::size_t i) {
    const double d = dist(i);
    return Vec2{(pa[i] - lr.c.x) / d, (pb[i] - lr.c.y) / d};
  };
  const Vec2 uo1 = unit(o1), uo2 = unit(o2), ui1 = unit(i1), ui2 = unit(i2);
  // The chords uo1-uo2 and ui1-ui2 cross at uo1 + s (uo2 - uo1) = ui1 + t (ui2 - ui1): the
  // crossing is the common point of both convex hulls, i.e. the first-order condition.
  const Vec2 e{uo2.x - uo1.x, uo2.y - uo1.y};
  const Vec2 f{ui2.x - ui1.x, ui2.y - ui1.y};
  const Vec2 g{ui1.x - uo1.x, ui1.y - uo1.y};
  const double det = -e.x * f.y + e.y * f.x;
  double s = -1.0, t = -1.0;
  if (det != 0.0) {
    s = (-g.x * f.y + g.y * f.x) / det;
    t = (e.x * g.y - e.y * g.x) / det;
  }
  const bool crossing = s >= -1e-9 && s <= 1.0 + 1e-9 && t >= -1e-9 && t <= 1.0 + 1e-9;
  s = std::clamp(s, 0.0, 1.0);
  t = std::clamp(t, 0.0, 1.0);
  z.multipliers = {0.5 * (1.0 - s), 0.5 * s, 0.5 * (1.0 - t), 0.5 * t};
  const bool on_zone = std::abs(dist(o1) - z.outer_radius_mm) <= tol &&
                       std::abs(dist(o2) - z.outer_radius_mm) <= tol &&
                       std::abs(dist(i1) - z.inner_radius_mm) <= tol &&
                       std::abs(dist(i2) - z.inner_radius_mm) <= tol;
  z.certified = on_zone && (crossing || z.zone_width_mm <= tol);
  if (!z.certified) {
    z.certified =
        general_certificate(pa, pb, n, lr.c, z.outer_radius_mm, z.inner_radius_mm, tol, z);
  }
  return z;
}

}  // namespace circtest
