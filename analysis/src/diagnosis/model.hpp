#pragma once
// The diagnosis model shared by its stages (docs/diagnosis.md states the model and its signs):
// the samples of all runs, the nonlinear state, the model's columns and their values per
// sample, and the threads the passes over the samples run on. The per-sample functions are
// inline here so that every stage's loops over the samples compile as one.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "circtest/core/parallel.hpp"

namespace circtest::diagnosis_detail {

constexpr double kPi = std::numbers::pi;
// exp(-kSpikeCut) = 1e-304: a spike term further from its reversal than this many time
// constants is taken as zero (it changes no sum; exp's underflow path is slow).
constexpr double kSpikeCut = 700.0;
// Samples the model fit needs per candidate term (docs/diagnosis.md): two left over for each
// term's residual, so that its standard error and the identifiability test have something to
// go on.
constexpr std::size_t kSamplesPerTerm = 3;

enum class Kind {
  centre_a,
  centre_b,
  radius,  // per feed group
  scale_mismatch,
  squareness,
  servo,
  backlash_a,
  backlash_b,
  spike_a,
  spike_b,
  cyclic_a_sin,
  cyclic_a_cos,
  cyclic_b_sin,
  cyclic_b_cos,
  // Derivatives of the spike terms with respect to their decay, for its standard error only.
  spike_tau_a,
  spike_tau_b,
};

struct Column {
  Kind kind;
  int group = 0;  // feed group of a radius column
  bool operator==(const Column&) const = default;
};

struct RunInfo {
  std::size_t begin = 0, end = 0;  // into the sample arrays
  std::size_t trace_begin = 0;     // the trace row of sample `begin`
  double dir = 1.0;                // +1 CCW, -1 CW
  double speed_mm_s = 0.0;         // 0 when unknown
  // The speed the direction-dependent (servo mismatch) ellipse scales with: the run's speed, or
  // with the feed unknown the radius per second, so that the servo column's coefficient is the
  // phase difference w dtau in rad (docs/diagnosis.md, "Without a feed").
  double ellipse_speed_mm_s = 0.0;
  // About a sample period in angle: samples this close to a reversal are left out of the fit
  // and the residual's G, since the reversal instant is known only to a sample.
  double eps_rad = 0.0;
  int group = 0;
};

// All measured samples of all runs, in run order.
struct Samples {
  std::vector<double> c, s;  // cos, sin of the measured angle about the nominal centre
  std::vector<double> dr;    // radius minus nominal radius
  // The measured axis positions: the trace's columns, not copied (sample i of a run is row
  // trace_begin + (i - begin)).
  const double* col_a = nullptr;
  const double* col_b = nullptr;
  std::vector<double> u;  // the measured angle unwrapped along the run, rad
  std::vector<std::uint32_t> run;
  std::vector<RunInfo> runs;
  double radius = 0.0;
  std::size_t size() const { return dr.size(); }
  double pos(int ax, std::size_t i) const {
    const RunInfo& r = runs[run[i]];
    return (ax == 0 ? col_a : col_b)[r.trace_begin + (i - r.begin)];
  }
  // The range of an axis' positions over the samples: max - min.
  double pos_span(int ax) const {
    double mn = std::numeric_limits<double>::infinity(), mx = -mn;
    for (const RunInfo& r : runs) {
      const double* p = (ax == 0 ? col_a : col_b) + r.trace_begin;
      for (std::size_t k = 0; k < r.end - r.begin; ++k) {
        mn = std::min(mn, p[k]);
        mx = std::max(mx, p[k]);
      }
    }
    return mx - mn;
  }
};

// The measured mean profile of one axis' reversal spike (spike_profile.cpp): the axis'
// deviation against the time since its reversal, outwards positive, on a grid of one bin per
// sample period (value k at (k + 1/2) bin_s), divided by the spike's height so that the
// fitted amplitude is the height; zero past the grid.
struct SpikeShape {
  double bin_s = 0.0;
  std::vector<double> v;
  double end_s() const { return static_cast<double>(v.size()) * bin_s; }
  // Linear between the grid's points; the first point's value before it.
  double at(double dt_s) const {
    const double x = dt_s / bin_s - 0.5;
    if (!(x < static_cast<double>(v.size()) - 0.5)) return 0.0;
    if (x <= 0.0) return v.front();
    const auto k = static_cast<std::size_t>(x);
    if (k + 1 >= v.size()) return v.back();
    const double f = x - static_cast<double>(k);
    return v[k] + f * (v[k + 1] - v[k]);
  }
};

// The nonlinear parts, held fixed while the linear parameters are fitted.
struct State {
  double backlash_a = 0.0, backlash_b = 0.0;  // current play estimate for the transition shape
  double tau_a = 0.0, tau_b = 0.0;            // spike decay, s
  double pitch_a = 0.0, pitch_b = 0.0;        // cyclic pitch, mm
  // Lag of A minus lag of B: the motor of A reverses at theta = k pi + dir w dtau as the
  // instrument sees it (its angle follows the other axis there), B at pi/2 + k pi - dir w dtau.
  double servo_mismatch_s = 0.0;
  double spike_h_a = 0.0, spike_h_b = 0.0;  // heights, for the decay derivatives
  // Each axis' spike as its measured profile; without one, the decaying step
  // exp(-t / tau) (the decay search, spikes.cpp, fits that first).
  std::array<std::shared_ptr<const SpikeShape>, 2> spike_shape{};
  bool operator==(const State&) const = default;
};

// Axis ax's spike dt_s seconds after its reversal per unit of its height: the measured
// profile when the state has one, else the decaying step exp(-dt / tau) (zero when tau is not
// set, and past exp(-700) = 1e-304, where exp's underflow path is slow).
inline double spike_unit(const State& st, int ax, double dt_s) {
  if (const auto& shape = st.spike_shape[static_cast<std::size_t>(ax)]) return shape->at(dt_s);
  const double tau = ax == 0 ? st.tau_a : st.tau_b;
  if (tau <= 0) return 0.0;
  const double x = dt_s / tau;
  return x > kSpikeCut ? 0.0 : std::exp(-x);
}

inline double sgn(double v) {
  return v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0);
}

// The passes over all samples run on up to this many threads, over fixed blocks of the sample
// range whose partial results are combined in block order: the result does not depend on the
// number of threads.
constexpr std::size_t kBlockSamples = 16384;

// The number of threads the passes over all samples run on (up to 8, decided once).
unsigned diagnosis_threads();

// fn(lo, hi, block) for every block [lo, hi) of [0, n), on up to 8 threads. A block's
// exception (an allocation that failed) reaches the caller, the first in block order.
template <class F>
void for_blocks(std::size_t n, F&& fn) {
  circtest::for_blocks(n, kBlockSamples, diagnosis_threads(), std::forward<F>(fn));
}

// fn(k) for k in [0, n) as independent tasks on the same threads (each writes only its own
// results), errors reported as for_blocks.
template <class F>
void for_each_task(std::size_t n, F&& fn) {
  run_tasks(n, diagnosis_threads(), [&](std::size_t k) { fn(k); });
}

// The reversal bookkeeping depends on the state only through the lag mismatch. It is worked
// out where a pass reads it, not cached: a cache of 1e6 entries cost more in fresh pages and
// memory traffic than the few operations it saves, since the mismatch changes with every
// Gauss-Newton step anyway.
//
// No trig per sample: c, s are the cosine and sine of the measured angle u, and the reversal
// angle `rev` is constant along a run, so cos(u - rev) and sin(u - rev) follow from c, s and
// the run's cos(rev), sin(rev); cos(since) is cos(u - rev) times the parity of the half turns
// passed.
struct Reversal {
  double since_a, since_b;   // angle travelled since the last reversal, rad
  double trav_a, trav_b;     // the motor's travel since then, mm
  std::int8_t dir_a, dir_b;  // axis direction after it
};

// +1 for an even whole number, -1 for an odd one, as fmod(k, 2) == 0 tells (k / 2 is exact).
inline double parity(double k) {
  const double h = k * 0.5;
  return std::floor(h) == h ? 1.0 : -1.0;
}

class Reversals {
 public:
  Reversals(const Samples& S, double servo_mismatch_s) : S_(&S), trig_(S.runs.size()) {
    for (std::size_t k = 0; k < S.runs.size(); ++k) {
      const RunInfo& r = S.runs[k];
      const double w = r.dir * r.ellipse_speed_mm_s / S.radius * servo_mismatch_s;
      RunTrig& t = trig_[k];
      t.rev_a = w;
      t.rev_b = kPi / 2 - w;
      t.ca = std::cos(t.rev_a);
      t.sa = std::sin(t.rev_a);
      t.cb = std::cos(t.rev_b);
      t.sb = std::sin(t.rev_b);
    }
  }
  Reversal at(std::size_t i) const {
    const Samples& S = *S_;
    const RunInfo& r = S.runs[S.run[i]];
    const RunTrig& t = trig_[S.run[i]];
    const double c = S.c[i], s = S.s[i], u = S.u[i];
    // cos and sin of u - rev.
    const double cos_a = c * t.ca + s * t.sa, sin_a = s * t.ca - c * t.sa;
    const double cos_b = c * t.cb + s * t.sb, sin_b = s * t.cb - c * t.sb;
    const double ka = r.dir > 0 ? std::floor((u - t.rev_a) / kPi) : std::ceil((u - t.rev_a) / kPi);
    const double kb = r.dir > 0 ? std::floor((u - t.rev_b) / kPi) : std::ceil((u - t.rev_b) / kPi);
    Reversal v;
    // As since(): the angle past the last reversal, ka (kb) half turns in.
    v.since_a = r.dir > 0 ? ((u - t.rev_a) / kPi - ka) * kPi : (ka - (u - t.rev_a) / kPi) * kPi;
    v.since_b = r.dir > 0 ? ((u - t.rev_b) / kPi - kb) * kPi : (kb - (u - t.rev_b) / kPi) * kPi;
    const double pa = parity(ka), pb = parity(kb);
    v.trav_a = S.radius * (1.0 - pa * cos_a);
    v.trav_b = S.radius * (1.0 - pb * cos_b);
    // Axis direction after its last reversal: vA = -dir R w sin(theta), vB = dir R w cos
    // (cos(u + w) = -sin(u - rev_b)).
    v.dir_a = static_cast<std::int8_t>(-r.dir * sgn(sin_a));
    v.dir_b = static_cast<std::int8_t>(-r.dir * sgn(sin_b));
    return v;
  }

 private:
  struct RunTrig {
    double rev_a, rev_b;    // reversal angles (mod pi)
    double ca, sa, cb, sb;  // their cosines and sines
  };
  const Samples* S_;
  std::vector<RunTrig> trig_;
};

inline bool at_reversal(const Samples& S, std::size_t i, const Reversal& rv) {
  const double eps = S.runs[S.run[i]].eps_rad;
  return eps > 0 && (rv.since_a < eps || rv.since_b < eps);
}

// Backlash of one axis: the table keeps its place after a reversal until the motor has
// travelled the play b, then lags by b/2 against the motion. Returns the derivative of the
// axis deviation with respect to b at `b` and the part not proportional to b (so that
// deviation = b * derivative + offset at the current b).
inline std::pair<double, double> backlash_terms(double new_dir, double travelled_mm, double b) {
  const double old_dir = -new_dir;
  if (b > 0.0 && travelled_mm < b) return {-old_dir / 2.0, old_dir * travelled_mm};
  return {old_dir / 2.0, 0.0};
}

// The value of a column of kind K at sample i (rv: its reversal bookkeeping; the cyclic and
// geometric columns do not read it).
template <Kind K>
double term(const Samples& S, const State& st, const Column& col, std::size_t i,
            const Reversal& rv) {
  const double c = S.c[i], s = S.s[i];
  const RunInfo& r = S.runs[S.run[i]];
  const double R = S.radius;
  if constexpr (K == Kind::centre_a) {
    return c;
  } else if constexpr (K == Kind::centre_b) {
    return s;
  } else if constexpr (K == Kind::radius) {
    return r.group == col.group ? 1.0 : 0.0;
  } else if constexpr (K == Kind::scale_mismatch) {
    return 0.5 * R * (c * c - s * s);
  } else if constexpr (K == Kind::squareness) {
    return R * s * c;
  } else if constexpr (K == Kind::servo) {
    return r.dir * r.ellipse_speed_mm_s * s * c;
  } else if constexpr (K == Kind::backlash_a) {
    return backlash_terms(rv.dir_a, rv.trav_a, st.backlash_a).first * c;
  } else if constexpr (K == Kind::backlash_b) {
    return backlash_terms(rv.dir_b, rv.trav_b, st.backlash_b).first * s;
  } else if constexpr (K == Kind::spike_a) {
    if (r.speed_mm_s <= 0) return 0.0;
    return -static_cast<double>(rv.dir_a) * spike_unit(st, 0, rv.since_a * R / r.speed_mm_s) * c;
  } else if constexpr (K == Kind::spike_b) {
    if (r.speed_mm_s <= 0) return 0.0;
    return -static_cast<double>(rv.dir_b) * spike_unit(st, 1, rv.since_b * R / r.speed_mm_s) * s;
  } else if constexpr (K == Kind::spike_tau_a) {
    if (st.tau_a <= 0 || r.speed_mm_s <= 0) return 0.0;
    const double dt = rv.since_a * R / r.speed_mm_s;
    if (dt > kSpikeCut * st.tau_a) return 0.0;
    return st.spike_h_a * -static_cast<double>(rv.dir_a) * std::exp(-dt / st.tau_a) * dt /
           (st.tau_a * st.tau_a) * c;
  } else if constexpr (K == Kind::spike_tau_b) {
    if (st.tau_b <= 0 || r.speed_mm_s <= 0) return 0.0;
    const double dt = rv.since_b * R / r.speed_mm_s;
    if (dt > kSpikeCut * st.tau_b) return 0.0;
    return st.spike_h_b * -static_cast<double>(rv.dir_b) * std::exp(-dt / st.tau_b) * dt /
           (st.tau_b * st.tau_b) * s;
  } else if constexpr (K == Kind::cyclic_a_sin) {
    return std::sin(2 * kPi * S.pos(0, i) / st.pitch_a) * c;
  } else if constexpr (K == Kind::cyclic_a_cos) {
    return std::cos(2 * kPi * S.pos(0, i) / st.pitch_a) * c;
  } else if constexpr (K == Kind::cyclic_b_sin) {
    return std::sin(2 * kPi * S.pos(1, i) / st.pitch_b) * s;
  } else {
    static_assert(K == Kind::cyclic_b_cos);
    return std::cos(2 * kPi * S.pos(1, i) / st.pitch_b) * s;
  }
}

// f(std::integral_constant<Kind, k>{}): the kind as a compile-time constant, so that a loop
// over the samples inside f has no switch per sample.
template <class F>
decltype(auto) with_kind(Kind k, F&& f) {
  switch (k) {
    case Kind::centre_a:
      return f(std::integral_constant<Kind, Kind::centre_a>{});
    case Kind::centre_b:
      return f(std::integral_constant<Kind, Kind::centre_b>{});
    case Kind::radius:
      return f(std::integral_constant<Kind, Kind::radius>{});
    case Kind::scale_mismatch:
      return f(std::integral_constant<Kind, Kind::scale_mismatch>{});
    case Kind::squareness:
      return f(std::integral_constant<Kind, Kind::squareness>{});
    case Kind::servo:
      return f(std::integral_constant<Kind, Kind::servo>{});
    case Kind::backlash_a:
      return f(std::integral_constant<Kind, Kind::backlash_a>{});
    case Kind::backlash_b:
      return f(std::integral_constant<Kind, Kind::backlash_b>{});
    case Kind::spike_a:
      return f(std::integral_constant<Kind, Kind::spike_a>{});
    case Kind::spike_b:
      return f(std::integral_constant<Kind, Kind::spike_b>{});
    case Kind::cyclic_a_sin:
      return f(std::integral_constant<Kind, Kind::cyclic_a_sin>{});
    case Kind::cyclic_a_cos:
      return f(std::integral_constant<Kind, Kind::cyclic_a_cos>{});
    case Kind::cyclic_b_sin:
      return f(std::integral_constant<Kind, Kind::cyclic_b_sin>{});
    case Kind::cyclic_b_cos:
      return f(std::integral_constant<Kind, Kind::cyclic_b_cos>{});
    case Kind::spike_tau_a:
      return f(std::integral_constant<Kind, Kind::spike_tau_a>{});
    case Kind::spike_tau_b:
      return f(std::integral_constant<Kind, Kind::spike_tau_b>{});
  }
  return f(std::integral_constant<Kind, Kind::centre_a>{});
}

inline double value(const Samples& S, const State& st, const Column& col, std::size_t i,
                    const Reversal& rv) {
  return with_kind(col.kind, [&](auto k) { return term<decltype(k)::value>(S, st, col, i, rv); });
}

// A column that does not read the reversal bookkeeping (geometric or cyclic).
inline double plain_value(const Samples& S, const State& st, const Column& col, std::size_t i) {
  return value(S, st, col, i, Reversal{});
}

// Column `col` at the samples idx[0..m) into out[0], out[step], ... (the kind dispatched once
// per column, not per sample).
inline void fill_column(const Samples& S, const State& st, const Column& col,
                        const std::size_t* idx, const Reversal* rvs, std::size_t m, double* out,
                        std::size_t step) {
  with_kind(col.kind, [&](auto k) {
    for (std::size_t q = 0; q < m; ++q)
      out[q * step] = term<decltype(k)::value>(S, st, col, idx[q], rvs[q]);
  });
}

// The part of the model that is not linear in the parameters (backlash transitions).
inline double offset(const Samples& S, const State& st, const std::vector<Column>& cols,
                     std::size_t i, const Reversal& rv) {
  double o = 0.0;
  if (st.servo_mismatch_s != 0.0) {
    // Second order of unequal lags (phase difference d = w dtau) at the measured angle:
    // dr = -R d^2 (5/16 + 3/16 cos 4theta); the constant part stays in the radius change.
    const RunInfo& r = S.runs[S.run[i]];
    const double d = r.ellipse_speed_mm_s / S.radius * st.servo_mismatch_s;
    const double c2 = S.c[i] * S.c[i] - S.s[i] * S.s[i], s2 = 2.0 * S.c[i] * S.s[i];
    o += -S.radius * d * d * (3.0 / 16.0) * (c2 * c2 - s2 * s2);
  }
  for (const Column& col : cols) {
    if (col.kind == Kind::backlash_a && st.backlash_a > 0) {
      o += backlash_terms(rv.dir_a, rv.trav_a, st.backlash_a).second * S.c[i];
    } else if (col.kind == Kind::backlash_b && st.backlash_b > 0) {
      o += backlash_terms(rv.dir_b, rv.trav_b, st.backlash_b).second * S.s[i];
    }
  }
  return o;
}

// The name of a term as the report gives it ("backlash X", "squareness", ...).
std::string kind_name(Kind k, const std::array<char, 2>& axes);
// Where a term's value goes in the diagnosis document ("backlash_mm.X", "squareness_urad");
// empty for the set-up's terms (centre offset, radius change) and the decay derivatives.
std::string term_key(Kind k, const std::array<char, 2>& axes);
// The place of the column of kind k (of feed group `group` for a radius column) in cols.
std::optional<std::size_t> find(const std::vector<Column>& cols, Kind k, int group = 0);

// Golden-section search of f on [lo, hi] (log-spaced argument handled by the caller).
template <class F>
double golden(F f, double lo, double hi, int iterations) {
  const double r = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = lo, b = hi;
  double x1 = b - r * (b - a), x2 = a + r * (b - a);
  double f1 = f(x1), f2 = f(x2);
  for (int k = 0; k < iterations; ++k) {
    if (f1 < f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - r * (b - a);
      f1 = f(x1);
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + r * (b - a);
      f2 = f(x2);
    }
  }
  return f1 < f2 ? x1 : x2;
}

}  // namespace circtest::diagnosis_detail
