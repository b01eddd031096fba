// Profiling added columns against a base fit.
#include "profile.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <new>

#include "circtest/core/memory.hpp"

namespace circtest::diagnosis_detail {

namespace {

// One added column on the profile's rows. A spike term is its sign times spike_unit, the
// same value as `value` gives.
void profile_column(const Samples& S, const State& st, const Profile& P, const Column& col,
                    Eigen::Ref<Eigen::VectorXd> out) {
  const Eigen::Index n = P.J.rows();
  if (col.kind == Kind::spike_a || col.kind == Kind::spike_b) {
    const int ax = col.kind == Kind::spike_a ? 0 : 1;
    const VecMap& sign = P.spike_sign[static_cast<std::size_t>(ax)];
    const VecMap& dt = P.spike_dt_s[static_cast<std::size_t>(ax)];
    for (Eigen::Index r = 0; r < n; ++r) {
      out[r] = dt[r] < 0 ? 0.0 : sign[r] * spike_unit(st, ax, dt[r]);
    }
    return;
  }
  // The other added columns (cyclic) do not depend on the reversals.
  for (Eigen::Index r = 0; r < n; ++r)
    out[r] = plain_value(S, st, col, P.index[static_cast<std::size_t>(r)]);
}

}  // namespace

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

}  // namespace circtest::diagnosis_detail
