// The diagnosis fit: docs/diagnosis.md states the model and its signs.
#include "circtest/analysis/diagnosis.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>
#include <numbers>
#include <numeric>
#include <type_traits>

#include "circtest/core/error.hpp"
#include "circtest/core/memory.hpp"
#include "circtest/core/parallel.hpp"
#include "circtest/core/trace_keys.hpp"
#include "radial_profile.hpp"
#include "rows_context.hpp"

namespace circtest {

namespace {

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

// The nonlinear parts, held fixed while the linear parameters are fitted.
struct State {
  double backlash_a = 0.0, backlash_b = 0.0;  // current play estimate for the transition shape
  double tau_a = 0.0, tau_b = 0.0;            // spike decay, s
  double pitch_a = 0.0, pitch_b = 0.0;        // cyclic pitch, mm
  // Lag of A minus lag of B: the motor of A reverses at theta = k pi + dir w dtau as the
  // instrument sees it (its angle follows the other axis there), B at pi/2 + k pi - dir w dtau.
  double servo_mismatch_s = 0.0;
  double spike_h_a = 0.0, spike_h_b = 0.0;  // heights, for the decay derivatives
  bool operator==(const State&) const = default;
};

double sgn(double v) {
  return v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0);
}

// The passes over all samples run on up to this many threads, over fixed blocks of the sample
// range whose partial results are combined in block order: the result does not depend on the
// number of threads.
constexpr std::size_t kBlockSamples = 16384;

unsigned diagnosis_threads() {
  static const unsigned threads = thread_count(ThreadCountRequest{.max_threads = 8});
  return threads;
}

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
double parity(double k) {
  const double h = k * 0.5;
  return std::floor(h) == h ? 1.0 : -1.0;
}

class Reversals {
 public:
  Reversals(const Samples& S, double servo_mismatch_s) : S_(&S), trig_(S.runs.size()) {
    for (std::size_t k = 0; k < S.runs.size(); ++k) {
      const RunInfo& r = S.runs[k];
      const double w = r.dir * r.speed_mm_s / S.radius * servo_mismatch_s;
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

bool at_reversal(const Samples& S, std::size_t i, const Reversal& rv) {
  const double eps = S.runs[S.run[i]].eps_rad;
  return eps > 0 && (rv.since_a < eps || rv.since_b < eps);
}

// Backlash of one axis: the table keeps its place after a reversal until the motor has
// travelled the play b, then lags by b/2 against the motion. Returns the derivative of the
// axis deviation with respect to b at `b` and the part not proportional to b (so that
// deviation = b * derivative + offset at the current b).
std::pair<double, double> backlash_terms(double new_dir, double travelled_mm, double b) {
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
    return r.dir * r.speed_mm_s * s * c;
  } else if constexpr (K == Kind::backlash_a) {
    return backlash_terms(rv.dir_a, rv.trav_a, st.backlash_a).first * c;
  } else if constexpr (K == Kind::backlash_b) {
    return backlash_terms(rv.dir_b, rv.trav_b, st.backlash_b).first * s;
  } else if constexpr (K == Kind::spike_a) {
    // Past exp(-700) (1e-304) a spike term is taken as zero, as profile_column does: most rows
    // are that far from a reversal, and exp's underflow path costs several times its fast one.
    if (st.tau_a <= 0 || r.speed_mm_s <= 0) return 0.0;
    const double x = rv.since_a * R / r.speed_mm_s / st.tau_a;
    if (x > kSpikeCut) return 0.0;
    return -static_cast<double>(rv.dir_a) * std::exp(-x) * c;
  } else if constexpr (K == Kind::spike_b) {
    if (st.tau_b <= 0 || r.speed_mm_s <= 0) return 0.0;
    const double x = rv.since_b * R / r.speed_mm_s / st.tau_b;
    if (x > kSpikeCut) return 0.0;
    return -static_cast<double>(rv.dir_b) * std::exp(-x) * s;
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

double value(const Samples& S, const State& st, const Column& col, std::size_t i,
             const Reversal& rv) {
  return with_kind(col.kind, [&](auto k) { return term<decltype(k)::value>(S, st, col, i, rv); });
}

// A column that does not read the reversal bookkeeping (geometric or cyclic).
double plain_value(const Samples& S, const State& st, const Column& col, std::size_t i) {
  return value(S, st, col, i, Reversal{});
}

// Column `col` at the samples idx[0..m) into out[0], out[step], ... (the kind dispatched once
// per column, not per sample).
void fill_column(const Samples& S, const State& st, const Column& col, const std::size_t* idx,
                 const Reversal* rvs, std::size_t m, double* out, std::size_t step) {
  with_kind(col.kind, [&](auto k) {
    for (std::size_t q = 0; q < m; ++q)
      out[q * step] = term<decltype(k)::value>(S, st, col, idx[q], rvs[q]);
  });
}

// The part of the model that is not linear in the parameters (backlash transitions).
double offset(const Samples& S, const State& st, const std::vector<Column>& cols, std::size_t i,
              const Reversal& rv) {
  double o = 0.0;
  if (st.servo_mismatch_s != 0.0) {
    // Second order of unequal lags (phase difference d = w dtau) at the measured angle:
    // dr = -R d^2 (5/16 + 3/16 cos 4theta); the constant part stays in the radius change.
    const RunInfo& r = S.runs[S.run[i]];
    const double d = r.speed_mm_s / S.radius * st.servo_mismatch_s;
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

struct Normal {
  Eigen::MatrixXd M;  // J^T J
  Eigen::VectorXd v;  // J^T y
  double yy = 0.0;
  std::size_t n = 0;
};

// Sums of a set of rows: J^T J (upper triangle), J^T Y and Y^T Y for the right-hand sides
// in Y's columns.
struct Sums {
  Eigen::MatrixXd M, V, YY;
  std::size_t n = 0;
  Sums(Eigen::Index p, Eigen::Index k)
      : M(Eigen::MatrixXd::Zero(p, p)),
        V(Eigen::MatrixXd::Zero(p, k)),
        YY(Eigen::MatrixXd::Zero(k, k)) {}
  Sums& operator+=(const Sums& o) {
    M += o.M;
    V += o.V;
    YY += o.YY;
    n += o.n;
    return *this;
  }
};

// The servo part of offset() divided by the square of the lag mismatch: the rows away from
// the reversals keep their sums against dr and against this, so a new mismatch needs no pass.
double servo_offset_per_s2(const Samples& S, std::size_t i) {
  const RunInfo& r = S.runs[S.run[i]];
  const double w = r.speed_mm_s / S.radius;
  const double c2 = S.c[i] * S.c[i] - S.s[i] * S.s[i], s2 = 2.0 * S.c[i] * S.s[i];
  return -S.radius * w * w * (3.0 / 16.0) * (c2 * c2 - s2 * s2);
}

// Adds the rows idx[0..m) (rvs: their reversal bookkeeping at st) to `out`: the design rows
// transposed (one per column), so J^T J is one matrix product. Y is dr - offset, or with
// `split_servo` (rows off every transition) the two columns dr and servo_offset_per_s2.
void add_rows(const Samples& S, const State& st, const std::vector<Column>& cols,
              const std::size_t* idx, const Reversal* rvs, std::size_t m, bool split_servo,
              Sums& out) {
  const auto p = static_cast<Eigen::Index>(cols.size());
  const auto mi = static_cast<Eigen::Index>(m);
  Eigen::MatrixXd Xt(p, mi);
  Eigen::MatrixXd Y(mi, split_servo ? 2 : 1);
  for (Eigen::Index j = 0; j < p; ++j) {
    fill_column(S, st, cols[static_cast<std::size_t>(j)], idx, rvs, m, Xt.data() + j,
                static_cast<std::size_t>(p));
  }
  for (std::size_t q = 0; q < m; ++q) {
    const auto qi = static_cast<Eigen::Index>(q);
    if (split_servo) {
      Y(qi, 0) = S.dr[idx[q]];
      Y(qi, 1) = servo_offset_per_s2(S, idx[q]);
    } else {
      Y(qi, 0) = S.dr[idx[q]] - offset(S, st, cols, idx[q], rvs[q]);
    }
  }
  out.M.selfadjointView<Eigen::Upper>().rankUpdate(Xt);
  out.V.noalias() += Xt * Y;
  out.YY.noalias() += Y.transpose() * Y;
  out.n += m;
}

// add_rows for the rows each(take) hands to take(i), less those at a reversal at st.
template <class Each>
void add_rows_off_reversals(const Samples& S, const State& st, const Reversals& rev,
                            const std::vector<Column>& cols, Each&& each, Sums& out) {
  std::vector<std::size_t> idx;
  std::vector<Reversal> rvs;
  each([&](std::size_t i) {
    const Reversal rv = rev.at(i);
    if (at_reversal(S, i, rv)) return;
    idx.push_back(i);
    rvs.push_back(rv);
  });
  add_rows(S, st, cols, idx.data(), rvs.data(), idx.size(), false, out);
}

Normal to_normal(const Sums& s, double servo_mismatch_s) {
  Normal N;
  N.M = s.M.selfadjointView<Eigen::Upper>();
  if (s.V.cols() == 1) {
    N.v = s.V.col(0);
    N.yy = s.YY(0, 0);
  } else {
    const double m2 = servo_mismatch_s * servo_mismatch_s;
    N.v = s.V.col(0) - m2 * s.V.col(1);
    N.yy = s.YY(0, 0) - 2.0 * m2 * s.YY(0, 1) + m2 * m2 * s.YY(1, 1);
  }
  N.n = s.n;
  return N;
}

// The angle after a reversal within which the motor takes up the play b (its travel
// R (1 - cos) is below b): the backlash columns change shape there.
double takeup_rad(double b, double radius) {
  if (!(b > 0.0)) return 0.0;
  return b >= 2.0 * radius ? kPi : std::acos(1.0 - b / radius);
}

// The sums of the rows away from every reversal, for one set of columns. There a row's columns
// do not depend on the play, and on the lag mismatch (within the window) only through factors
// common to all such rows: the backlash columns are +-1/2 cos or sin, a spike column scales by
// one factor per axis (steady_normal), and the servo offset is the lag mismatch squared times
// a fixed function. A Gauss-Newton step then works out only the rows
// near a reversal (a few percent) and adds these sums. The windows are angles before and
// after the reversals as they were when the sums were taken; a state that moves a reversal or
// a take-up of the play out of them makes the sums be taken again.
struct SteadySums {
  std::vector<Column> cols;
  std::size_t stride = 0;
  State ref;                       // the state they were taken at
  std::vector<double> before_rad;  // per run: window before a reversal
  std::vector<double> after_rad;   // per run: window after a reversal
  std::vector<std::size_t> near;   // the stride rows inside a window, in order
  std::optional<Sums> sums;        // of the others, Y = (dr, servo_offset_per_s2)
};

// Whether `cols` can use steady sums at all: a column of a decay derivative is needed once.
bool steady_applies(const std::vector<Column>& cols) {
  return std::none_of(cols.begin(), cols.end(), [](const Column& c) {
    return c.kind == Kind::spike_tau_a || c.kind == Kind::spike_tau_b;
  });
}

bool steady_valid(const Samples& S, const SteadySums& ss, const State& st,
                  const std::vector<Column>& cols, std::size_t stride) {
  if (ss.stride != stride || ss.cols != cols || st.pitch_a != ss.ref.pitch_a ||
      st.pitch_b != ss.ref.pitch_b || st.tau_a != ss.ref.tau_a || st.tau_b != ss.ref.tau_b)
    return false;
  const double need_b =
      std::max(takeup_rad(st.backlash_a, S.radius), takeup_rad(st.backlash_b, S.radius));
  for (std::size_t k = 0; k < S.runs.size(); ++k) {
    const RunInfo& r = S.runs[k];
    const double shift =
        std::abs(r.speed_mm_s / S.radius * (st.servo_mismatch_s - ss.ref.servo_mismatch_s));
    if (!(shift + r.eps_rad < ss.before_rad[k]) ||
        !(shift + std::max(r.eps_rad, need_b) < ss.after_rad[k]))
      return false;
  }
  return true;
}

SteadySums take_steady(const Samples& S, const State& st, const std::vector<Column>& cols,
                       std::size_t stride) {
  SteadySums ss;
  ss.cols = cols;
  ss.stride = stride;
  ss.ref = st;
  const double play =
      std::max({2.0 * std::abs(st.backlash_a), 2.0 * std::abs(st.backlash_b), 1e-3 * S.radius});
  for (const RunInfo& r : S.runs) {
    const double w = r.speed_mm_s / S.radius;
    // Room for the reversals to move with the lag mismatch, and for the excluded samples.
    const double room = std::max(
        {2.0 * r.eps_rad, kPi / 180.0, 2.0 * w * std::max(std::abs(st.servo_mismatch_s), 2e-3)});
    ss.before_rad.push_back(room);
    ss.after_rad.push_back(room + takeup_rad(play, S.radius));
  }
  const Reversals rev(S, st.servo_mismatch_s);
  const auto p = static_cast<Eigen::Index>(cols.size());
  const std::size_t nblocks = (S.size() + kBlockSamples - 1) / kBlockSamples;
  std::vector<Sums> part(nblocks, Sums(p, 2));
  std::vector<std::vector<std::size_t>> near(nblocks);
  for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t block) {
    std::vector<std::size_t> idx;
    std::vector<Reversal> rvs;
    for (std::size_t i = (lo + stride - 1) / stride * stride; i < hi; i += stride) {
      const Reversal rv = rev.at(i);
      const std::size_t k = S.run[i];
      const double before = ss.before_rad[k];
      const double after = ss.after_rad[k];
      if (rv.since_a < after || kPi - rv.since_a < before || rv.since_b < after ||
          kPi - rv.since_b < before) {
        near[block].push_back(i);
      } else {
        idx.push_back(i);
        rvs.push_back(rv);
      }
    }
    add_rows(S, st, cols, idx.data(), rvs.data(), idx.size(), true, part[block]);
  });
  ss.sums.emplace(p, 2);
  for (std::size_t b = 0; b < nblocks; ++b) {
    *ss.sums += part[b];
    ss.near.insert(ss.near.end(), near[b].begin(), near[b].end());
  }
  return ss;
}

// The normal equations at st from steady sums valid for it: the rows near the reversals
// worked out now, in chunks.
Normal steady_normal(const Samples& S, const SteadySums& ss, const State& st,
                     const std::vector<Column>& cols) {
  const Reversals rev(S, st.servo_mismatch_s);
  const auto p = static_cast<Eigen::Index>(cols.size());
  // Chunks side by side, added in chunk order.
  constexpr std::size_t kChunk = 4096;
  const std::size_t nchunks = (ss.near.size() + kChunk - 1) / kChunk;
  std::vector<Sums> part(nchunks, Sums(p, 1));
  for_each_task(nchunks, [&](std::size_t c) {
    add_rows_off_reversals(
        S, st, rev, cols,
        [&](auto&& take) {
          for (std::size_t t = c * kChunk; t < std::min(ss.near.size(), (c + 1) * kChunk); ++t)
            take(ss.near[t]);
        },
        part[c]);
  });
  Sums near(p, 1);
  for (const Sums& c : part) near += c;
  Normal N = to_normal(*ss.sums, st.servo_mismatch_s);
  // A spike column on a steady row is exp(-t / tau) times a fixed part, t the time since the
  // reversal, and a new lag mismatch moves the reversals by its change d in time: A's column
  // scales by exp(d / tau_a) and B's by exp(-d / tau_b) on every such row (docs/diagnosis.md:
  // the reversal of A at w dtau, of B at pi/2 - w dtau).
  const double d = st.servo_mismatch_s - ss.ref.servo_mismatch_s;
  if (d != 0.0) {
    Eigen::VectorXd scale = Eigen::VectorXd::Ones(p);
    for (Eigen::Index j = 0; j < p; ++j) {
      const Kind k = cols[static_cast<std::size_t>(j)].kind;
      if (k == Kind::spike_a && st.tau_a > 0) scale[j] = std::exp(d / st.tau_a);
      if (k == Kind::spike_b && st.tau_b > 0) scale[j] = std::exp(-d / st.tau_b);
    }
    N.M = scale.asDiagonal() * N.M * scale.asDiagonal();
    N.v = scale.asDiagonal() * N.v;
  }
  const Normal Nn = to_normal(near, 0.0);
  N.M += Nn.M;
  N.v += Nn.v;
  N.yy += Nn.yy;
  N.n += Nn.n;
  return N;
}

Normal accumulate_pass(const Samples& S, const State& st, const std::vector<Column>& cols,
                       std::size_t stride) {
  const Reversals rev(S, st.servo_mismatch_s);
  const auto p = static_cast<Eigen::Index>(cols.size());
  const std::size_t nblocks = (S.size() + kBlockSamples - 1) / kBlockSamples;
  std::vector<Sums> part(nblocks, Sums(p, 1));
  for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t block) {
    add_rows_off_reversals(
        S, st, rev, cols,
        [&](auto&& take) {
          for (std::size_t i = (lo + stride - 1) / stride * stride; i < hi; i += stride) take(i);
        },
        part[block]);
  });
  Sums all(p, 1);
  for (const Sums& b : part) all += b;
  return to_normal(all, 0.0);
}

// The normal equations already built: the last ones (the first step of a fit often asks again
// for those the identifiability check just built), and the steady sums of the last columns.
struct NormalMemo {
  std::vector<Column> cols;
  State st;
  std::size_t stride = 0;
  Normal N;
  std::optional<SteadySums> steady;
};

Normal accumulate(const Samples& S, const State& st, const std::vector<Column>& cols,
                  std::size_t stride, NormalMemo& memo) {
  if (memo.stride == stride && memo.st == st && memo.cols == cols) return memo.N;
  Normal N;
  if (!steady_applies(cols)) {
    N = accumulate_pass(S, st, cols, stride);
  } else {
    if (!memo.steady || !steady_valid(S, *memo.steady, st, cols, stride))
      memo.steady = take_steady(S, st, cols, stride);
    N = steady_normal(S, *memo.steady, st, cols);
  }
  memo.cols = cols;
  memo.st = st;
  memo.stride = stride;
  memo.N = N;
  return N;
}

struct Solution {
  Eigen::VectorXd x;
  Eigen::MatrixXd inv;  // (J^T J)^-1
  double rss = 0.0;
  double sigma2 = 0.0;
};

Solution solve(const Normal& N) {
  Solution sol;
  const auto p = N.M.rows();
  // Scale to unit diagonal for a well-posed inverse.
  Eigen::VectorXd d = N.M.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd C = d.asDiagonal() * N.M * d.asDiagonal();
  Eigen::LDLT<Eigen::MatrixXd> ldlt(C);
  const Eigen::MatrixXd Cinv = ldlt.solve(Eigen::MatrixXd::Identity(p, p));
  sol.inv = d.asDiagonal() * Cinv * d.asDiagonal();
  sol.x = sol.inv * N.v;
  sol.rss = std::max(0.0, N.yy - 2.0 * sol.x.dot(N.v) + sol.x.dot(N.M * sol.x));
  const double dof = static_cast<double>(N.n) - static_cast<double>(p);
  sol.sigma2 = dof > 0 ? sol.rss / dof : 0.0;
  return sol;
}

// 1 - R^2 of column j regressed on the columns in `set` (all normalised to unit diagonal).
double unexplained(const Eigen::MatrixXd& C, const std::vector<Eigen::Index>& set, Eigen::Index j) {
  if (set.empty()) return 1.0;
  const auto k = static_cast<Eigen::Index>(set.size());
  Eigen::MatrixXd A(k, k);
  Eigen::VectorXd b(k);
  for (Eigen::Index u = 0; u < k; ++u) {
    b[u] = C(set[static_cast<std::size_t>(u)], j);
    for (Eigen::Index w = 0; w < k; ++w)
      A(u, w) = C(set[static_cast<std::size_t>(u)], set[static_cast<std::size_t>(w)]);
  }
  const Eigen::VectorXd x = A.ldlt().solve(b);
  return C(j, j) - b.dot(x);
}

std::string kind_name(Kind k, const std::array<char, 2>& axes) {
  const std::string A(1, axes[0]), B(1, axes[1]);
  switch (k) {
    case Kind::centre_a:
      return "centre offset " + A;
    case Kind::centre_b:
      return "centre offset " + B;
    case Kind::radius:
      return "radius change";
    case Kind::scale_mismatch:
      return "scale mismatch";
    case Kind::squareness:
      return "squareness";
    case Kind::servo:
      return "servo mismatch";
    case Kind::backlash_a:
      return "backlash " + A;
    case Kind::backlash_b:
      return "backlash " + B;
    case Kind::spike_a:
      return "reversal spike " + A;
    case Kind::spike_b:
      return "reversal spike " + B;
    case Kind::cyclic_a_sin:
    case Kind::cyclic_a_cos:
      return "cyclic " + A;
    case Kind::cyclic_b_sin:
    case Kind::cyclic_b_cos:
      return "cyclic " + B;
    case Kind::spike_tau_a:
    case Kind::spike_tau_b:
      return "spike decay";
  }
  return "?";
}

std::optional<std::size_t> find(const std::vector<Column>& cols, Kind k, int group = 0) {
  for (std::size_t j = 0; j < cols.size(); ++j) {
    if (cols[j].kind == k && (k != Kind::radius || cols[j].group == group)) return j;
  }
  return std::nullopt;
}

// The base fit's design rows and residual on a subsample, for profiling added columns. Its
// arrays (about 17 MB for 60,000 rows) live in one block asked for huge pages: allocated one
// by one they cost thousands of page faults, more than the arithmetic on them.
using MatMap = Eigen::Map<Eigen::MatrixXd, Eigen::AlignedMax>;
using VecMap = Eigen::Map<Eigen::VectorXd, Eigen::AlignedMax>;

struct Profile {
  Profile() = default;
  Profile(const Profile&) = delete;
  Profile& operator=(const Profile&) = delete;
  Profile(Profile&&) = default;  // the block moves with its buffer: the maps stay valid

  std::unique_ptr<double[]> store;  // the block the maps below point into
  std::vector<std::size_t> index;   // sample indices
  MatMap J{nullptr, 0, 0};          // rows of the base columns
  VecMap e{nullptr, 0};             // base residual
  Eigen::MatrixXd inv;              // (J^T J)^-1 of the base fit (full-data scaling)
  double rss = 0.0;
  // The spike terms' parts that do not depend on the decay, per axis and profile row: the
  // signed projection (-direction * cos or sin) and the time since the reversal (negative when
  // the feed is unknown). The decay search evaluates the spike columns hundreds of times.
  std::array<VecMap, 2> spike_sign{VecMap{nullptr, 0}, VecMap{nullptr, 0}};
  std::array<VecMap, 2> spike_dt_s{VecMap{nullptr, 0}, VecMap{nullptr, 0}};
  // The same per axis over only the rows past a reversal (time known), ordered by the time
  // since it, with their base design rows and residual: a spike column at decay tau is zero
  // past ~40 tau, so an evaluation reads only the leading rows.
  struct SpikeRows {
    std::vector<Eigen::Index> row;   // profile row of each ordered row
    std::vector<Eigen::Index> rank;  // per profile row: its place in this order, or -1
    VecMap sign{nullptr, 0}, dt_s{nullptr, 0}, e{nullptr, 0};
    MatMap J{nullptr, 0, 0};
  };
  std::array<SpikeRows, 2> spike_rows;
};

Profile make_profile(const Samples& S, const State& st, const std::vector<Column>& cols,
                     const Solution& base, std::size_t stride) {
  const Reversals rev(S, st.servo_mismatch_s);
  Profile P;
  reserve_huge(P.index, S.size() / stride + 1);
  for (std::size_t i = 0; i < S.size(); i += stride) {
    if (!at_reversal(S, i, rev.at(i))) P.index.push_back(i);
  }
  const auto n = static_cast<Eigen::Index>(P.index.size());
  const auto p = static_cast<Eigen::Index>(cols.size());
  const auto nu = static_cast<std::size_t>(n), pu = static_cast<std::size_t>(p);
  // The block: J, e, 2 x (sign, dt), 2 x (ordered sign, dt, e, J); each array starts on a
  // 64-byte boundary (Eigen's alignment, so the maps compute as the matrices did).
  constexpr std::size_t kAlign = 8;  // doubles
  const std::size_t padded = (nu + kAlign - 1) / kAlign * kAlign;
  const std::size_t total = padded * (3 * pu + 11) + kAlign;
  // Not zeroed: every element is written before it is read.
  P.store.reset(new double[total]);
  advise_huge_pages(P.store.get(), total * sizeof(double));
  double* next = P.store.get();
  next += (kAlign - reinterpret_cast<std::uintptr_t>(next) / sizeof(double) % kAlign) % kAlign;
  auto take = [&](std::size_t count) {
    double* at = next;
    next += (count + kAlign - 1) / kAlign * kAlign;
    return at;
  };
  new (&P.J) MatMap(take(nu * pu), n, p);
  new (&P.e) VecMap(take(nu), n);
  // The rows in chunks: their reversal bookkeeping is worked out again rather than stored.
  for (std::size_t ax = 0; ax < 2; ++ax) {
    new (&P.spike_sign[ax]) VecMap(take(nu), n);
    new (&P.spike_dt_s[ax]) VecMap(take(nu), n);
  }
  // The chunks side by side: each writes only its own rows.
  constexpr std::size_t kChunk = 4096;
  for_each_task((nu + kChunk - 1) / kChunk, [&](std::size_t chunk) {
    const std::size_t lo = chunk * kChunk, hi = std::min(nu, lo + kChunk);
    std::vector<Reversal> rvs(hi - lo);
    for (std::size_t r = lo; r < hi; ++r) rvs[r - lo] = rev.at(P.index[r]);
    for (std::size_t j = 0; j < pu; ++j) {
      fill_column(S, st, cols[j], P.index.data() + lo, rvs.data(), hi - lo,
                  P.J.data() + j * nu + lo, 1);
    }
    for (std::size_t r = lo; r < hi; ++r) {
      const std::size_t i = P.index[r];
      const auto ri = static_cast<Eigen::Index>(r);
      const Reversal& rv = rvs[r - lo];
      P.e[ri] = S.dr[i] - offset(S, st, cols, i, rv) - P.J.row(ri).dot(base.x);
      const double v = S.runs[S.run[i]].speed_mm_s;
      P.spike_sign[0][ri] = -static_cast<double>(rv.dir_a) * S.c[i];
      P.spike_sign[1][ri] = -static_cast<double>(rv.dir_b) * S.s[i];
      P.spike_dt_s[0][ri] = v > 0 ? rv.since_a * S.radius / v : -1.0;
      P.spike_dt_s[1][ri] = v > 0 ? rv.since_b * S.radius / v : -1.0;
    }
  });
  // (J^T J)^-1 of this subsample, so that the profile is consistent within itself.
  const Eigen::MatrixXd M = P.J.transpose() * P.J;
  Eigen::VectorXd d = M.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd C = d.asDiagonal() * M * d.asDiagonal();
  P.inv = d.asDiagonal() * C.ldlt().solve(Eigen::MatrixXd::Identity(p, p)) * d.asDiagonal();
  // The base residual re-projected on this subsample.
  const Eigen::VectorXd x = P.inv * (P.J.transpose() * P.e);
  P.e -= P.J * x;
  P.rss = P.e.squaredNorm();
  // Per axis, side by side: the rows with a time since the reversal, in its order.
  for_each_task(2, [&](std::size_t ax) {
    Profile::SpikeRows& o = P.spike_rows[ax];
    const VecMap& dt = P.spike_dt_s[ax];
    o.row.reserve(nu);
    for (Eigen::Index r = 0; r < n; ++r) {
      if (dt[r] >= 0) o.row.push_back(r);
    }
    std::stable_sort(o.row.begin(), o.row.end(),
                     [&](Eigen::Index a, Eigen::Index b) { return dt[a] < dt[b]; });
    o.rank.assign(nu, -1);
    for (std::size_t k = 0; k < o.row.size(); ++k)
      o.rank[static_cast<std::size_t>(o.row[k])] = static_cast<Eigen::Index>(k);
  });
  for (std::size_t ax = 0; ax < 2; ++ax) {
    Profile::SpikeRows& o = P.spike_rows[ax];
    const auto m = static_cast<Eigen::Index>(o.row.size());
    const auto mu = static_cast<std::size_t>(m);
    new (&o.sign) VecMap(take(mu), m);
    new (&o.dt_s) VecMap(take(mu), m);
    new (&o.e) VecMap(take(mu), m);
    new (&o.J) MatMap(take(mu * pu), m, p);
  }
  for_each_task(2, [&](std::size_t ax) {
    Profile::SpikeRows& o = P.spike_rows[ax];
    for (Eigen::Index k = 0; k < o.sign.size(); ++k) {
      const Eigen::Index r = o.row[static_cast<std::size_t>(k)];
      o.sign[k] = P.spike_sign[ax][r];
      o.dt_s[k] = P.spike_dt_s[ax][r];
      o.e[k] = P.e[r];
      o.J.row(k) = P.J.row(r);
    }
  });
  return P;
}

// profile_rss for spike columns only (the decay search), on the ordered rows: each column is
// evaluated on the rows with dt < 40 tau (exp(-40) = 4e-18 of the height; the rest add nothing
// the sums could hold), so a short decay costs a small part of a full evaluation.
double spike_profile_rss(const Profile& P, const State& st, const std::vector<Column>& extra) {
  const auto q = static_cast<Eigen::Index>(extra.size());
  std::vector<std::size_t> axis(extra.size());
  std::vector<Eigen::VectorXd> x(extra.size());
  Eigen::MatrixXd SS = Eigen::MatrixXd::Zero(q, q);
  Eigen::MatrixXd SJ(q, P.J.cols());
  Eigen::VectorXd g(q);
  for (Eigen::Index j = 0; j < q; ++j) {
    const auto ju = static_cast<std::size_t>(j);
    const std::size_t ax = extra[ju].kind == Kind::spike_a ? 0 : 1;
    axis[ju] = ax;
    const double tau = ax == 0 ? st.tau_a : st.tau_b;
    const Profile::SpikeRows& o = P.spike_rows[ax];
    Eigen::Index m = 0;
    if (tau > 0) {
      const double cut = 40.0 * tau;
      m = std::upper_bound(o.dt_s.data(), o.dt_s.data() + o.dt_s.size(), cut) - o.dt_s.data();
    }
    Eigen::VectorXd& v = x[ju];
    v.resize(m);
    for (Eigen::Index k = 0; k < m; ++k) v[k] = o.sign[k] * std::exp(-o.dt_s[k] / tau);
    SS(j, j) = v.squaredNorm();
    SJ.row(j) = v.transpose() * o.J.topRows(m);
    g[j] = v.dot(o.e.head(m));
  }
  // Cross products of two columns: through their profile rows.
  for (Eigen::Index j = 0; j < q; ++j) {
    for (Eigen::Index k = j + 1; k < q; ++k) {
      const Profile::SpikeRows& oj = P.spike_rows[axis[static_cast<std::size_t>(j)]];
      const Profile::SpikeRows& ok = P.spike_rows[axis[static_cast<std::size_t>(k)]];
      const Eigen::VectorXd& vj = x[static_cast<std::size_t>(j)];
      const Eigen::VectorXd& vk = x[static_cast<std::size_t>(k)];
      double sum = 0.0;
      for (Eigen::Index t = 0; t < vk.size(); ++t) {
        const Eigen::Index at =
            oj.rank[static_cast<std::size_t>(ok.row[static_cast<std::size_t>(t)])];
        if (at >= 0 && at < vj.size()) sum += vk[t] * vj[at];
      }
      SS(j, k) = SS(k, j) = sum;
    }
  }
  const Eigen::MatrixXd H = SS - SJ * P.inv * SJ.transpose();
  Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
  if (ldlt.info() != Eigen::Success || H.diagonal().minCoeff() <= 0) return P.rss;
  return P.rss - g.dot(ldlt.solve(g));
}

// One added column on the profile's rows. A spike term is exp(-dt / tau) times its sign, the
// same value as `value` gives; past exp(-700) (1e-304) it is taken as zero, which spares the
// slow underflow path of exp and changes no sum.
void profile_column(const Samples& S, const State& st, const Profile& P, const Column& col,
                    Eigen::Ref<Eigen::VectorXd> out) {
  const Eigen::Index n = P.J.rows();
  if (col.kind == Kind::spike_a || col.kind == Kind::spike_b) {
    const std::size_t ax = col.kind == Kind::spike_a ? 0 : 1;
    const double tau = ax == 0 ? st.tau_a : st.tau_b;
    if (tau <= 0) {
      out.setZero();
      return;
    }
    const double cut = kSpikeCut * tau;
    const VecMap& sign = P.spike_sign[ax];
    const VecMap& dt = P.spike_dt_s[ax];
    for (Eigen::Index r = 0; r < n; ++r) {
      out[r] = dt[r] < 0 || dt[r] > cut ? 0.0 : sign[r] * std::exp(-dt[r] / tau);
    }
    return;
  }
  // The other added columns (cyclic) do not depend on the reversals.
  for (Eigen::Index r = 0; r < n; ++r)
    out[r] = plain_value(S, st, col, P.index[static_cast<std::size_t>(r)]);
}

// Residual sum of squares when the columns `extra` join the base fit:
// RSS_base - g^T H^-1 g with g = S^T e0 and H = S^T S - S^T J (J^T J)^-1 J^T S.
double profile_rss(const Samples& S, const State& st, const Profile& P,
                   const std::vector<Column>& extra) {
  const auto q = static_cast<Eigen::Index>(extra.size());
  Eigen::MatrixXd X(P.J.rows(), q);
  for (Eigen::Index j = 0; j < q; ++j)
    profile_column(S, st, P, extra[static_cast<std::size_t>(j)], X.col(j));
  const Eigen::MatrixXd SS = X.transpose() * X;
  const Eigen::MatrixXd SJ = X.transpose() * P.J;
  const Eigen::VectorXd g = X.transpose() * P.e;
  const Eigen::MatrixXd H = SS - SJ * P.inv * SJ.transpose();
  Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
  if (ldlt.info() != Eigen::Success || H.diagonal().minCoeff() <= 0) return P.rss;
  return P.rss - g.dot(ldlt.solve(g));
}

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

// The residual dr - model at every stride-th sample into res[i / stride], on the threads, the
// columns filled in chunks (each kind dispatched once per chunk).
void residual_every(const Samples& S, const State& st, const std::vector<Column>& cols,
                    const Eigen::VectorXd& x, std::size_t stride, std::vector<double>& res) {
  const std::size_t count = (S.size() + stride - 1) / stride;
  if (res.capacity() < count) reserve_huge(res, count);
  res.resize(count);
  const Reversals rev(S, st.servo_mismatch_s);
  for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t) {
    std::vector<std::size_t> idx;
    std::vector<Reversal> rvs;
    for (std::size_t i = (lo + stride - 1) / stride * stride; i < hi; i += stride) {
      idx.push_back(i);
      rvs.push_back(rev.at(i));
    }
    const std::size_t m = idx.size();
    std::vector<double> col(m);
    for (std::size_t q = 0; q < m; ++q)
      res[idx[q] / stride] = S.dr[idx[q]] - offset(S, st, cols, idx[q], rvs[q]);
    for (std::size_t j = 0; j < cols.size(); ++j) {
      fill_column(S, st, cols[j], idx.data(), rvs.data(), m, col.data(), 1);
      const double xj = x[static_cast<Eigen::Index>(j)];
      for (std::size_t q = 0; q < m; ++q) res[idx[q] / stride] -= col[q] * xj;
    }
  });
}

struct Peak {
  double pitch_mm = 0.0;
  double ratio = 0.0;  // peak power / median power
};

// Periodogram of the residual projected on one axis, over that axis's position: the residual
// is first reduced to a least-squares axis deviation per position bin.
constexpr std::size_t kMinPeriodogramBins = 16;

// `bins` gets the number of position bins the samples fill (the search needs
// kMinPeriodogramBins).
std::optional<Peak> periodogram(const std::vector<double>& pos, const std::vector<double>& proj,
                                const std::vector<double>& resid, double radius, double min_pitch,
                                std::size_t& bins) {
  bins = 0;
  const auto [mn, mx] = std::minmax_element(pos.begin(), pos.end());
  const double span = *mx - *mn;
  if (!(span > 0)) return std::nullopt;
  const double width = min_pitch / 8.0;
  const auto nbins = static_cast<std::size_t>(std::ceil(span / width)) + 1;
  std::vector<double> sw(nbins, 0.0), swy(nbins, 0.0);
  for (std::size_t i = 0; i < pos.size(); ++i) {
    const auto b = static_cast<std::size_t>((pos[i] - *mn) / width);
    sw[b] += proj[i] * proj[i];
    swy[b] += proj[i] * resid[i];
  }
  std::vector<double> x, y, w;
  std::vector<std::size_t> bin;
  for (std::size_t b = 0; b < nbins; ++b) {
    if (sw[b] <= 0) continue;
    x.push_back(*mn + (static_cast<double>(b) + 0.5) * width);
    y.push_back(swy[b] / sw[b]);
    w.push_back(sw[b]);
    bin.push_back(b);
  }
  bins = x.size();
  if (x.size() < kMinPeriodogramBins) return std::nullopt;
  // Remove the weighted mean so the zero frequency does not leak.
  const double wsum = std::accumulate(w.begin(), w.end(), 0.0);
  double ym = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) ym += w[k] * y[k];
  ym /= wsum;
  const double fmin = 4.0 / radius;  // pitches up to R/4: longer waves are shape, not pitch
  const double fmax = 1.0 / min_pitch;
  const double df = 1.0 / (4.0 * span);
  if (fmax <= fmin) return std::nullopt;
  std::vector<double> freq;
  for (double f = fmin; f <= fmax; f += df) freq.push_back(f);
  std::vector<double> power(freq.size());
  // The frequencies in chunks side by side. Inside a chunk the bins are the outer loop and the
  // chunk's frequencies the inner one, so their independent rotations run in vector lanes
  // instead of one dependent chain each; every frequency's operations are the same as alone.
  constexpr std::size_t kChunk = 64;
  for_each_task((freq.size() + kChunk - 1) / kChunk, [&](std::size_t chunk) {
    const std::size_t f0 = chunk * kChunk, nf = std::min(freq.size(), f0 + kChunk) - f0;
    // The bins are equally spaced: exp(-2 pi i f x) turns by a fixed step from bin to bin
    // (taken exactly again every 64 bins, so that rounding does not build up).
    std::array<double, kChunk> step_re{}, step_im{}, z_re{}, z_im{}, acc_re{}, acc_im{};
    for (std::size_t t = 0; t < nf; ++t) {
      const double a = -2 * kPi * freq[f0 + t] * width;
      step_re[t] = std::cos(a);
      step_im[t] = std::sin(a);
    }
    std::size_t at = 0, seed = 0;
    for (std::size_t k = 0; k < x.size(); ++k) {
      if (k == 0 || bin[k] >= seed + 64) {
        for (std::size_t t = 0; t < nf; ++t) {
          const double ph = -2 * kPi * freq[f0 + t] * x[k];
          z_re[t] = std::cos(ph);
          z_im[t] = std::sin(ph);
        }
        seed = bin[k];
      } else {
        for (; at < bin[k]; ++at) {
          for (std::size_t t = 0; t < nf; ++t) {
            const double re = z_re[t] * step_re[t] - z_im[t] * step_im[t];
            z_im[t] = z_re[t] * step_im[t] + z_im[t] * step_re[t];
            z_re[t] = re;
          }
        }
      }
      at = bin[k];
      const double wy = w[k] * (y[k] - ym);
      for (std::size_t t = 0; t < nf; ++t) {
        acc_re[t] += wy * z_re[t];
        acc_im[t] += wy * z_im[t];
      }
    }
    for (std::size_t t = 0; t < nf; ++t)
      power[f0 + t] = std::norm(std::complex<double>(acc_re[t], acc_im[t]));
  });
  if (power.size() < 8) return std::nullopt;
  std::vector<double> sorted = power;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const double median = sorted[sorted.size() / 2];
  const auto it = std::max_element(power.begin(), power.end());
  const auto k = static_cast<std::size_t>(it - power.begin());
  double f = freq[k];
  if (k > 0 && k + 1 < power.size()) {
    const double a = power[k - 1], b = power[k], c = power[k + 1];
    const double den = a - 2 * b + c;
    if (den < 0) f += 0.5 * (a - c) / den * df;
  }
  Peak peak;
  peak.pitch_mm = 1.0 / f;
  peak.ratio = median > 0 ? *it / median : std::numeric_limits<double>::infinity();
  return peak;
}

const std::vector<double>* cmd_column(const Trace& trace, char axis) {
  return trace.column(column_name::commanded(axis));
}

// A reversal of one axis inside a run: the first sample past it (not the first of its run),
// the angle since the reversal there and the axis direction after it.
struct ReversalEvent {
  std::size_t sample;
  double since;
  std::int8_t dir;
};

// The backlash at each end of an axis' travel on its own: at every reversal the model's step
// is b in the radius (at both ends, both directions); what the residual still steps there,
// from a straight line on each side extrapolated to the reversal, is added to it. The ends
// are averaged over the runs. Both ends must be covered.

void reversal_steps(const Samples& S, const std::vector<double>& resid,
                    const std::array<std::vector<ReversalEvent>, 2>& events, Diagnosis& D) {
  constexpr double kWindowRad = 4.0 * kPi / 180.0;
  constexpr std::size_t kMinSide = 5;
  for (int ax = 0; ax < 2; ++ax) {
    const auto axs = static_cast<std::size_t>(ax);
    if (!D.backlash_mm[axs].value) continue;
    const double b = *D.backlash_mm[axs].value;
    // The angle in which the motor takes up the play (travelled R (1 - cos) = b), twice.
    const double takeup_rad = 2.0 * std::acos(std::max(-1.0, 1.0 - std::abs(b) / S.radius));
    std::array<double, 2> sum{0.0, 0.0};  // [0]: + end, [1]: - end
    std::array<int, 2> count{0, 0};
    for (const ReversalEvent& ev : events[axs]) {
      const std::size_t i = ev.sample;
      const RunInfo& r = S.runs[S.run[i]];
      const double u_rev = S.u[i] - r.dir * ev.since;
      // Least-squares line of the residual against the signed angle on one side, at 0.
      auto intercept = [&](bool after, std::size_t& n) {
        double s0 = 0, s1 = 0, s2 = 0, t0 = 0, t1 = 0;
        n = 0;
        // After the reversal, past twice the take-up of the play: where the true play differs
        // from the fitted one, the residual has a bump there.
        const double from = after ? std::max(r.eps_rad, takeup_rad) : r.eps_rad;
        auto take = [&](std::size_t j) {
          const double d = r.dir * (S.u[j] - u_rev);
          if (std::abs(d) > from + kWindowRad) return false;
          if (std::abs(d) > from) {
            s0 += 1;
            s1 += d;
            s2 += d * d;
            t0 += resid[j];
            t1 += resid[j] * d;
            ++n;
          }
          return true;
        };
        if (after) {
          for (std::size_t j = i; j < r.end && take(j); ++j) {
          }
        } else {
          for (std::size_t j = i; j-- > r.begin && take(j);) {
          }
        }
        const double det = s0 * s2 - s1 * s1;
        return det > 0 ? (s2 * t0 - s1 * t1) / det : 0.0;
      };
      std::size_t na = 0, nb = 0;
      const double after = intercept(true, na), before = intercept(false, nb);
      if (na < kMinSide || nb < kMinSide) continue;
      const std::size_t end = ev.dir < 0 ? 0 : 1;  // moving - after it: the + end
      sum[end] += b + (after - before);
      ++count[end];
    }
    if (count[0] > 0 && count[1] > 0) {
      D.backlash_reversals_mm[axs] = std::array<double, 2>{sum[0] / count[0], sum[1] / count[1]};
    }
  }
}

// The first number of the diagnosis that is not finite, by name; none when all are. A fit the
// samples do not determine (noise far above the radius, feeds from a time column that stalls
// and jumps) can leave NaN in its solution, which no output may carry.
std::optional<std::string> first_not_finite(const Diagnosis& D) {
  const auto bad = [](const std::optional<double>& v) { return v && !std::isfinite(*v); };
  const auto bad_estimate = [&](const Estimate& e) {
    return bad(e.value) || bad(e.standard_error);
  };
  for (std::size_t ax = 0; ax < 2; ++ax) {
    const std::string axis(1, D.axes[ax]);
    if (bad_estimate(D.backlash_mm[ax])) return "backlash " + axis;
    if (bad_estimate(D.spike_mm[ax]) || bad_estimate(D.spike_ms[ax])) return "spike " + axis;
    if (bad_estimate(D.scale_ppm[ax])) return "scale " + axis;
    if (bad_estimate(D.centre_offset_mm[ax])) return "centre offset " + axis;
    if (const auto& r = D.backlash_reversals_mm[ax]; r && (bad((*r)[0]) || bad((*r)[1]))) {
      return "backlash at the reversals of " + axis;
    }
    if (const auto& c = D.cyclic[ax];
        c && !(std::isfinite(c->amplitude_mm) && std::isfinite(c->pitch_mm) &&
               std::isfinite(c->phase_rad) && std::isfinite(c->amplitude_se_mm))) {
      return "cyclic error " + axis;
    }
  }
  if (bad_estimate(D.scale_mismatch_ppm)) return std::string("scale mismatch");
  if (bad_estimate(D.squareness_urad)) return std::string("squareness");
  if (bad_estimate(D.servo_mismatch_ms)) return std::string("servo mismatch");
  if (bad_estimate(D.kv_per_s)) return std::string("Kv");
  if (bad_estimate(D.lag_ms)) return std::string("following lag");
  for (const FeedRadius& f : D.radius_change) {
    if (bad_estimate(f.dr_mm)) return std::string("radius change");
  }
  for (const Contribution& c : D.contributions) {
    if (!std::isfinite(c.g_mm) || !std::isfinite(c.share_mm) || !std::isfinite(c.percent)) {
      return "contribution of " + c.source;
    }
  }
  if (!std::isfinite(D.model_g_mm)) return std::string("modelled G");
  if (!std::isfinite(D.residual_rms_mm) || !std::isfinite(D.residual_g_mm)) {
    return std::string("residual");
  }
  return std::nullopt;
}

}  // namespace

Diagnosis diagnose(const Trace& trace, const DiagnosisOptions& options) {
  const Evaluation ev = evaluate(trace, options.evaluation);
  return diagnose(trace, ev, options);
}

Diagnosis diagnose(const Trace& trace, const Evaluation& ev, const DiagnosisOptions& options) {
  Diagnosis D;
  D.source = ev.source;
  D.plane = ev.plane;
  const PlaneAxes pa = plane_axes(ev.plane);
  const char la = pa.first, lb = pa.second;
  D.axes = {static_cast<char>(la - 'a' + 'A'), static_cast<char>(lb - 'a' + 'A')};
  const std::string A(1, D.axes[0]), B(1, D.axes[1]);
  if (const std::string* h = trace.metadata.find(meta_key::ini_sha256)) D.ini_sha256 = *h;
  D.absolute_channels = options.absolute_channels;
  if (const std::string* ins = trace.metadata.find(meta_key::instrument)) {
    std::string low = *ins;
    std::transform(low.begin(), low.end(), low.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    if (low.find("ballbar") != std::string::npos || low.find("radial") != std::string::npos) {
      D.absolute_channels = false;
    }
  }
  if (ev.runs.empty()) throw DataError(trace.source, 0, "no run to diagnose");

  const auto& col_a = trace.values[ev.columns.a];
  const auto& col_b = trace.values[ev.columns.b];
  // The linearisation point: the nominal circle, else the least-squares circle of all runs.
  double ca = 0, cb = 0, R = 0;
  if (ev.centre && ev.nominal_radius_mm) {
    ca = ev.centre->a_mm;
    cb = ev.centre->b_mm;
    R = *ev.nominal_radius_mm;
  } else {
    std::vector<double> xa, xb;
    for (const auto& r : ev.runs) {
      xa.insert(xa.end(), col_a.begin() + static_cast<std::ptrdiff_t>(r.run.begin),
                col_a.begin() + static_cast<std::ptrdiff_t>(r.run.end));
      xb.insert(xb.end(), col_b.begin() + static_cast<std::ptrdiff_t>(r.run.begin),
                col_b.begin() + static_cast<std::ptrdiff_t>(r.run.end));
    }
    const Circle all =
        detail::with_rows_context(trace, ev.runs.front().run.begin, ev.runs.back().run.end,
                                  "the runs together", [&] { return fit_lsc(xa, xb); });
    ca = ev.centre ? ev.centre->a_mm : all.centre_a_mm;
    cb = ev.centre ? ev.centre->b_mm : all.centre_b_mm;
    R = ev.nominal_radius_mm.value_or(all.radius_mm);
    if (!ev.nominal_radius_mm) {
      D.notes.push_back(
          "no nominal radius: deviations are taken from the least-squares radius, so the "
          "radius change and absolute scale are not available");
    }
  }
  D.radius_mm = R;

  // Feed groups: runs within 2 % of each other's feed share a radius parameter.
  std::optional<double> meta_feed = trace.metadata.number(meta_key::feed_mm_per_min, trace.source);
  std::vector<double> group_feed;
  Samples S;
  S.radius = R;
  S.col_a = col_a.data();
  S.col_b = col_b.data();
  State st;
  bool speed_known = true;
  bool have_ccw = false, have_cw = false;
  bool reversal_a = false, reversal_b = false;
  double min_sweep = 360.0;
  {
    std::size_t total = 0;
    for (const RunResult& rr : ev.runs) total += rr.run.size();
    // Side by side: mapping in these fresh pages (27 MB on the benchmark trace) costs more
    // than filling them.
    std::vector<double>* arrays[] = {&S.c, &S.s, &S.dr, &S.u};
    for_each_task(5, [&](std::size_t k) {
      if (k < 4) {
        reserve_huge(*arrays[k], total);
      } else {
        reserve_huge(S.run, total);
      }
    });
  }
  // The runs' bookkeeping in order, then their samples side by side (each run's into its own
  // range of the arrays).
  for (std::size_t k = 0; k < ev.runs.size(); ++k) {
    const RunResult& rr = ev.runs[k];
    RunInfo info;
    info.dir = rr.run.direction == Direction::CCW ? 1.0 : -1.0;
    (info.dir > 0 ? have_ccw : have_cw) = true;
    min_sweep = std::min(min_sweep, rr.run.sweep_deg);
    const std::optional<double> feed = rr.feed_mm_per_min ? rr.feed_mm_per_min : meta_feed;
    if (feed && *feed > 0) {
      info.speed_mm_s = *feed / 60.0;
      std::size_t g = 0;
      while (g < group_feed.size() && std::abs(group_feed[g] - *feed) > 0.02 * *feed) ++g;
      if (g == group_feed.size()) group_feed.push_back(*feed);
      info.group = static_cast<int>(g);
    } else {
      speed_known = false;
      if (group_feed.empty()) group_feed.push_back(0.0);
      info.group = 0;
    }
    info.begin = S.runs.empty() ? 0 : S.runs.back().end;
    info.end = info.begin + rr.run.size();
    info.trace_begin = rr.run.begin;
    // One sample period in angle (the time column's mean step).
    if (const std::vector<double>* t = trace.column(column_name::t);
        t && rr.run.size() > 1 && info.speed_mm_s > 0) {
      const double dt =
          ((*t)[rr.run.end - 1] - (*t)[rr.run.begin]) / static_cast<double>(rr.run.size() - 1);
      info.eps_rad = 1.5 * dt * info.speed_mm_s / R;
    }
    S.runs.push_back(info);
  }
  {
    const std::size_t total = S.runs.empty() ? 0 : S.runs.back().end;
    for (auto* v : {&S.c, &S.s, &S.dr, &S.u}) v->resize(total);
    S.run.resize(total);
  }
  std::vector<std::array<double, 2>> angle_range(ev.runs.size());  // lowest, highest
  for_each_task(ev.runs.size(), [&](std::size_t k) {
    const Run& run = ev.runs[k].run;
    const RunInfo& info = S.runs[k];
    // The angle straight into u and the radius into dr (made r - R below): no copy.
    double* const angle = S.u.data() + info.begin;
    double* const radius = S.dr.data() + info.begin;
    detail::path_polar_into(std::span(col_a).subspan(run.begin, run.size()),
                            std::span(col_b).subspan(run.begin, run.size()), PlanePoint{ca, cb},
                            angle, radius);
    double lo = 0, hi = 0;
    for (std::size_t q = 0; q < run.size(); ++q) {
      const std::size_t i = run.begin + q, j = info.begin + q;
      const double da = col_a[i] - ca, db = col_b[i] - cb;
      const double r = radius[q];
      const double u = angle[q];
      if (q == 0) lo = hi = u;
      lo = std::min(lo, u);
      hi = std::max(hi, u);
      S.c[j] = da / r;
      S.s[j] = db / r;
      S.dr[j] = r - R;
      S.run[j] = static_cast<std::uint32_t>(k);
    }
    angle_range[k] = {lo, hi};
  });
  for (const std::array<double, 2>& range : angle_range) {
    const double lo = range[0], hi = range[1];
    // An axis reverses inside the run when the arc crosses its reversal angle (with a margin
    // so the step itself is inside the data).
    const double margin = 2.0 * kPi / 180.0;
    auto crosses = [&](double shift) {
      return std::floor((hi - margin - shift) / kPi) >= std::ceil((lo + margin - shift) / kPi);
    };
    reversal_a = reversal_a || crosses(0.0);
    reversal_b = reversal_b || crosses(kPi / 2);
  }
  D.runs = ev.runs.size();
  D.samples = S.size();
  D.feeds_mm_per_min = group_feed;
  if (!speed_known) {
    D.feeds_mm_per_min.clear();
    D.notes.push_back(
        "feed unknown (no time column or feed_mm_per_min metadata): servo mismatch and "
        "reversal spikes not fitted");
  }
  if (!have_ccw || !have_cw) {
    D.notes.push_back(fmt::format(
        "one direction only ({}): backlash and servo mismatch cannot be told apart from "
        "geometry by the direction change; a CCW and a CW run are needed for H-related terms",
        have_ccw ? "CCW" : "CW"));
  }
  if (min_sweep < 359.0) {
    D.notes.push_back(fmt::format(
        "partial arc ({:.0f} deg): only the terms the arc separates are fitted", min_sweep));
  }

  // Candidate columns in order of priority: a later one that the earlier ones already explain
  // is not identifiable and is left out.
  std::vector<Column> cand;
  cand.push_back({Kind::centre_a});
  cand.push_back({Kind::centre_b});
  for (std::size_t g = 0; g < group_feed.size(); ++g)
    cand.push_back({Kind::radius, static_cast<int>(g)});
  cand.push_back({Kind::scale_mismatch});
  cand.push_back({Kind::squareness});
  if (speed_known) cand.push_back({Kind::servo});
  // Without a reversal the play still shifts the runs of the two directions apart: it is
  // fitted (so it does not bias the rest) but not reported as backlash.
  cand.push_back({Kind::backlash_a});
  if (!reversal_a) {
    D.notes.push_back(fmt::format(
        "no reversal of {} inside the measured arcs: {} backlash and reversal spike not "
        "reported",
        A, A));
  }
  // Without a reversal the play still shifts the runs of the two directions apart: it is
  // fitted (so it does not bias the rest) but not reported as backlash.
  cand.push_back({Kind::backlash_b});
  if (!reversal_b) {
    D.notes.push_back(fmt::format(
        "no reversal of {} inside the measured arcs: {} backlash and reversal spike not "
        "reported",
        B, B));
  }

  // A fit of p terms on a handful of samples has no residual left to judge it by: its
  // standard errors and identifiability test mean nothing and the later stages (periodogram,
  // decay search) work on noise. Refused up front, naming what it needs.
  const std::size_t needed = kSamplesPerTerm * cand.size();
  if (S.size() < needed) {
    const Run& first = ev.runs.front().run;
    throw DataError(
        trace.source, trace.line_of_row[first.begin],
        fmt::format("diagnosis not measurable ({} samples, needs {}): the model's {} terms "
                    "need {} samples each over the measured runs ({} run{}, lines {}-{}); "
                    "record more samples per run (a lower feed or a shorter sample period)",
                    S.size(), needed, cand.size(), kSamplesPerTerm, ev.runs.size(),
                    ev.runs.size() == 1 ? "" : "s", trace.line_of_row[first.begin],
                    trace.line_of_row[ev.runs.back().run.end - 1]));
  }

  const std::size_t stride =
      std::max<std::size_t>(1, (S.size() + options.max_fit_samples - 1) / options.max_fit_samples);
  const double vif_floor = 1.0 / options.max_variance_inflation;

  NormalMemo memo;
  // Identifiability: forward selection on the normalised normal matrix.
  auto select = [&](const std::vector<Column>& in, std::vector<Column>& out,
                    std::vector<std::pair<Column, double>>& rejected) {
    const Normal N = accumulate(S, st, in, stride, memo);
    Eigen::VectorXd d = N.M.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd C = d.asDiagonal() * N.M * d.asDiagonal();
    std::vector<Eigen::Index> kept;
    for (std::size_t j = 0; j < in.size(); ++j) {
      const auto ji = static_cast<Eigen::Index>(j);
      const double u = N.M(ji, ji) > 0 ? unexplained(C, kept, ji) : 0.0;
      if (u >= vif_floor) {
        kept.push_back(ji);
        out.push_back(in[j]);
      } else {
        rejected.emplace_back(in[j], u);
      }
    }
  };
  std::vector<Column> cols;
  std::vector<std::pair<Column, double>> rejected;
  select(cand, cols, rejected);

  bool squareness_servo_confounded = false;
  for (const auto& [col, u] : rejected) {
    const std::string name = kind_name(col.kind, D.axes);
    if (col.kind == Kind::servo && find(cols, Kind::squareness)) {
      squareness_servo_confounded = true;
      D.notes.push_back(
          "squareness and servo mismatch both make a sin 2theta term here (one direction at one "
          "feed): neither is reported; both directions or two feeds separate them");
    } else if ((col.kind == Kind::backlash_a && !reversal_a) ||
               (col.kind == Kind::backlash_b && !reversal_b)) {
      // Already said: no reversal.
    } else if (col.kind == Kind::radius) {
      D.notes.push_back(fmt::format("radius change at {:.0f} mm/min not identifiable",
                                    group_feed[static_cast<std::size_t>(col.group)]));
    } else {
      D.notes.push_back(fmt::format(
          "{} not identifiable from this trace: its term is {:.2f} % explained by the terms "
          "fitted before it (arc too short or a missing direction)",
          name, 100.0 * (1.0 - u)));
    }
  }

  // Backlash transitions: a few Gauss-Newton steps on the play.
  Solution sol;
  auto fit = [&]() {
    for (int it = 0; it < 4; ++it) {
      sol = solve(accumulate(S, st, cols, stride, memo));
      bool changed = false;
      if (auto j = find(cols, Kind::backlash_a)) {
        const double b = sol.x[static_cast<Eigen::Index>(*j)];
        changed = changed || std::abs(b - st.backlash_a) > 1e-4 * std::abs(b) + 1e-9;
        st.backlash_a = b;
      }
      if (auto j = find(cols, Kind::backlash_b)) {
        const double b = sol.x[static_cast<Eigen::Index>(*j)];
        changed = changed || std::abs(b - st.backlash_b) > 1e-4 * std::abs(b) + 1e-9;
        st.backlash_b = b;
      }
      if (auto j = find(cols, Kind::servo)) {
        const double m = sol.x[static_cast<Eigen::Index>(*j)];
        changed = changed || std::abs(m - st.servo_mismatch_s) > 1e-4 * std::abs(m) + 1e-9;
        st.servo_mismatch_s = m;
      }
      if (!changed) break;
    }
  };
  fit();

  // Cyclic errors: a given pitch, else a periodogram of the residual over axis position.
  {
    std::vector<double> res;
    // The columns and state `res` was taken at; none before the first residual (an empty
    // column set at the default state is a state like any other, not "already taken").
    std::optional<std::pair<std::vector<Column>, State>> res_at;
    const std::size_t cstride = std::max<std::size_t>(1, (S.size() + 199999) / 200000);
    for (int ax = 0; ax < 2; ++ax) {
      const char letter = ax == 0 ? la : lb;
      std::optional<CyclicEstimate> found;
      double pitch = 0.0;
      auto it = options.pitch_mm.find(letter);
      CyclicEstimate ce;
      if (it != options.pitch_mm.end()) {
        pitch = it->second;
        ce.pitch_source = "option";
      } else {
        // Every cstride-th sample, entry i / cstride, on the threads. The residual is the
        // same for both axes unless the first one added a cyclic term.
        const std::size_t count = (S.size() + cstride - 1) / cstride;
        std::vector<double> pos, proj;
        for (auto* v : {&pos, &proj}) {
          reserve_huge(*v, count);
          v->resize(count);
        }
        if (!res_at || !(res_at->first == cols && res_at->second == st)) {
          residual_every(S, st, cols, sol.x, cstride, res);
          res_at.emplace(cols, st);
        }
        for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t) {
          for (std::size_t i = (lo + cstride - 1) / cstride * cstride; i < hi; i += cstride) {
            pos[i / cstride] = S.pos(ax, i);
            proj[i / cstride] = ax == 0 ? S.c[i] : S.s[i];
          }
        });
        const double min_pitch = std::max(0.5, R / 400.0);
        std::size_t bins = 0;
        const auto peak = periodogram(pos, proj, res, R, min_pitch, bins);
        if (bins < kMinPeriodogramBins) {
          D.notes.push_back(fmt::format(
              "cyclic error of {} not measurable ({} samples fill {} position bins of {:.3g} "
              "mm, needs {}): give its pitch with --pitch to fit it",
              ax == 0 ? A : B, pos.size(), bins, min_pitch / 8.0, kMinPeriodogramBins));
        }
        if (peak && peak->ratio >= options.cyclic_detection_factor) {
          pitch = peak->pitch_mm;
          ce.pitch_source = "periodogram";
          ce.peak_to_median_power = peak->ratio;
        } else if (peak) {
          ce.peak_to_median_power = peak->ratio;
        }
      }
      if (pitch <= 0) continue;
      const Kind ks = ax == 0 ? Kind::cyclic_a_sin : Kind::cyclic_b_sin;
      const Kind kc = ax == 0 ? Kind::cyclic_a_cos : Kind::cyclic_b_cos;
      double& st_pitch = ax == 0 ? st.pitch_a : st.pitch_b;
      if (ce.pitch_source == "periodogram") {
        // Refine the pitch on the profile residual.
        const double f0 = 1.0 / pitch;
        double span = 0.0;
        { span = S.pos_span(ax); }
        const double df = 1.0 / (4.0 * span);
        const Profile prof = make_profile(S, st, cols, sol, cstride);
        auto rss_at = [&](double f) {
          State s2 = st;
          (ax == 0 ? s2.pitch_a : s2.pitch_b) = 1.0 / f;
          return profile_rss(S, s2, prof, {{ks}, {kc}});
        };
        pitch = 1.0 / golden(rss_at, f0 - df, f0 + df, 16);
      }
      st_pitch = pitch;
      cols.push_back({ks});
      cols.push_back({kc});
      fit();
      const auto js = static_cast<Eigen::Index>(*find(cols, ks));
      const auto jc = static_cast<Eigen::Index>(*find(cols, kc));
      const double a = sol.x[js], b = sol.x[jc];
      ce.pitch_mm = pitch;
      ce.amplitude_mm = std::hypot(a, b);
      ce.phase_rad = std::atan2(b, a);
      // Amplitude standard error: the larger of the two components' (a conservative bound).
      ce.amplitude_se_mm = std::sqrt(sol.sigma2 * std::max(sol.inv(js, js), sol.inv(jc, jc)));
      if (ce.pitch_source == "periodogram" && (ce.amplitude_mm < options.min_cyclic_amplitude_mm ||
                                               ce.amplitude_mm < 5.0 * ce.amplitude_se_mm)) {
        // A peak of a residual that is itself negligible: not a cyclic error.
        cols.resize(cols.size() - 2);
        st_pitch = 0.0;
        fit();
        continue;
      }
      found = ce;
      D.cyclic[static_cast<std::size_t>(ax)] = found;
    }
  }

  // Reversal spikes: the decay is profiled over a log grid, then refined. The decays found
  // are the next search's starting points.
  std::array<double, 2> hints = {0.0, 0.0};
  auto search_spikes = [&]() {
    if (!speed_known || !(reversal_a || reversal_b)) return;
    for (Kind k : {Kind::spike_a, Kind::spike_b}) {
      if (auto j = find(cols, k)) cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*j));
    }
    st.tau_a = st.tau_b = 0.0;
    fit();
    const std::size_t sstride = std::max<std::size_t>(1, (S.size() + 59999) / 60000);
    const double tau_lo = 0.5e-3, tau_hi = 1.0;
    std::array<bool, 2> on = {reversal_a && find(cols, Kind::backlash_a).has_value(),
                              reversal_b && find(cols, Kind::backlash_b).has_value()};
    State trial = st;
    trial.tau_a = trial.tau_b = 0.0;
    const Profile prof = make_profile(S, st, cols, sol, sstride);
    for (int round = 0; round < 2; ++round) {
      for (int ax = 0; ax < 2; ++ax) {
        if (!on[static_cast<std::size_t>(ax)]) continue;
        std::vector<Column> extra;
        if (on[0]) extra.push_back({Kind::spike_a});
        if (on[1]) extra.push_back({Kind::spike_b});
        auto rss_at = [&](double log_tau) {
          State s2 = trial;
          (ax == 0 ? s2.tau_a : s2.tau_b) = std::exp(log_tau);
          // The other axis's spike: its current decay, or out of the fit while still unknown.
          std::vector<Column> ex;
          for (const Column& c : extra) {
            const bool mine = (c.kind == Kind::spike_a) == (ax == 0);
            if (mine || (c.kind == Kind::spike_a ? s2.tau_a : s2.tau_b) > 0) ex.push_back(c);
          }
          return spike_profile_rss(prof, s2, ex);
        };
        // A 29-point log grid, or 7 points around a decay already found (round 2, or the
        // search again after the pitch refinement), widened to the whole grid when the best
        // point is at the edge of the short one.
        const int n = 28;
        const double l0 = std::log(tau_lo), l1 = std::log(tau_hi);
        const double step = (l1 - l0) / n;
        auto grid_best = [&](int k0, int k1) {
          // The grid's points side by side, then the first lowest in grid order.
          std::vector<double> rss(static_cast<std::size_t>(k1 - k0 + 1));
          for_each_task(rss.size(), [&](std::size_t t) {
            rss[t] = rss_at(l0 + step * (k0 + static_cast<int>(t)));
          });
          double best = std::numeric_limits<double>::infinity();
          int kbest = k0;
          for (int k = k0; k <= k1; ++k) {
            const double r = rss[static_cast<std::size_t>(k - k0)];
            if (r < best) {
              best = r;
              kbest = k;
            }
          }
          return kbest;
        };
        const double hint = round == 0 ? hints[static_cast<std::size_t>(ax)]
                                       : (ax == 0 ? trial.tau_a : trial.tau_b);
        int kbest = -1;
        if (hint > 0) {
          const int kc =
              std::clamp(static_cast<int>(std::lround((std::log(hint) - l0) / step)), 0, n);
          const int k0 = std::max(0, kc - 3), k1 = std::min(n, kc + 3);
          kbest = grid_best(k0, k1);
          if ((kbest == k0 && k0 > 0) || (kbest == k1 && k1 < n)) kbest = -1;
        }
        if (kbest < 0) kbest = grid_best(0, n);
        // Golden steps until the bracket (2 grid steps) is below 1 % in tau.
        const int steps = static_cast<int>(
            std::ceil(std::log(0.01 / (2 * step)) / std::log((std::sqrt(5.0) - 1.0) / 2.0)));
        const double lt =
            golden(rss_at, l0 + step * kbest - step, l0 + step * kbest + step, std::max(1, steps));
        (ax == 0 ? trial.tau_a : trial.tau_b) = std::exp(lt);
      }
    }
    // The fit without spikes (decays zero), taken back unchanged when every spike found is
    // dropped below.
    const State st_without = st;
    const Solution sol_without = sol;
    hints = {trial.tau_a, trial.tau_b};
    st.tau_a = trial.tau_a;
    st.tau_b = trial.tau_b;
    std::vector<Column> with = cols;
    if (on[0]) with.push_back({Kind::spike_a});
    if (on[1]) with.push_back({Kind::spike_b});
    std::swap(cols, with);
    fit();
    // Keep a spike only when it stands out; else it is noise fitted by the free decay.
    std::vector<Kind> drop;
    for (Kind k : {Kind::spike_a, Kind::spike_b}) {
      const auto j = find(cols, k);
      if (!j) continue;
      const auto ji = static_cast<Eigen::Index>(*j);
      const double h = sol.x[ji];
      const double se = std::sqrt(std::max(0.0, sol.sigma2 * sol.inv(ji, ji)));
      const bool at_edge = (k == Kind::spike_a ? st.tau_a : st.tau_b) > 0.9 * tau_hi;
      if (!(std::abs(h) > options.spike_detection_t * se) || at_edge || h < options.min_spike_mm) {
        drop.push_back(k);
      }
    }
    for (Kind k : drop) {
      cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, k)));
      (k == Kind::spike_a ? st.tau_a : st.tau_b) = 0.0;
    }
    if (drop.size() == static_cast<std::size_t>(on[0]) + static_cast<std::size_t>(on[1])) {
      st = st_without;
      sol = sol_without;
    } else if (!drop.empty()) {
      fit();
    }
  };
  search_spikes();

  // With the spikes in the model, a pitch found by the periodogram is refined once more, and
  // the spikes are searched again with that pitch.
  bool refined = false;
  for (int ax = 0; ax < 2; ++ax) {
    auto& cy = D.cyclic[static_cast<std::size_t>(ax)];
    if (!cy || cy->pitch_source != "periodogram") continue;
    const Kind ks = ax == 0 ? Kind::cyclic_a_sin : Kind::cyclic_b_sin;
    const Kind kc = ax == 0 ? Kind::cyclic_a_cos : Kind::cyclic_b_cos;
    cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, ks)));
    cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, kc)));
    fit();
    const double df = 1.0 / (16.0 * S.pos_span(ax));
    const std::size_t cstride = std::max<std::size_t>(1, (S.size() + 199999) / 200000);
    const Profile prof = make_profile(S, st, cols, sol, cstride);
    auto rss_at = [&](double f) {
      State s2 = st;
      (ax == 0 ? s2.pitch_a : s2.pitch_b) = 1.0 / f;
      return profile_rss(S, s2, prof, {{ks}, {kc}});
    };
    const double pitch = 1.0 / golden(rss_at, 1.0 / cy->pitch_mm - df, 1.0 / cy->pitch_mm + df, 14);
    (ax == 0 ? st.pitch_a : st.pitch_b) = pitch;
    cols.push_back({ks});
    cols.push_back({kc});
    fit();
    const auto js = static_cast<Eigen::Index>(*find(cols, ks));
    const auto jc = static_cast<Eigen::Index>(*find(cols, kc));
    cy->pitch_mm = pitch;
    cy->amplitude_mm = std::hypot(sol.x[js], sol.x[jc]);
    cy->phase_rad = std::atan2(sol.x[jc], sol.x[js]);
    cy->amplitude_se_mm = std::sqrt(sol.sigma2 * std::max(sol.inv(js, js), sol.inv(jc, jc)));
    refined = true;
    // The peak may have been the spikes' residual before they were fitted: the same test as
    // when it was found, now with the spikes in the model.
    if (cy->amplitude_mm < options.min_cyclic_amplitude_mm ||
        cy->amplitude_mm < 5.0 * cy->amplitude_se_mm) {
      cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, ks)));
      cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, kc)));
      (ax == 0 ? st.pitch_a : st.pitch_b) = 0.0;
      cy.reset();
      fit();
    }
  }
  if (refined) search_spikes();

  // Parameters and standard errors.
  auto est = [&](Kind k, double scale, int group = 0) -> Estimate {
    Estimate e;
    if (auto j = find(cols, k, group)) {
      const auto ji = static_cast<Eigen::Index>(*j);
      e.value = sol.x[ji] * scale;
      e.standard_error = std::sqrt(std::max(0.0, sol.sigma2 * sol.inv(ji, ji))) * std::abs(scale);
    }
    return e;
  };
  for (int ax = 0; ax < 2; ++ax) {
    auto& cy = D.cyclic[static_cast<std::size_t>(ax)];
    if (!cy) continue;
    const auto js =
        static_cast<Eigen::Index>(*find(cols, ax == 0 ? Kind::cyclic_a_sin : Kind::cyclic_b_sin));
    const auto jc =
        static_cast<Eigen::Index>(*find(cols, ax == 0 ? Kind::cyclic_a_cos : Kind::cyclic_b_cos));
    cy->amplitude_mm = std::hypot(sol.x[js], sol.x[jc]);
    cy->phase_rad = std::atan2(sol.x[jc], sol.x[js]);
    cy->amplitude_se_mm = std::sqrt(sol.sigma2 * std::max(sol.inv(js, js), sol.inv(jc, jc)));
  }
  D.centre_offset_mm = {est(Kind::centre_a, 1.0), est(Kind::centre_b, 1.0)};
  D.backlash_mm = {est(Kind::backlash_a, 1.0), est(Kind::backlash_b, 1.0)};
  for (int ax = 0; ax < 2; ++ax) {
    auto& b = D.backlash_mm[static_cast<std::size_t>(ax)];
    if ((ax == 0 ? reversal_a : reversal_b) || !b.value) continue;
    D.notes.push_back(fmt::format(
        "{} does not reverse: the runs of the two directions are {:.2f} um apart along {} (lost "
        "motion or drift; not reported as backlash)",
        ax == 0 ? A : B, *b.value * 1e3, ax == 0 ? A : B));
    b = {};
  }
  D.spike_mm = {est(Kind::spike_a, 1.0), est(Kind::spike_b, 1.0)};
  for (int ax = 0; ax < 2; ++ax) {
    const auto axs = static_cast<std::size_t>(ax);
    const bool reversal = ax == 0 ? reversal_a : reversal_b;
    const double tau = ax == 0 ? st.tau_a : st.tau_b;
    if (D.spike_mm[axs].value) {
      D.spike_ms[axs].value = tau * 1e3;
      // Standard error of the decay: the Jacobian with its derivative column added.
      State s2 = st;
      s2.spike_h_a = D.spike_mm[0].value.value_or(0.0);
      s2.spike_h_b = D.spike_mm[1].value.value_or(0.0);
      std::vector<Column> aug = cols;
      aug.push_back({ax == 0 ? Kind::spike_tau_a : Kind::spike_tau_b});
      const Normal N = accumulate(S, s2, aug, stride, memo);
      const auto last = static_cast<Eigen::Index>(aug.size() - 1);
      const Solution a = solve(N);
      D.spike_ms[axs].standard_error =
          std::sqrt(std::max(0.0, sol.sigma2 * a.inv(last, last))) * 1e3;
    } else if (reversal && speed_known &&
               find(cols, ax == 0 ? Kind::backlash_a : Kind::backlash_b)) {
      // No spike that stands out of the noise: height zero, decay undefined.
      D.spike_mm[axs].value = 0.0;
    }
  }
  D.scale_mismatch_ppm = est(Kind::scale_mismatch, 1e6);
  if (!squareness_servo_confounded) {
    D.squareness_urad = est(Kind::squareness, 1e6);
    D.servo_mismatch_ms = est(Kind::servo, 1e3);
  }
  for (std::size_t g = 0; g < group_feed.size(); ++g) {
    FeedRadius fr;
    fr.feed_mm_per_min = group_feed[g];
    fr.dr_mm = est(Kind::radius, 1.0, static_cast<int>(g));
    D.radius_change.push_back(fr);
  }
  if (!ev.nominal_radius_mm) {
    for (auto& fr : D.radius_change) fr.dr_mm = {};
  }

  // The mean following lag from the commanded columns (same servo period as the instrument).
  const std::vector<double>* cmd_a = cmd_column(trace, la);
  const std::vector<double>* cmd_b = cmd_column(trace, lb);
  std::optional<double> lag_s;
  double period = 0.0;
  if (cmd_a && cmd_b && speed_known) {
    const double oa = D.centre_offset_mm[0].value.value_or(0.0);
    const double ob = D.centre_offset_mm[1].value.value_or(0.0);
    const double alpha = D.squareness_urad.value.value_or(0.0) * 1e-6;
    const double ds = D.scale_mismatch_ppm.value.value_or(0.0) * 1e-6;
    const double ba = D.backlash_mm[0].value.value_or(0.0);
    const double bb = D.backlash_mm[1].value.value_or(0.0);
    const double dtau = D.servo_mismatch_ms.value.value_or(0.0) * 1e-3;
    // Per run, the sums of the tangential deviation and of the geometric terms' part of it; on
    // the threads, per block, added in block order.
    const std::size_t nruns = S.runs.size();
    const std::size_t nblocks = (S.size() + kBlockSamples - 1) / kBlockSamples;
    std::vector<double> tsums(nblocks * nruns, 0.0), gsums(nblocks * nruns, 0.0);
    for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t block) {
      // The block's part of each run: contiguous rows of the trace, summed without branches
      // (so the loop is vectorised); a row whose lag angle is too large for the series sends
      // the part through atan2 again.
      for (std::size_t j0 = lo; j0 < hi;) {
        const std::size_t k = S.run[j0];
        const RunInfo& info = S.runs[k];
        const std::size_t j1 = std::min(hi, info.end);
        const std::size_t i0 = info.trace_begin + (j0 - info.begin), n = j1 - j0;
        const double* ra = col_a.data() + i0;
        const double* rb = col_b.data() + i0;
        const double* qa_ = cmd_a->data() + i0;
        const double* qb_ = cmd_b->data() + i0;
        double tsum = 0.0, gsum = 0.0;
        int far = 0;
#pragma omp simd reduction(+ : tsum, gsum) reduction(| : far)
        for (std::size_t q = 0; q < n; ++q) {
          const double ma = ra[q] - ca - oa, mb = rb[q] - cb - ob;
          const double qa = qa_[q] - ca, qb = qb_[q] - cb;
          const double cross = qa * mb - qb * ma, dot = qa * ma + qb * mb;
          far |= static_cast<int>(!(dot > 0.0 && std::abs(cross) < detail::kAtanSeriesMax * dot));
          tsum += detail::atan_series(cross / dot);
          // No overflow or underflow at machine coordinates: hypot's care is not needed.
          const double r = std::sqrt(ma * ma + mb * mb);
          const double c = ma / r, s = mb / r;
          // Tangential deviations the fitted geometric terms make (docs/diagnosis.md).
          gsum += -info.dir * alpha * R * s * s - info.dir * R * ds * s * c -
                  0.5 * ba * std::abs(s) - 0.5 * bb * std::abs(c) -
                  info.speed_mm_s * 0.5 * dtau * (s * s - c * c);
        }
        if (far != 0) {
          tsum = 0.0;
          for (std::size_t q = 0; q < n; ++q) {
            const double ma = ra[q] - ca - oa, mb = rb[q] - cb - ob;
            const double qa = qa_[q] - ca, qb = qb_[q] - cb;
            tsum += detail::turn_angle(qa * mb - qb * ma, qa * ma + qb * mb);
          }
        }
        tsums[block * nruns + k] += info.dir * tsum * R;
        gsums[block * nruns + k] += gsum;
        j0 = j1;
      }
    });
    double num = 0.0, den = 0.0;
    for (std::size_t k = 0; k < nruns; ++k) {
      const RunInfo& info = S.runs[k];
      double tsum = 0.0, gsum = 0.0;
      for (std::size_t b = 0; b < nblocks; ++b) {
        tsum += tsums[b * nruns + k];
        gsum += gsums[b * nruns + k];
      }
      const auto n = static_cast<double>(info.end - info.begin);
      // T = -v lag + g  =>  lag = (g - T) / v
      num += (gsum - tsum) / info.speed_mm_s;
      den += n;
    }
    // The commanded value is sampled in the same period as the position it leads to: the
    // continuous loop's lag is half a sample longer than the delay seen between samples.
    if (const std::vector<double>* t = trace.column(column_name::t)) {
      const Run& r0 = ev.runs.front().run;
      if (r0.size() > 1)
        period = ((*t)[r0.end - 1] - (*t)[r0.begin]) / static_cast<double>(r0.size() - 1);
    }
    if (den > 0) {
      lag_s = num / den + period / 2.0;
      D.lag_ms.value = *lag_s * 1e3;
    }
  }
  // Unequal loops also scale the two axes' amplitudes differently (a cos 2theta term that
  // looks like a scale mismatch): -(v^2 / 2R)(tauA^2 - tauB^2)/2 = -(R/2) w^2 lag dtau.
  if (lag_s && D.servo_mismatch_ms.value && D.scale_mismatch_ppm.value) {
    double w2 = 0.0;
    for (std::size_t i = 0; i < S.size(); ++i) {
      const double w = S.runs[S.run[i]].speed_mm_s / R;
      w2 += w * w;
    }
    w2 /= static_cast<double>(S.size());
    *D.scale_mismatch_ppm.value += w2 * *lag_s * *D.servo_mismatch_ms.value * 1e-3 * 1e6;
  } else if (D.servo_mismatch_ms.value && D.scale_mismatch_ppm.value) {
    D.notes.push_back(
        "no commanded columns: the scale mismatch includes the cos 2theta part of the servo "
        "mismatch (w^2 lag dtau)");
  }

  // Absolute scale and Kv from the radius change: it is R (sA + sB) / 2 - v^2 lag^2 / (2 R).
  const std::optional<double> ds = D.scale_mismatch_ppm.value;
  std::optional<double> mean_scale, mean_scale_se;
  std::size_t nfeeds = 0;
  for (const auto& fr : D.radius_change) nfeeds += fr.dr_mm.value ? 1 : 0;
  if (ev.nominal_radius_mm && nfeeds >= 2) {
    // Weighted line dr = c0 + k v^2.
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const auto& fr : D.radius_change) {
      if (!fr.dr_mm.value) continue;
      const double v = fr.feed_mm_per_min / 60.0;
      const double se = std::max(fr.dr_mm.standard_error.value_or(1e-6), 1e-9);
      const double w = 1.0 / (se * se);
      const double x = v * v, y = *fr.dr_mm.value;
      sw += w;
      sx += w * x;
      sy += w * y;
      sxx += w * x * x;
      sxy += w * x * y;
    }
    const double det = sw * sxx - sx * sx;
    if (det > 0) {
      const double k = (sw * sxy - sx * sy) / det;
      const double c0 = (sxx * sy - sx * sxy) / det;
      const double se_k = std::sqrt(sw / det), se_c0 = std::sqrt(sxx / det);
      mean_scale = c0 / R;
      mean_scale_se = se_c0 / R;
      if (k < 0 && -k > 2 * se_k) {
        const double kv = std::sqrt(-1.0 / (2.0 * R * k));
        D.kv_per_s.value = kv;
        D.kv_per_s.standard_error = kv * 0.5 * se_k / std::abs(k);
        D.kv_source = "feeds";
      } else {
        D.notes.push_back(
            "the radius does not shrink measurably with feed: no position-loop gain derived");
      }
    }
  } else if (ev.nominal_radius_mm && nfeeds == 1 && lag_s) {
    const auto& fr = *std::find_if(D.radius_change.begin(), D.radius_change.end(),
                                   [](const FeedRadius& f) { return f.dr_mm.value.has_value(); });
    const double v = fr.feed_mm_per_min / 60.0;
    const double dtau = D.servo_mismatch_ms.value.value_or(0.0) * 1e-3;
    const double loss = -v * v * (*lag_s * *lag_s + dtau * dtau / 4.0) / (2.0 * R);
    mean_scale = (*fr.dr_mm.value - loss) / R;
    mean_scale_se = fr.dr_mm.standard_error.value_or(0.0) / R;
    if (*lag_s > 2.0 * period) {
      D.kv_per_s.value = 1.0 / *lag_s;
      D.kv_source = "lag";
    }
    D.notes.push_back(fmt::format(
        "one feed: the servo radius loss ({:.2f} um) is taken from the following lag against "
        "the commanded columns ({:.3f} ms); the rest of the radius change is scale",
        loss * 1e3, *lag_s * 1e3));
  } else if (ev.nominal_radius_mm) {
    D.notes.push_back(
        "one feed and no commanded columns: the radius change mixes the mean scale of the "
        "axes and the servo radius loss; absolute scale not reported (run two feeds)");
  }
  if (!D.absolute_channels) {
    mean_scale.reset();
    D.notes.push_back("instrument is not absolute (ballbar): only the scale mismatch is reported");
  }
  if (mean_scale && ds) {
    const double se_ds = D.scale_mismatch_ppm.standard_error.value_or(0.0);
    const double m = *mean_scale * 1e6, mse = mean_scale_se.value_or(0.0) * 1e6;
    D.scale_ppm[0].value = m + *ds / 2;
    D.scale_ppm[1].value = m - *ds / 2;
    D.scale_ppm[0].standard_error = D.scale_ppm[1].standard_error = std::hypot(mse, se_ds / 2);
  }

  // Residual over every sample, and the model's terms for the contributions.
  const Reversals rev(S, st.servo_mismatch_s);
  // The sources of the contributions (below), and each column's: their terms' ranges per run
  // are taken in the same pass as the residual.
  std::vector<std::string> sources;
  std::vector<int> source_of(cols.size(), -1);
  for (std::size_t j = 0; j < cols.size(); ++j) {
    const Column& c = cols[j];
    if (c.kind == Kind::centre_a || c.kind == Kind::centre_b || c.kind == Kind::radius) continue;
    const std::string name = kind_name(c.kind, D.axes);
    auto at = std::find(sources.begin(), sources.end(), name);
    if (at == sources.end()) at = sources.insert(sources.end(), name);
    source_of[j] = static_cast<int>(at - sources.begin());
  }
  const std::size_t ns = sources.size();
  // One pass over all samples on the threads. Per block: each run's term ranges, the model's
  // extremes (first minimum, last maximum, as std::minmax_element) and the residual's range
  // off the reversals; combined in block order, so the result is the sequential one.
  const std::size_t nruns = S.runs.size();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  struct Extremes {
    std::vector<double> term_min, term_max;  // [run * ns + source]
    std::vector<double> model_min, model_max, resid_min, resid_max;
    std::vector<std::size_t> model_imin, model_imax;
    double ss = 0.0;
    std::array<std::vector<ReversalEvent>, 2> events;  // per axis, in sample order
  };
  const std::size_t nblocks = (S.size() + kBlockSamples - 1) / kBlockSamples;
  std::vector<Extremes> ext(nblocks);
  for (Extremes& e : ext) {
    e.term_min.assign(ns * nruns, kInf);
    e.term_max.assign(ns * nruns, -kInf);
    for (auto* v : {&e.model_min, &e.resid_min}) v->assign(nruns, kInf);
    for (auto* v : {&e.model_max, &e.resid_max}) v->assign(nruns, -kInf);
    e.model_imin.assign(nruns, 0);
    e.model_imax.assign(nruns, 0);
  }
  std::vector<double> resid;
  reserve_huge(resid, S.size());
  resid.resize(S.size());
  for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t block) {
    Extremes& e = ext[block];
    // The samples in chunks inside one run: the columns filled with each kind dispatched
    // once, then every sum and extreme a column at a time (loops the compiler vectorises; each
    // sample's sums still add the columns in their order).
    constexpr std::size_t kChunk = 512;
    const std::size_t p = cols.size();
    std::vector<std::size_t> idx(kChunk);
    std::vector<Reversal> rvs(kChunk);
    std::vector<double> colv(kChunk * p), full(kChunk), shape(kChunk), term(kChunk * ns);
    std::vector<double> xs(p);
    for (std::size_t j = 0; j < p; ++j) xs[j] = sol.x[static_cast<Eigen::Index>(j)];
    // The sources that take a backlash column's transition (offset) part too.
    int src_ba = -1, src_bb = -1;
    for (std::size_t j = 0; j < p; ++j) {
      if (cols[j].kind == Kind::backlash_a && st.backlash_a > 0) src_ba = source_of[j];
      if (cols[j].kind == Kind::backlash_b && st.backlash_b > 0) src_bb = source_of[j];
    }
    // The reversals inside a run, where the angle since one drops from a sample to the next.
    Reversal prev{};
    if (lo > 0) prev = rev.at(lo - 1);
    for (std::size_t c0 = lo; c0 < hi;) {
      const std::size_t run = S.run[c0];
      const std::size_t c1 = std::min({hi, c0 + kChunk, S.runs[run].end});
      const std::size_t m = c1 - c0;
      for (std::size_t t = 0; t < m; ++t) {
        const std::size_t i = c0 + t;
        idx[t] = i;
        const Reversal rv = rev.at(i);
        rvs[t] = rv;
        if (i > 0 && S.run[i - 1] == run) {
          if (rv.since_a < prev.since_a) e.events[0].push_back({i, rv.since_a, rv.dir_a});
          if (rv.since_b < prev.since_b) e.events[1].push_back({i, rv.since_b, rv.dir_b});
        }
        prev = rv;
        full[t] = offset(S, st, cols, i, rv);
        shape[t] = full[t];  // without centring and radius
      }
      std::fill(term.begin(), term.end(), 0.0);
      for (std::size_t j = 0; j < p; ++j) {
        double* cv = colv.data() + j * kChunk;
        fill_column(S, st, cols[j], idx.data(), rvs.data(), m, cv, 1);
        const double xj = xs[j];
        const int src = source_of[j];
        if (src < 0) {
          for (std::size_t t = 0; t < m; ++t) full[t] += cv[t] * xj;
          continue;
        }
        double* tk = term.data() + static_cast<std::size_t>(src) * kChunk;
        for (std::size_t t = 0; t < m; ++t) {
          const double v = cv[t] * xj;
          full[t] += v;
          shape[t] += v;
          tk[t] += v;
        }
      }
      if (src_ba >= 0) {
        double* tk = term.data() + static_cast<std::size_t>(src_ba) * kChunk;
        for (std::size_t t = 0; t < m; ++t)
          tk[t] += backlash_terms(rvs[t].dir_a, rvs[t].trav_a, st.backlash_a).second * S.c[c0 + t];
      }
      if (src_bb >= 0) {
        double* tk = term.data() + static_cast<std::size_t>(src_bb) * kChunk;
        for (std::size_t t = 0; t < m; ++t)
          tk[t] += backlash_terms(rvs[t].dir_b, rvs[t].trav_b, st.backlash_b).second * S.s[c0 + t];
      }
      const std::size_t base = run * ns;
      for (std::size_t k = 0; k < ns; ++k) {
        const double* tk = term.data() + k * kChunk;
        double mn = e.term_min[base + k], mx = e.term_max[base + k];
        for (std::size_t t = 0; t < m; ++t) {
          mn = std::min(mn, tk[t]);
          mx = std::max(mx, tk[t]);
        }
        e.term_min[base + k] = mn;
        e.term_max[base + k] = mx;
      }
      for (std::size_t t = 0; t < m; ++t) {
        const std::size_t i = c0 + t;
        if (shape[t] < e.model_min[run]) {
          e.model_min[run] = shape[t];
          e.model_imin[run] = i;
        }
        if (!(shape[t] < e.model_max[run])) {
          e.model_max[run] = shape[t];
          e.model_imax[run] = i;
        }
        const double res = S.dr[i] - full[t];
        resid[i] = res;
        e.ss += res * res;
        if (!at_reversal(S, i, rvs[t])) {
          e.resid_min[run] = std::min(e.resid_min[run], res);
          e.resid_max[run] = std::max(e.resid_max[run], res);
        }
      }
      c0 = c1;
    }
  });
  Extremes all = ext.empty() ? Extremes{} : ext.front();
  for (std::size_t b = 1; b < ext.size(); ++b) {
    const Extremes& e = ext[b];
    for (std::size_t k = 0; k < ns * nruns; ++k) {
      all.term_min[k] = std::min(all.term_min[k], e.term_min[k]);
      all.term_max[k] = std::max(all.term_max[k], e.term_max[k]);
    }
    for (std::size_t r = 0; r < nruns; ++r) {
      if (e.model_min[r] < all.model_min[r]) {
        all.model_min[r] = e.model_min[r];
        all.model_imin[r] = e.model_imin[r];
      }
      if (e.model_max[r] != -kInf && !(e.model_max[r] < all.model_max[r])) {
        all.model_max[r] = e.model_max[r];
        all.model_imax[r] = e.model_imax[r];
      }
      all.resid_min[r] = std::min(all.resid_min[r], e.resid_min[r]);
      all.resid_max[r] = std::max(all.resid_max[r], e.resid_max[r]);
    }
    all.ss += e.ss;
    for (std::size_t ax = 0; ax < 2; ++ax)
      all.events[ax].insert(all.events[ax].end(), e.events[ax].begin(), e.events[ax].end());
  }
  const std::vector<double>& term_min = all.term_min;
  const std::vector<double>& term_max = all.term_max;
  reversal_steps(S, resid, all.events, D);
  D.residual_rms_mm = std::sqrt(all.ss / static_cast<double>(S.size()));
  std::size_t imax = 0, imin = 0;
  for (std::size_t k = 0; k < nruns; ++k) {
    const RunInfo& r = S.runs[k];
    if (all.resid_max[k] >= all.resid_min[k])
      D.residual_g_mm = std::max(D.residual_g_mm, all.resid_max[k] - all.resid_min[k]);
    if (r.end == r.begin) continue;
    if (all.model_max[k] - all.model_min[k] >= D.model_g_mm) {
      D.model_g_mm = all.model_max[k] - all.model_min[k];
      imax = all.model_imax[k];
      imin = all.model_imin[k];
    }
  }
  // Contributions: each source's term alone (its G over the runs) and its part of the
  // modelled G at the model's extreme points (these parts add up to the modelled G).
  for (std::size_t k = 0; k < ns; ++k) {
    const std::string& name = sources[k];
    std::vector<std::size_t> mine;
    for (std::size_t j = 0; j < cols.size(); ++j) {
      if (kind_name(cols[j].kind, D.axes) == name) mine.push_back(j);
    }
    auto term = [&](std::size_t i) {
      const Reversal rv = rev.at(i);
      double t = 0.0;
      for (std::size_t j : mine) {
        t += value(S, st, cols[j], i, rv) * sol.x[static_cast<Eigen::Index>(j)];
        if (cols[j].kind == Kind::backlash_a && st.backlash_a > 0) {
          t += backlash_terms(rv.dir_a, rv.trav_a, st.backlash_a).second * S.c[i];
        } else if (cols[j].kind == Kind::backlash_b && st.backlash_b > 0) {
          t += backlash_terms(rv.dir_b, rv.trav_b, st.backlash_b).second * S.s[i];
        }
      }
      return t;
    };
    Contribution con;
    con.source = name;
    for (std::size_t r = 0; r < S.runs.size(); ++r) {
      if (S.runs[r].end == S.runs[r].begin) continue;
      con.g_mm = std::max(con.g_mm, term_max[r * ns + k] - term_min[r * ns + k]);
    }
    con.share_mm = term(imax) - term(imin);
    con.percent = D.model_g_mm > 0 ? 100.0 * con.share_mm / D.model_g_mm : 0.0;
    D.contributions.push_back(con);
  }
  std::stable_sort(D.contributions.begin(), D.contributions.end(),
                   [](const Contribution& a, const Contribution& b) { return a.g_mm > b.g_mm; });
  if (const auto what = first_not_finite(D)) {
    const Run& first = ev.runs.front().run;
    throw DataError(trace.source, trace.line_of_row[first.begin],
                    fmt::format("diagnosis not measurable: the model fit gives no finite {} on "
                                "these {} samples (lines {}-{}): the samples do not determine "
                                "the model (noise far above the errors, or a time column that "
                                "stalls and jumps)",
                                *what, S.size(), trace.line_of_row[first.begin],
                                trace.line_of_row[ev.runs.back().run.end - 1]));
  }
  return D;
}

}  // namespace circtest
