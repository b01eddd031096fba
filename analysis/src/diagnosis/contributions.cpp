// The residual over every sample and the modelled G split into each term's contribution.
#include <algorithm>
#include <cmath>
#include <limits>

#include "circtest/analysis/uncertainty.hpp"
#include "circtest/core/memory.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Per block of samples: each run's term ranges, the model's extremes (first minimum, last
// maximum, as std::minmax_element) and the residual's range off the reversals.
struct Extremes {
  std::vector<double> term_min, term_max;  // [run * ns + source]
  std::vector<double> model_min, model_max, resid_min, resid_max;
  std::vector<std::size_t> model_imin, model_imax;
  double ss = 0.0;
  std::array<std::vector<ReversalEvent>, 2> events;  // per axis, in sample order
};

// The sources of the contributions, and each column's (-1: centring and radius, no source).
struct Sources {
  std::vector<std::string> names;
  std::vector<int> of;  // per column
};

// The sources of the contributions (below), and each column's: their terms' ranges per run
// are taken in the same pass as the residual.
Sources contribution_sources(const Model& m, const Diagnosis& D) {
  const std::vector<Column>& cols = m.cols;
  Sources out;
  std::vector<std::string>& sources = out.names;
  std::vector<int>& source_of = out.of;
  source_of.assign(cols.size(), -1);
  for (std::size_t j = 0; j < cols.size(); ++j) {
    const Column& c = cols[j];
    if (c.kind == Kind::centre_a || c.kind == Kind::centre_b || c.kind == Kind::radius) continue;
    const std::string name = kind_name(c.kind, D.axes);
    auto at = std::find(sources.begin(), sources.end(), name);
    if (at == sources.end()) at = sources.insert(sources.end(), name);
    source_of[j] = static_cast<int>(at - sources.begin());
  }
  return out;
}

// The samples [lo, hi) into the residual and the block's extremes.
void residual_block(const Samples& S, const Model& model, const Reversals& rev,
                    const std::vector<int>& source_of, std::size_t ns, std::size_t lo,
                    std::size_t hi, Extremes& e, std::vector<double>& resid) {
  const std::vector<Column>& cols = model.cols;
  const State& st = model.st;
  const Solution& sol = model.sol;
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
}

// One pass over all samples on the threads, combined in block order, so the result is the
// sequential one.
Extremes residual_pass(const Samples& S, const Model& m, const Reversals& rev, const Sources& src,
                       std::vector<double>& resid) {
  const std::size_t ns = src.names.size();
  const std::size_t nruns = S.runs.size();
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
  reserve_huge(resid, S.size());
  resid.resize(S.size());
  for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t block) {
    residual_block(S, m, rev, src.of, ns, lo, hi, ext[block], resid);
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
  return all;
}

// Contributions: each source's term alone (its G over the runs) and its part of the
// modelled G at the model's extreme points imax, imin (these parts add up to the modelled G).
void contributions(const Samples& S, const Model& m, const Reversals& rev, const Sources& src,
                   const Extremes& all, std::size_t imax, std::size_t imin, Diagnosis& D) {
  const std::vector<Column>& cols = m.cols;
  const State& st = m.st;
  const Solution& sol = m.sol;
  const std::vector<std::string>& sources = src.names;
  const std::size_t ns = sources.size();
  const std::vector<double>& term_min = all.term_min;
  const std::vector<double>& term_max = all.term_max;
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
}

}  // namespace

// Residual over every sample, and the model's terms for the contributions.
void residual_and_contributions(const Inputs& in, const SampleSet& ss, const Model& m,
                                Diagnosis& D) {
  const Samples& S = ss.S;
  const Reversals rev(S, m.st.servo_mismatch_s);
  const Sources src = contribution_sources(m, D);
  const std::size_t nruns = S.runs.size();
  std::vector<double> resid;
  const Extremes all = residual_pass(S, m, rev, src, resid);
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
  contributions(S, m, rev, src, all, imax, imin, D);
  // The measured G the residual's is a part of: the largest of the runs (least squares centre).
  for (const RunResult& rr : in.ev.runs) {
    if (!D.measured_g_mm || rr.g_lsc_mm > *D.measured_g_mm) D.measured_g_mm = rr.g_lsc_mm;
  }
  // With its U (k = 2), as every G circtest states.
  if (D.measured_g_mm)
    D.measured_g_u_mm = uncertainty_budget(in.ev, in.ev.uncertainty_options).u_g_mm;
}

}  // namespace circtest::diagnosis_detail
