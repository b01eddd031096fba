// Least-squares, radial-range and shared numerics of the circle fits. The minimum-zone,
// circumscribed and inscribed fits live in circle_fit_zone.cpp.
#include "circtest/analysis/circle_fit.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "circle_fit_detail.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/parallel.hpp"

namespace circtest {
namespace fit_detail {

void check_points(std::span<const double> a, std::span<const double> b, const char* what) {
  if (a.size() != b.size()) {
    throw DataError("", 0,
                    std::string(what) + ": coordinate arrays differ in length (" +
                        std::to_string(a.size()) + " vs " + std::to_string(b.size()) + ")");
  }
  if (a.size() < 3) {
    throw DataError(
        "", 0, std::string(what) + ": needs at least 3 points, got " + std::to_string(a.size()));
  }
}

Vec2 mean_point(const double* a, const double* b, std::size_t n) {
  // Blocked sums feed a Neumaier accumulator: the inner loop stays plain (and vectorisable)
  // while the error no longer grows with n.
  Neumaier sa, sb;
  bool finite = true;
  for (std::size_t start = 0; start < n; start += kBlock) {
    const std::size_t stop = std::min(n, start + kBlock);
    double ba = 0.0, bb = 0.0;
    for (std::size_t i = start; i < stop; ++i) {
      ba += a[i];
      bb += b[i];
    }
    finite = finite && std::isfinite(ba) && std::isfinite(bb);
    sa.add(ba);
    sb.add(bb);
  }
  if (!finite) throw DataError("", 0, "circle fit: a coordinate is not a finite number");
  const double inv = 1.0 / static_cast<double>(n);
  return {sa.value() * inv, sb.value() * inv};
}

Circle kasa_about(const double* a, const double* b, std::size_t n, Vec2 origin) {
  // Moments of the data relative to `origin` (the mean, or a point near the data), so that
  // |p|^2 does not carry the absolute position of the circle and cancel catastrophically.
  Neumaier sxx, sxy, syy, sxz, syz, sz, sx, sy;
  for (std::size_t start = 0; start < n; start += kBlock) {
    const std::size_t stop = std::min(n, start + kBlock);
    double bxx = 0, bxy = 0, byy = 0, bxz = 0, byz = 0, bz = 0, bx = 0, by = 0;
    for (std::size_t i = start; i < stop; ++i) {
      const double x = a[i] - origin.x;
      const double y = b[i] - origin.y;
      const double z = x * x + y * y;
      bxx += x * x;
      bxy += x * y;
      byy += y * y;
      bxz += x * z;
      byz += y * z;
      bz += z;
      bx += x;
      by += y;
    }
    sxx.add(bxx), sxy.add(bxy), syy.add(byy), sxz.add(bxz), syz.add(byz), sz.add(bz);
    sx.add(bx), sy.add(by);
  }
  const double nn = static_cast<double>(n);
  const double mx = sx.value() / nn, my = sy.value() / nn, mz = sz.value() / nn;
  // Central moments: the model z = 2 cx x + 2 cy y + k decouples once x and y have zero mean.
  const double cxx = sxx.value() / nn - mx * mx;
  const double cxy = sxy.value() / nn - mx * my;
  const double cyy = syy.value() / nn - my * my;
  const double cxz = sxz.value() / nn - mx * mz;
  const double cyz = syz.value() / nn - my * mz;
  const double det = cxx * cyy - cxy * cxy;
  const double scale = cxx + cyy;
  // Rounding leaves det near 1e-32 scale^2 for collinear data; real arcs of 90 deg or more
  // are many orders above 1e-20.
  if (!(scale > 0.0) || !(det > 1e-20 * scale * scale)) {
    throw DataError("", 0, "circle fit: the points are collinear or coincident");
  }
  const double ux = 0.5 * (cxz * cyy - cyz * cxy) / det;
  const double uy = 0.5 * (cyz * cxx - cxz * cxy) / det;
  // Radius from the mean of |p - c|^2 over the data (relative to the data mean).
  const double r2 = cxx + cyy + (ux - mx) * (ux - mx) + (uy - my) * (uy - my);
  return {origin.x + ux, origin.y + uy, std::sqrt(r2)};
}

}  // namespace fit_detail

using fit_detail::kBlock;
using fit_detail::Neumaier;
using fit_detail::Vec2;

RadialRange radial_range(std::span<const double> a, std::span<const double> b, double centre_a_mm,
                         double centre_b_mm) {
  fit_detail::check_points(a, b, "radial_range");
  double lo = INFINITY, hi = 0.0;
  const std::size_t n = a.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = a[i] - centre_a_mm;
    const double dy = b[i] - centre_b_mm;
    const double d2 = dx * dx + dy * dy;
    lo = std::min(lo, d2);
    hi = std::max(hi, d2);
  }
  return {std::sqrt(lo), std::sqrt(hi)};
}

Circle fit_lsc_algebraic(std::span<const double> a, std::span<const double> b) {
  fit_detail::check_points(a, b, "fit_lsc_algebraic");
  const Vec2 m = fit_detail::mean_point(a.data(), b.data(), a.size());
  return fit_detail::kasa_about(a.data(), b.data(), a.size(), m);
}

namespace {

// Levenberg-Marquardt for the geometric circle, in coordinates relative to `m`, from `start`.
// Each pass evaluates the cost, J^T J and J^T e at the trial parameters; a trial that does not
// lower the cost is rejected and retried with a larger damping, reusing the stored normal
// equations.
struct Points {
  const double* a;
  const double* b;
  std::size_t n;
};

// The sums of one block of points [lo, hi) of a set for the centre (ox, oy) and radius r:
// ux^2, ux uy, ux, uy^2, uy, count, ux e, uy e, e, e^2 with u the unit vector from the centre
// and e the radial residual.
void block_sums(const Points& set, std::size_t lo, std::size_t hi, double ox, double oy, double r,
                double out[10]) {
  const double* pa = set.a;
  const double* pb = set.b;
  double s0 = 0, s1 = 0, s2 = 0, s3 = 0, s4 = 0, s6 = 0, s7 = 0, s8 = 0, s9 = 0;
  // The block's sums may be taken in any order (vector lanes); the compensated accumulators
  // across blocks keep the total accurate.
#pragma omp simd reduction(+ : s0, s1, s2, s3, s4, s6, s7, s8, s9)
  for (std::size_t i = lo; i < hi; ++i) {
    const double dx = pa[i] - ox;
    const double dy = pb[i] - oy;
    // sqrt instead of std::hypot in the hot loop: the data are centred, so dx^2 + dy^2
    // cannot overflow or underflow for any coordinate in mm, and hypot is ~10x slower.
    const double d = std::sqrt(dx * dx + dy * dy);
    // No branch, so that the loop is vectorised: a point exactly on the centre has
    // dx = dy = 0 and so ux = uy = 0 whatever inv is.
    const double inv = 1.0 / std::max(d, std::numeric_limits<double>::min());
    const double ux = dx * inv, uy = dy * inv;
    const double e = d - r;
    // Jacobian row is (-ux, -uy, -1); signs are folded into the step below.
    s0 += ux * ux;
    s1 += ux * uy;
    s2 += ux;
    s3 += uy * uy;
    s4 += uy;
    s6 += ux * e;
    s7 += uy * e;
    s8 += e;
    s9 += e * e;
  }
  const double sums[10] = {s0, s1, s2, s3, s4, static_cast<double>(hi - lo), s6, s7, s8, s9};
  std::copy(sums, sums + 10, out);
}

// Each pass's block sums are worked out (side by side with threads > 1) and then added in block
// order: the same fit to the bit for any thread count.
Circle lsc_refine(std::span<const Points> sets, Vec2 m, Circle start, unsigned threads = 1) {
  struct Eval {
    double jtj[6];  // xx, xy, xr, yy, yr, rr
    double jte[3];
    double cost;
  };
  struct Block {
    const Points* set;
    std::size_t lo, hi;
  };
  std::vector<Block> blocks;
  for (const Points& set : sets) {
    for (std::size_t lo = 0; lo < set.n; lo += kBlock) {
      blocks.push_back({&set, lo, std::min(set.n, lo + kBlock)});
    }
  }
  std::vector<std::array<double, 10>> sums(blocks.size());
  auto evaluate = [&](double cx, double cy, double r) {
    const double ox = m.x + cx, oy = m.y + cy;
    // One stretch of blocks per thread (a thread's start costs ~0.1 ms); one thread works them
    // all in place.
    const unsigned t = std::max(threads, 1u);
    const std::size_t per = (blocks.size() + t - 1) / t;
    for_blocks(blocks.size(), per, t, [&](std::size_t lo, std::size_t hi, std::size_t) {
      for (std::size_t k = lo; k < hi; ++k) {
        block_sums(*blocks[k].set, blocks[k].lo, blocks[k].hi, ox, oy, r, sums[k].data());
      }
    });
    Neumaier acc[10];
    for (const auto& block : sums) {
      for (int k = 0; k < 10; ++k) acc[k].add(block[k]);
    }
    Eval ev{};
    for (int k = 0; k < 6; ++k) ev.jtj[k] = acc[k].value();
    for (int k = 0; k < 3; ++k) ev.jte[k] = acc[6 + k].value();
    ev.cost = acc[9].value();
    return ev;
  };

  double cx = start.centre_a_mm - m.x, cy = start.centre_b_mm - m.y, r = start.radius_mm;
  Eval cur = evaluate(cx, cy, r);
  double lambda = 1e-6;
  const double scale = r + std::hypot(cx, cy);
  for (int iter = 0; iter < 200; ++iter) {
    // Normal equations (J^T J + lambda diag) delta = -J^T e with J = -(ux, uy, 1).
    const double d0 = cur.jtj[0] * (1 + lambda), d3 = cur.jtj[3] * (1 + lambda),
                 d5 = cur.jtj[5] * (1 + lambda);
    const double A[3][3] = {
        {d0, cur.jtj[1], cur.jtj[2]}, {cur.jtj[1], d3, cur.jtj[4]}, {cur.jtj[2], cur.jtj[4], d5}};
    const double g[3] = {cur.jte[0], cur.jte[1], cur.jte[2]};
    // J = -(u, 1) so J^T e = -g and the step solves A delta = g.
    const double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
                       A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
                       A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
    if (!(std::abs(det) > 0.0)) break;
    double delta[3];
    for (int k = 0; k < 3; ++k) {
      double M[3][3];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) M[i][j] = (j == k) ? g[i] : A[i][j];
      delta[k] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                  M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                  M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) /
                 det;
    }
    const double step = std::abs(delta[0]) + std::abs(delta[1]) + std::abs(delta[2]);
    const double ncx = cx + delta[0], ncy = cy + delta[1], nr = r + delta[2];
    if (step <= 1e-12 * scale && lambda <= 1e-6) {
      // Converged: a Gauss-Newton step (damping at or below its start) of 1e-12 of the radius
      // moves the circle by less than 1e-9 mm for any radius a machine tool draws, and the
      // pass that would only confirm it costs as much as a step (a quarter of a 1e6-point fit).
      cx = ncx, cy = ncy, r = nr;
      break;
    }
    const Eval trial = evaluate(ncx, ncy, nr);
    // The slack admits steps whose cost change is rounding noise: near the optimum of an
    // ill-conditioned (short-arc) fit the Gauss-Newton step is still right while the cost
    // differences it causes are below the resolution of the summed squares.
    if (trial.cost <= cur.cost * (1.0 + 1e-11)) {
      cx = ncx, cy = ncy, r = nr;
      cur = trial;
      lambda = std::max(lambda * 0.1, 1e-12);
      // Near the optimum the next step is far smaller than this one; a step of 1e-12 of the
      // radius is below 1e-9 mm for any radius a machine tool draws.
      if (step <= 1e-12 * scale) break;
    } else {
      // A rejected step this small means the cost is flat to rounding: converged.
      if (step <= 1e-13 * scale) break;
      lambda *= 10.0;
      if (lambda > 1e12) break;
    }
  }
  return {m.x + cx, m.y + cy, r};
}

// Above this many points the fit starts from the converged fit of an evenly strided subset,
// as the minimum-zone fit does: the full passes then only polish a start already within the
// noise, so a 1e6-point fit takes about 3 passes instead of 7.
constexpr std::size_t kSubsampleAbove = std::size_t{1} << 16;
constexpr std::size_t kSubsamplePoints = std::size_t{1} << 14;

}  // namespace

namespace {

// The fit over one or two point sets: the start from an evenly strided subset of all of them
// when they are large, then the full passes over each set in place (no joined copy).
Circle fit_lsc_sets(std::span<const Points> sets, Vec2 m, unsigned threads = 1) {
  std::size_t n = 0;
  for (const Points& p : sets) n += p.n;
  if (n <= kSubsampleAbove) {
    if (sets.size() == 1) {
      return lsc_refine(sets, m, fit_detail::kasa_about(sets[0].a, sets[0].b, n, m), threads);
    }
    std::vector<double> ja, jb;
    for (const Points& p : sets) {
      ja.insert(ja.end(), p.a, p.a + p.n);
      jb.insert(jb.end(), p.b, p.b + p.n);
    }
    return lsc_refine(sets, m, fit_detail::kasa_about(ja.data(), jb.data(), n, m), threads);
  }
  const std::size_t stride = n / kSubsamplePoints;
  std::vector<double> sa, sb;
  sa.reserve(n / stride + sets.size());
  sb.reserve(n / stride + sets.size());
  for (const Points& p : sets) {
    for (std::size_t i = 0; i < p.n; i += stride) {
      sa.push_back(p.a[i]);
      sb.push_back(p.b[i]);
    }
  }
  Circle rough;
  try {
    const Points sub{sa.data(), sb.data(), sa.size()};
    rough = lsc_refine({&sub, 1}, m, fit_detail::kasa_about(sa.data(), sb.data(), sa.size(), m));
  } catch (const DataError&) {
    // A degenerate subset: start from all points.
    std::vector<double> ja, jb;
    for (const Points& p : sets) {
      ja.insert(ja.end(), p.a, p.a + p.n);
      jb.insert(jb.end(), p.b, p.b + p.n);
    }
    rough = fit_detail::kasa_about(ja.data(), jb.data(), n, m);
  }
  return lsc_refine(sets, m, rough, threads);
}

}  // namespace

Circle fit_lsc(std::span<const double> a, std::span<const double> b) {
  fit_detail::check_points(a, b, "fit_lsc");
  const Points all{a.data(), b.data(), a.size()};
  return fit_lsc_sets({&all, 1}, fit_detail::mean_point(a.data(), b.data(), a.size()));
}

Circle fit_lsc(std::span<const double> a1, std::span<const double> b1, std::span<const double> a2,
               std::span<const double> b2, unsigned threads) {
  if (a1.size() != b1.size()) fit_detail::check_points(a1, b1, "fit_lsc");
  if (a2.size() != b2.size()) fit_detail::check_points(a2, b2, "fit_lsc");
  if (a1.size() < 3 || a2.size() < 3) {
    // Too few in one set for its own mean: join them (a few points at most).
    std::vector<double> ja(a1.begin(), a1.end()), jb(b1.begin(), b1.end());
    ja.insert(ja.end(), a2.begin(), a2.end());
    jb.insert(jb.end(), b2.begin(), b2.end());
    return fit_lsc(ja, jb);
  }
  const std::size_t n1 = a1.size(), n2 = a2.size();
  const Vec2 m1 = fit_detail::mean_point(a1.data(), b1.data(), n1);
  const Vec2 m2 = fit_detail::mean_point(a2.data(), b2.data(), n2);
  const double w1 = static_cast<double>(n1) / static_cast<double>(n1 + n2);
  const Vec2 m{m1.x + (m2.x - m1.x) * (1.0 - w1), m1.y + (m2.y - m1.y) * (1.0 - w1)};
  const Points sets[2] = {{a1.data(), b1.data(), n1}, {a2.data(), b2.data(), n2}};
  return fit_lsc_sets(sets, m, threads);
}

}  // namespace circtest
