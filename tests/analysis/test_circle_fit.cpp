// Circle fits against independent truths: the certified TraCIM minimum-zone reference set,
// closed-form least-squares and minimum-zone cases, and analytic MCC/MIC cases. The
// minimum-zone certificate is re-checked here from the raw points, not trusted.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/analysis/circle_fit.hpp"
#include "circtest/core/error.hpp"
#include "reference.hpp"

namespace circtest {
namespace {

constexpr double kPi = std::numbers::pi;

struct Points {
  std::vector<double> a, b;
  void add(double x, double y) {
    a.push_back(x);
    b.push_back(y);
  }
  std::size_t size() const { return a.size(); }
};

const std::string kTracimDir = circtest::testing::reference_path("tracim-circle-2d/");

Points read_xy(const std::string& path) {
  std::ifstream in(path);
  if (!in) ADD_FAILURE() << "cannot open " << path;
  Points p;
  std::string line;
  std::getline(in, line);  // header x,y
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const auto comma = line.find(',');
    p.add(std::strtod(line.substr(0, comma).c_str(), nullptr),
          std::strtod(line.substr(comma + 1).c_str(), nullptr));
  }
  return p;
}

struct Answer {
  std::string name;
  double cx, cy, r, w;
};

std::vector<Answer> read_answers() {
  std::ifstream in(kTracimDir + "answers.csv");
  std::vector<Answer> out;
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::stringstream ss(line);
    Answer a;
    std::string field;
    std::getline(ss, a.name, ',');
    std::getline(ss, field, ',');
    a.cx = std::strtod(field.c_str(), nullptr);
    std::getline(ss, field, ',');
    a.cy = std::strtod(field.c_str(), nullptr);
    std::getline(ss, field, ',');
    a.r = std::strtod(field.c_str(), nullptr);
    std::getline(ss, field, ',');
    a.w = std::strtod(field.c_str(), nullptr);
    out.push_back(a);
  }
  return out;
}

double zone_at(const Points& p, double cx, double cy) {
  double lo = INFINITY, hi = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double d = std::hypot(p.a[i] - cx, p.b[i] - cy);
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  return hi - lo;
}

// Re-derives the optimality certificate from the points: every point inside the zone, the
// contacts on its boundaries, alternating outer/inner around the centre, and the multipliers
// balancing the outer unit vectors against the inner ones.
void expect_certificate(const Points& p, const MinimumZone& z) {
  ASSERT_TRUE(z.certified);
  const double tol = 1e-12 * z.outer_radius_mm;
  double lo = INFINITY, hi = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double d = std::hypot(p.a[i] - z.centre_a_mm, p.b[i] - z.centre_b_mm);
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  EXPECT_NEAR(hi, z.outer_radius_mm, tol);
  EXPECT_NEAR(lo, z.inner_radius_mm, tol);
  EXPECT_NEAR(z.zone_width_mm, hi - lo, 2 * tol);
  ASSERT_EQ(z.outer_contacts.size(), 2u);
  ASSERT_EQ(z.inner_contacts.size(), 2u);
  ASSERT_EQ(z.multipliers.size(), 4u);
  struct Contact {
    double angle;
    bool outer;
    double ux, uy, w;
  };
  std::vector<Contact> c;
  for (std::size_t k = 0; k < 4; ++k) {
    const bool outer = k < 2;
    const std::size_t i = outer ? z.outer_contacts[k] : z.inner_contacts[k - 2];
    ASSERT_LT(i, p.size());
    const double dx = p.a[i] - z.centre_a_mm, dy = p.b[i] - z.centre_b_mm;
    const double d = std::hypot(dx, dy);
    EXPECT_NEAR(d, outer ? hi : lo, tol) << "contact " << i;
    c.push_back({std::atan2(dy, dx), outer, dx / d, dy / d, z.multipliers[k]});
  }
  double sum_o = 0, sum_i = 0, bx = 0, by = 0;
  for (const Contact& k : c) {
    EXPECT_GE(k.w, 0.0);
    (k.outer ? sum_o : sum_i) += k.w;
    bx += (k.outer ? 1 : -1) * k.w * k.ux;
    by += (k.outer ? 1 : -1) * k.w * k.uy;
  }
  EXPECT_NEAR(sum_o, 0.5, 1e-12);
  EXPECT_NEAR(sum_i, 0.5, 1e-12);
  EXPECT_NEAR(bx, 0.0, 1e-9);
  EXPECT_NEAR(by, 0.0, 1e-9);
  if (hi - lo > tol) {
    std::sort(c.begin(), c.end(),
              [](const Contact& x, const Contact& y) { return x.angle < y.angle; });
    for (std::size_t k = 0; k < 4; ++k) {
      EXPECT_NE(c[k].outer, c[(k + 1) % 4].outer) << "contacts do not alternate";
    }
  }
}

// Local optimality probed directly: no small move of the centre narrows the zone.
void expect_local_minimum(const Points& p, const MinimumZone& z, double step) {
  const double w0 = zone_at(p, z.centre_a_mm, z.centre_b_mm);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ang(0.0, 2 * kPi);
  for (int k = 0; k < 200; ++k) {
    const double t = ang(rng);
    for (double s : {step, step * 1e-2, step * 1e-4}) {
      const double w = zone_at(p, z.centre_a_mm + s * std::cos(t), z.centre_b_mm + s * std::sin(t));
      EXPECT_GE(w, w0 - 1e-12 * z.outer_radius_mm);
    }
  }
}

TEST(CircleFitTracim, EveryCaseMatchesCertifiedAnswer) {
  CIRCTEST_SKIP_WITHOUT_REFERENCE(kTracimDir + "answers.csv");
  const auto answers = read_answers();
  ASSERT_EQ(answers.size(), 8u);
  double worst_w = 0, worst_c = 0;
  for (const Answer& ans : answers) {
    SCOPED_TRACE(ans.name);
    const Points p = read_xy(kTracimDir + ans.name + ".csv");
    ASSERT_GE(p.size(), 3u);
    const MinimumZone z = fit_mzc(p.a, p.b);
    const double ew = std::abs(z.zone_width_mm - ans.w);
    const double ec = std::hypot(z.centre_a_mm - ans.cx, z.centre_b_mm - ans.cy);
    std::printf("%s: n=%zu zone %.15f (ref %.15f) |dw| %.3e |dc| %.3e\n", ans.name.c_str(),
                p.size(), z.zone_width_mm, ans.w, ew, ec);
    worst_w = std::max(worst_w, ew);
    worst_c = std::max(worst_c, ec);
    EXPECT_LE(ew, 1e-9);
    EXPECT_LE(ec, 1e-6);
    expect_certificate(p, z);
  }
  std::printf("TraCIM worst: |dw| %.3e mm, |dc| %.3e mm\n", worst_w, worst_c);
}

Points lobed(double cx, double cy, double r, double amp, int lobes, std::size_t n,
             double from = 0.0, double span = 2 * kPi, bool closed = true) {
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = from + span * static_cast<double>(i) / static_cast<double>(closed ? n : n - 1);
    const double rr = r + amp * std::cos(lobes * t);
    p.add(cx + rr * std::cos(t), cy + rr * std::sin(t));
  }
  return p;
}

TEST(CircleFitLsc, LobedFormFarFromOriginHasTrueCentreAndRadius) {
  // On uniformly spaced angles a 2- or 3-lobe form is orthogonal to the centre and radius
  // terms, so the true circle is the exact LSC, at a deviation of 1e-7 of the radius.
  for (int lobes : {2, 3}) {
    const Points p = lobed(1e4, -1e4, 50.0, 50.0 * 1e-7, lobes, 360);
    const Circle c = fit_lsc(p.a, p.b);
    EXPECT_NEAR(c.centre_a_mm, 1e4, 1e-10) << lobes;
    EXPECT_NEAR(c.centre_b_mm, -1e4, 1e-10) << lobes;
    EXPECT_NEAR(c.radius_mm, 50.0, 1e-10) << lobes;
  }
}

TEST(CircleFitLsc, PartialArcAndNoisyData) {
  // Exact circle on a 90 deg arc: LSC is the circle itself.
  const Points arc = lobed(-300.0, 120.0, 75.0, 0.0, 0, 200, 0.3, kPi / 2, false);
  const Circle c = fit_lsc(arc.a, arc.b);
  EXPECT_NEAR(c.centre_a_mm, -300.0, 1e-9);
  EXPECT_NEAR(c.centre_b_mm, 120.0, 1e-9);
  EXPECT_NEAR(c.radius_mm, 75.0, 1e-9);
  // With a 3-lobe form on the arc the residuals are no longer orthogonal; the result must
  // still be a stationary point of the geometric cost: sum e_i u_i = 0 and sum e_i = 0.
  const Points f = lobed(-300.0, 120.0, 75.0, 0.01, 3, 200, 0.3, kPi / 2, false);
  const Circle g = fit_lsc(f.a, f.b);
  double se = 0, sx = 0, sy = 0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double dx = f.a[i] - g.centre_a_mm, dy = f.b[i] - g.centre_b_mm;
    const double d = std::hypot(dx, dy);
    se += d - g.radius_mm;
    sx += (d - g.radius_mm) * dx / d;
    sy += (d - g.radius_mm) * dy / d;
  }
  EXPECT_NEAR(se, 0.0, 1e-11);
  EXPECT_NEAR(sx, 0.0, 1e-11);
  EXPECT_NEAR(sy, 0.0, 1e-11);
}

TEST(CircleFitLsc, AlgebraicFitIsExactOnACircle) {
  const Points p = lobed(1e4, -1e4, 50.0, 0.0, 0, 100);
  const Circle c = fit_lsc_algebraic(p.a, p.b);
  EXPECT_NEAR(c.centre_a_mm, 1e4, 1e-9);
  EXPECT_NEAR(c.centre_b_mm, -1e4, 1e-9);
  EXPECT_NEAR(c.radius_mm, 50.0, 1e-9);
}

TEST(CircleFitRange, RadialRangeOfALobedForm) {
  const Points p = lobed(3.0, 4.0, 10.0, 0.5, 2, 8);
  const RadialRange r = radial_range(p.a, p.b, 3.0, 4.0);
  EXPECT_NEAR(r.min_mm, 9.5, 1e-12);
  EXPECT_NEAR(r.max_mm, 10.5, 1e-12);
  EXPECT_NEAR(r.width_mm(), 1.0, 1e-12);
}

TEST(CircleFitMzc, TwoLobeFormHasZoneTwiceTheAmplitude) {
  for (auto [cx, cy] : {std::pair{0.0, 0.0}, std::pair{1e4, -1e4}}) {
    const double e = 5e-6;  // 1e-7 of the radius
    const Points p = lobed(cx, cy, 50.0, e, 2, 360);
    const MinimumZone z = fit_mzc(p.a, p.b);
    EXPECT_NEAR(z.zone_width_mm, 2 * e, 1e-10);
    EXPECT_NEAR(z.centre_a_mm, cx, 1e-6);
    EXPECT_NEAR(z.centre_b_mm, cy, 1e-6);
    EXPECT_NEAR(z.mean_radius_mm(), 50.0, 1e-9);
    expect_certificate(p, z);
  }
}

TEST(CircleFitMzc, PartialArcs) {
  // dr = e cos(3 pi s / span) on an arc has alternating extremes at its ends and thirds, so
  // the true circle satisfies the minimum-zone condition with zone 2e.
  for (double span_deg : {90.0, 180.0, 270.0}) {
    const double span = span_deg * kPi / 180.0;
    const double e = 0.004;
    Points p;
    const std::size_t n = 301;
    for (std::size_t i = 0; i < n; ++i) {
      const double s = span * static_cast<double>(i) / static_cast<double>(n - 1);
      const double t = 0.7 + s;
      const double rr = 40.0 + e * std::cos(3 * kPi * s / span);
      p.add(250.0 + rr * std::cos(t), -80.0 + rr * std::sin(t));
    }
    const MinimumZone z = fit_mzc(p.a, p.b);
    SCOPED_TRACE(span_deg);
    EXPECT_NEAR(z.zone_width_mm, 2 * e, 1e-10);
    EXPECT_NEAR(z.centre_a_mm, 250.0, 1e-6);
    EXPECT_NEAR(z.centre_b_mm, -80.0, 1e-6);
    expect_certificate(p, z);
  }
}

Points harmonic_trace(std::size_t n, std::uint64_t seed, double cx = 12.0, double cy = -7.0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.0005);
  std::uniform_real_distribution<double> phase(0.0, 2 * kPi);
  const double amp[] = {0.020, 0.008, 0.005, 0.003, 0.001};
  const int order[] = {2, 3, 4, 7, 13};
  double ph[5];
  for (double& x : ph) x = phase(rng);
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = 2 * kPi * static_cast<double>(i) / static_cast<double>(n);
    double rr = 75.0 + noise(rng);
    for (int k = 0; k < 5; ++k) rr += amp[k] * std::cos(order[k] * t + ph[k]);
    p.add(cx + rr * std::cos(t), cy + rr * std::sin(t));
  }
  return p;
}

TEST(CircleFitMzc, HarmonicFormWithNoiseIsCertifiedAndLocallyOptimal) {
  for (std::size_t n : {50u, 1000u, 20000u, 300000u}) {
    SCOPED_TRACE(n);
    const Points p = harmonic_trace(n, 11 + n);
    const MinimumZone z = fit_mzc(p.a, p.b);
    expect_certificate(p, z);
    if (n <= 20000) expect_local_minimum(p, z, 1e-3);
    // The MZC width can never exceed the radial range about the LSC centre.
    const Circle l = fit_lsc(p.a, p.b);
    EXPECT_LE(z.zone_width_mm, radial_range(p.a, p.b, l.centre_a_mm, l.centre_b_mm).width_mm());
  }
}

TEST(CircleFitMzc, LargeInputMatchesDirectSolveOnScrambledCopy) {
  // The recursive path (subsample, candidate passes) must give the same zone as when the
  // data are reordered so that the subsample sees different points.
  const Points p = harmonic_trace(200000, 3, 1e4, -1e4);
  Points q = p;
  std::mt19937 rng(5);
  std::vector<std::size_t> perm(p.size());
  for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = i;
  std::shuffle(perm.begin(), perm.end(), rng);
  for (std::size_t i = 0; i < perm.size(); ++i) q.a[i] = p.a[perm[i]], q.b[i] = p.b[perm[i]];
  const MinimumZone zp = fit_mzc(p.a, p.b);
  const MinimumZone zq = fit_mzc(q.a, q.b);
  expect_certificate(p, zp);
  expect_certificate(q, zq);
  EXPECT_NEAR(zp.zone_width_mm, zq.zone_width_mm, 1e-11);
  EXPECT_NEAR(zp.centre_a_mm, zq.centre_a_mm, 1e-8);
  EXPECT_NEAR(zp.centre_b_mm, zq.centre_b_mm, 1e-8);
}

TEST(CircleFitMzc, DegenerateInputs) {
  // A perfect circle: zone 0.
  {
    const Points p = lobed(1e4, -1e4, 50.0, 0.0, 0, 5000);
    const MinimumZone z = fit_mzc(p.a, p.b);
    EXPECT_LE(z.zone_width_mm, 1e-10);
    EXPECT_NEAR(z.centre_a_mm, 1e4, 1e-9);
    EXPECT_NEAR(z.centre_b_mm, -1e4, 1e-9);
    EXPECT_TRUE(z.certified);
  }
  // Three points: the circle through them.
  {
    Points p;
    p.add(1.0, 0.0);
    p.add(-1.0, 0.0);
    p.add(0.0, 1.0);
    const MinimumZone z = fit_mzc(p.a, p.b);
    EXPECT_NEAR(z.zone_width_mm, 0.0, 1e-15);
    EXPECT_NEAR(z.centre_a_mm, 0.0, 1e-15);
    EXPECT_NEAR(z.centre_b_mm, 0.0, 1e-15);
    EXPECT_NEAR(z.outer_radius_mm, 1.0, 1e-15);
    EXPECT_TRUE(z.certified);
  }
  // Four points of a rectangle-like quadrilateral: two opposite at radius 1.1, two at 0.9
  // about the origin on perpendicular diameters; the zone is 0.2 at the origin.
  {
    Points p;
    p.add(1.1, 0.0);
    p.add(0.0, 0.9);
    p.add(-1.1, 0.0);
    p.add(0.0, -0.9);
    const MinimumZone z = fit_mzc(p.a, p.b);
    EXPECT_NEAR(z.zone_width_mm, 0.2, 1e-14);
    EXPECT_NEAR(z.centre_a_mm, 0.0, 1e-14);
    EXPECT_NEAR(z.centre_b_mm, 0.0, 1e-14);
    expect_certificate(p, z);
  }
  // Every point twice: same answer as once.
  {
    const Points p = harmonic_trace(500, 9);
    Points q;
    for (std::size_t i = 0; i < p.size(); ++i) q.add(p.a[i], p.b[i]), q.add(p.a[i], p.b[i]);
    const MinimumZone zp = fit_mzc(p.a, p.b);
    const MinimumZone zq = fit_mzc(q.a, q.b);
    EXPECT_NEAR(zp.zone_width_mm, zq.zone_width_mm, 1e-13);
    EXPECT_NEAR(zp.centre_a_mm, zq.centre_a_mm, 1e-10);
    expect_certificate(q, zq);
  }
}

TEST(CircleFitErrors, TooFewOrCollinearPoints) {
  const std::vector<double> two = {0.0, 1.0};
  EXPECT_THROW(fit_lsc(two, two), DataError);
  EXPECT_THROW(fit_mzc(two, two), DataError);
  EXPECT_THROW(fit_mcc(two, two), DataError);
  EXPECT_THROW(fit_mic(two, two), DataError);
  EXPECT_THROW(fit_lsc_algebraic(two, two), DataError);
  const std::vector<double> xs = {0.0, 1.0, 2.0, 3.0}, ys = {1.0, 3.0, 5.0, 7.0};
  EXPECT_THROW(fit_lsc(xs, ys), DataError);
  EXPECT_THROW(fit_mzc(xs, ys), DataError);
  EXPECT_THROW(fit_mic(xs, ys), DataError);
  const std::vector<double> three = {0.0, 1.0, 2.0};
  try {
    fit_lsc(three, two);
    ADD_FAILURE() << "length mismatch accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::data);
  }
}

Points ellipse(double cx, double cy, double a, double b, std::size_t n) {
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = 2 * kPi * static_cast<double>(i) / static_cast<double>(n);
    p.add(cx + a * std::cos(t), cy + b * std::sin(t));
  }
  return p;
}

TEST(CircleFitMccMic, Ellipse) {
  const double a = 50.0, b = 40.0, cx = -1e3, cy = 2e3;
  const std::size_t n = 36000;  // includes the four vertices
  const Points p = ellipse(cx, cy, a, b, n);
  const ContactCircle mcc = fit_mcc(p.a, p.b);
  EXPECT_NEAR(mcc.circle.radius_mm, a, 1e-11);
  EXPECT_NEAR(mcc.circle.centre_a_mm, cx, 1e-9);
  EXPECT_NEAR(mcc.circle.centre_b_mm, cy, 1e-9);
  ASSERT_EQ(mcc.contacts.size(), 2u);
  EXPECT_EQ(mcc.contacts[0], 0u);
  EXPECT_EQ(mcc.contacts[1], n / 2);
  // Sampled, the ellipse admits a circle slightly larger than b: the centre can slide along
  // the major axis by s = (a^2 - b^2) sin(dt) / 2a before the neighbours of the minor
  // vertices touch, gaining about s^2 / 2b.
  const ContactCircle mic = fit_mic(p.a, p.b).mic.value();
  const double s = (a * a - b * b) * std::sin(2 * kPi / n) / (2 * a);
  EXPECT_GE(mic.circle.radius_mm, b - 1e-12);
  EXPECT_LE(mic.circle.radius_mm, b + s * s / (2 * b) * 1.01);
  EXPECT_NEAR(mic.circle.centre_a_mm, cx, 1.01 * s);
  EXPECT_NEAR(mic.circle.centre_b_mm, cy, 1e-9);
  EXPECT_GE(mic.contacts.size(), 3u);
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_GE(std::hypot(p.a[i] - mic.circle.centre_a_mm, p.b[i] - mic.circle.centre_b_mm),
              mic.circle.radius_mm * (1 - 1e-12));
  }
}

TEST(CircleFitMccMic, AnArcOfHalfACircleOrLessHasNoMicAndSaysWhy) {
  // 150 deg of a circle: no centre is surrounded, so there is no inscribed circle; a normal
  // partial-arc test, answered as "none" with the reason, not as an error.
  Points arc;
  for (int i = 0; i <= 150; ++i) {
    const double t = i * kPi / 180.0;
    arc.a.push_back(3.0 + 50.0 * std::cos(t));
    arc.b.push_back(-1.0 + 50.0 * std::sin(t));
  }
  const MicFit none = fit_mic(arc.a, arc.b);
  EXPECT_FALSE(none.mic.has_value());
  EXPECT_NE(none.why_none.find("do not enclose the centre"), std::string::npos) << none.why_none;
  // The same radius over 360 deg: the circle itself, no reason.
  const Points full = lobed(3.0, -1.0, 50.0, 0.0, 0, 360);
  const MicFit some = fit_mic(full.a, full.b);
  ASSERT_TRUE(some.mic.has_value());
  EXPECT_NEAR(some.mic->circle.radius_mm, 50.0, 1e-9);
  EXPECT_TRUE(some.why_none.empty());
}

TEST(CircleFitMccMic, RegularPolygon) {
  for (int k : {3, 4, 5, 7, 12}) {
    SCOPED_TRACE(k);
    const Points p = lobed(7.0, -3.0, 20.0, 0.0, 0, static_cast<std::size_t>(k));
    const ContactCircle mcc = fit_mcc(p.a, p.b);
    const ContactCircle mic = fit_mic(p.a, p.b).mic.value();
    for (const ContactCircle* c : {&mcc, &mic}) {
      EXPECT_NEAR(c->circle.radius_mm, 20.0, 1e-12);
      EXPECT_NEAR(c->circle.centre_a_mm, 7.0, 1e-12);
      EXPECT_NEAR(c->circle.centre_b_mm, -3.0, 1e-12);
      EXPECT_EQ(c->contacts.size(), static_cast<std::size_t>(k));
    }
  }
}

TEST(CircleFitMccMic, RandomPointsInsideAKnownCircle) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Points p;
  const double r = 30.0, cx = 500.0, cy = 500.0;
  for (int i = 0; i < 5000; ++i) {
    const double t = 2 * kPi * u(rng), s = r * std::sqrt(u(rng)) * 0.999;
    p.add(cx + s * std::cos(t), cy + s * std::sin(t));
  }
  // Three points on the circle at 120 deg spacing pin the MCC to it.
  for (int k = 0; k < 3; ++k) {
    const double t = 0.3 + 2 * kPi * k / 3;
    p.add(cx + r * std::cos(t), cy + r * std::sin(t));
  }
  const ContactCircle mcc = fit_mcc(p.a, p.b);
  EXPECT_NEAR(mcc.circle.radius_mm, r, 1e-12);
  EXPECT_NEAR(mcc.circle.centre_a_mm, cx, 1e-11);
  EXPECT_NEAR(mcc.circle.centre_b_mm, cy, 1e-11);
  EXPECT_EQ(mcc.contacts, (std::vector<std::size_t>{5000, 5001, 5002}));
}

TEST(CircleFitMccMic, BoundedByTheMinimumZoneCircles) {
  // The MZC outer circle contains every point, so the smallest enclosing circle is no larger;
  // the MZC inner circle is empty, so the largest empty circle is no smaller. Each fit also
  // has its defining property: MCC radius = farthest point, MIC radius = nearest point.
  const Points p = harmonic_trace(20000, 21);
  const ContactCircle mcc = fit_mcc(p.a, p.b);
  const ContactCircle mic = fit_mic(p.a, p.b).mic.value();
  const RadialRange rc = radial_range(p.a, p.b, mcc.circle.centre_a_mm, mcc.circle.centre_b_mm);
  const RadialRange ri = radial_range(p.a, p.b, mic.circle.centre_a_mm, mic.circle.centre_b_mm);
  EXPECT_NEAR(rc.max_mm, mcc.circle.radius_mm, 1e-12);
  EXPECT_NEAR(ri.min_mm, mic.circle.radius_mm, 1e-11);
  const MinimumZone z = fit_mzc(p.a, p.b);
  EXPECT_LE(mcc.circle.radius_mm, z.outer_radius_mm + 1e-12);
  EXPECT_GE(mic.circle.radius_mm, z.inner_radius_mm - 1e-12);
  EXPECT_GE(mcc.contacts.size(), 2u);
  EXPECT_GE(mic.contacts.size(), 2u);
}

}  // namespace
}  // namespace circtest

namespace circtest {
namespace {

// A D150 run about (250, 250) with a 2-lobe and a 3-lobe form error (5 um each) and one
// glitched sample: y recorded as 0.
// With the outlier p at distance D > 225 from c0 a centre inside the circle needs a width of
// at least D - 75 - 0.01 > 150; a centre outside it, at distance s from c0, at least
// (s + 75) - (s - 75) - 0.02 = 150 - 0.02, and that is reached on the line from c0 towards p
// where |p - c| = s + 75 (both far sides on the outer circle): 150 - 0.02..150, less a
// little where 462 samples miss the nearest point of that line.
TEST(circle_fit_Mzc, OneGrossOutlierStillGivesTheZoneThatHoldsIt) {
  for (std::size_t n : {std::size_t{462}, std::size_t{7068}}) {
    for (std::size_t at : {std::size_t{5}, n / 3, n - 1}) {
      std::vector<double> a(n), b(n);
      for (std::size_t i = 0; i < n; ++i) {
        const double t = 2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n);
        const double r = 75.0 + 0.005 * std::cos(2 * t) + 0.005 * std::sin(3 * t + 0.3);
        a[i] = 250.0 + r * std::cos(t);
        b[i] = 250.0 + r * std::sin(t);
      }
      b[at] = 0.0;
      const double d = std::hypot(a[at] - 250.0, b[at] - 250.0);
      MinimumZone z;
      ASSERT_NO_THROW(z = fit_mzc(a, b)) << n << " " << at;
      ASSERT_GT(d, 225.0);
      EXPECT_NEAR(z.zone_width_mm, 149.99, 0.03) << n << " " << at;  // sampling: 462 points
      for (std::size_t i = 0; i < n; ++i) {
        const double di = std::hypot(a[i] - z.centre_a_mm, b[i] - z.centre_b_mm);
        ASSERT_LE(di, z.outer_radius_mm * (1 + 1e-12));
        ASSERT_GE(di, z.inner_radius_mm * (1 - 1e-12));
      }
    }
  }
}

}  // namespace
}  // namespace circtest

namespace circtest {

// The two-set LSC (H's common circle, fitted without joining the runs) is the LSC of the
// joined points, small sets and sets large enough for the subsample start alike.
TEST(CircleFitLsc, TwoSetsFitLikeTheirUnion) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.002);
  for (std::size_t n : {std::size_t{5}, std::size_t{400}, std::size_t{90000}}) {
    SCOPED_TRACE(n);
    std::vector<double> a1, b1, a2, b2;
    for (std::size_t i = 0; i < n; ++i) {
      const double t1 = 2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n);
      const double t2 = 0.3 - 1.7 * std::numbers::pi * static_cast<double>(i) /
                                  static_cast<double>(n);  // CW, 306 deg
      a1.push_back(120.0 + 60.0 * std::cos(t1) + noise(rng));
      b1.push_back(-40.0 + 60.0 * std::sin(t1) + noise(rng));
      a2.push_back(120.01 + 60.02 * std::cos(t2) + noise(rng));
      b2.push_back(-40.0 + 60.02 * std::sin(t2) + noise(rng));
    }
    std::vector<double> ja = a1, jb = b1;
    ja.insert(ja.end(), a2.begin(), a2.end());
    jb.insert(jb.end(), b2.begin(), b2.end());
    const Circle joined = fit_lsc(ja, jb);
    const Circle two = fit_lsc(a1, b1, a2, b2);
    EXPECT_NEAR(two.centre_a_mm, joined.centre_a_mm, 1e-9);
    EXPECT_NEAR(two.centre_b_mm, joined.centre_b_mm, 1e-9);
    EXPECT_NEAR(two.radius_mm, joined.radius_mm, 1e-9);
    // Its passes shared out over threads add the same block sums in the same order: the same
    // circle to the bit.
    for (unsigned threads : {2u, 3u}) {
      const Circle shared = fit_lsc(a1, b1, a2, b2, threads);
      EXPECT_EQ(shared.centre_a_mm, two.centre_a_mm) << threads;
      EXPECT_EQ(shared.centre_b_mm, two.centre_b_mm) << threads;
      EXPECT_EQ(shared.radius_mm, two.radius_mm) << threads;
    }
  }
  const std::vector<double> one = {1.0}, two_points = {1.0, 2.0};
  EXPECT_THROW(fit_lsc(one, one, two_points, one), Error);  // lengths differ
}

}  // namespace circtest
