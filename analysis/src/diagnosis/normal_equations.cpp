// The normal equations of the diagnosis model and their solution.
#include "normal_equations.hpp"

#include <algorithm>
#include <cmath>

namespace circtest::diagnosis_detail {

namespace {

// The servo part of offset() divided by the square of the lag mismatch: the rows away from
// the reversals keep their sums against dr and against this, so a new mismatch needs no pass.
double servo_offset_per_s2(const Samples& S, std::size_t i) {
  const RunInfo& r = S.runs[S.run[i]];
  const double w = r.ellipse_speed_mm_s / S.radius;
  const double c2 = S.c[i] * S.c[i] - S.s[i] * S.s[i], s2 = 2.0 * S.c[i] * S.s[i];
  return -S.radius * w * w * (3.0 / 16.0) * (c2 * c2 - s2 * s2);
}

// Adds the rows idx[0..m) (rvs: their reversal bookkeeping at st) to `out`: the design rows
// transposed (one per column), so J^T J is one matrix product. Y is dr - offset, or with
// `split_servo` (rows off every transition) the two columns dr and servo_offset_per_s2.
void add_rows(const Samples& S, const State& st, const std::vector<Column>& cols,
              const std::size_t* idx, const Reversal* rvs, std::size_t m, bool split_servo,
              Sums& out) {
  // No rows add nothing; an empty design matrix has no storage to point into.
  if (m == 0) return;
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

// Whether `cols` can use steady sums at all: a column of a decay derivative is needed once.
bool steady_applies(const std::vector<Column>& cols) {
  return std::none_of(cols.begin(), cols.end(), [](const Column& c) {
    return c.kind == Kind::spike_tau_a || c.kind == Kind::spike_tau_b;
  });
}

// The angle after a reversal within which run r's spike columns follow a measured profile
// (zero past it).
double shape_rad(const State& st, const RunInfo& r, double radius) {
  double end_s = 0.0;
  for (const auto& shape : st.spike_shape) {
    if (shape) end_s = std::max(end_s, shape->end_s());
  }
  return end_s * r.speed_mm_s / radius;
}

bool steady_valid(const Samples& S, const SteadySums& ss, const State& st,
                  const std::vector<Column>& cols, std::size_t stride) {
  if (ss.stride != stride || ss.cols != cols || st.pitch_a != ss.ref.pitch_a ||
      st.pitch_b != ss.ref.pitch_b || st.tau_a != ss.ref.tau_a || st.tau_b != ss.ref.tau_b ||
      st.spike_shape != ss.ref.spike_shape)
    return false;
  const double need_b =
      std::max(takeup_rad(st.backlash_a, S.radius), takeup_rad(st.backlash_b, S.radius));
  for (std::size_t k = 0; k < S.runs.size(); ++k) {
    const RunInfo& r = S.runs[k];
    const double shift =
        std::abs(r.ellipse_speed_mm_s / S.radius * (st.servo_mismatch_s - ss.ref.servo_mismatch_s));
    if (!(shift + r.eps_rad < ss.before_rad[k]) ||
        !(shift + std::max({r.eps_rad, need_b, shape_rad(st, r, S.radius)}) < ss.after_rad[k]))
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
    const double w = r.ellipse_speed_mm_s / S.radius;
    // Room for the reversals to move with the lag mismatch, and for the excluded samples.
    const double room = std::max(
        {2.0 * r.eps_rad, kPi / 180.0, 2.0 * w * std::max(std::abs(st.servo_mismatch_s), 2e-3)});
    ss.before_rad.push_back(room);
    ss.after_rad.push_back(room + std::max(takeup_rad(play, S.radius), shape_rad(st, r, S.radius)));
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
  // A decaying step's spike column on a steady row is exp(-t / tau) times a fixed part, t the
  // time since the reversal, and a new lag mismatch moves the reversals by its change d in
  // time: A's column scales by exp(d / tau_a) and B's by exp(-d / tau_b) on every such row
  // (docs/diagnosis.md: the reversal of A at w dtau, of B at pi/2 - w dtau). A measured
  // profile is zero on every steady row.
  const double d = st.servo_mismatch_s - ss.ref.servo_mismatch_s;
  if (d != 0.0) {
    Eigen::VectorXd scale = Eigen::VectorXd::Ones(p);
    for (Eigen::Index j = 0; j < p; ++j) {
      const Kind k = cols[static_cast<std::size_t>(j)].kind;
      if (k == Kind::spike_a && st.tau_a > 0 && !st.spike_shape[0])
        scale[j] = std::exp(d / st.tau_a);
      if (k == Kind::spike_b && st.tau_b > 0 && !st.spike_shape[1])
        scale[j] = std::exp(-d / st.tau_b);
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

}  // namespace

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

Eigen::VectorXd regression(const Eigen::MatrixXd& C, const std::vector<Eigen::Index>& set,
                           Eigen::Index j) {
  const auto k = static_cast<Eigen::Index>(set.size());
  Eigen::MatrixXd A(k, k);
  Eigen::VectorXd b(k);
  for (Eigen::Index u = 0; u < k; ++u) {
    b[u] = C(set[static_cast<std::size_t>(u)], j);
    for (Eigen::Index w = 0; w < k; ++w)
      A(u, w) = C(set[static_cast<std::size_t>(u)], set[static_cast<std::size_t>(w)]);
  }
  return A.ldlt().solve(b);
}

// 1 - R^2 of column j regressed on the columns in `set` (all normalised to unit diagonal).
double unexplained(const Eigen::MatrixXd& C, const std::vector<Eigen::Index>& set, Eigen::Index j) {
  if (set.empty()) return 1.0;
  const Eigen::VectorXd x = regression(C, set, j);
  double explained = 0.0;
  for (std::size_t u = 0; u < set.size(); ++u)
    explained += C(set[u], j) * x[static_cast<Eigen::Index>(u)];
  return C(j, j) - explained;
}

}  // namespace circtest::diagnosis_detail
