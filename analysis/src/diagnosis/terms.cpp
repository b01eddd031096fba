// The model's terms: the candidates in order of priority, and those the trace identifies.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "circtest/core/error.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

// What choose_terms works on: the candidate columns, those the trace identifies, the others
// with how much of them is left unexplained, and a rejected reported term with a kept one its
// effect goes into.
struct Selection {
  std::vector<Column> cand;
  std::vector<std::pair<Column, double>> rejected;
  std::vector<std::pair<Kind, Kind>> confounded;
};

// Candidate columns in order of priority: a later one that the earlier ones already explain
// is not identifiable and is left out.
void candidates(const TraceDescription& td, const SampleSet& ss, std::vector<Column>& cand,
                Diagnosis& D) {
  const std::vector<double>& group_feed = ss.group_feed;
  const bool reversal_a = ss.reversal_a, reversal_b = ss.reversal_b;
  const std::string &A = td.A, &B = td.B;
  cand.push_back({Kind::centre_a});
  cand.push_back({Kind::centre_b});
  for (std::size_t g = 0; g < group_feed.size(); ++g)
    cand.push_back({Kind::radius, static_cast<int>(g)});
  cand.push_back({Kind::scale_mismatch});
  cand.push_back({Kind::squareness});
  // The direction-dependent ellipse of unequal lags is fitted with or without the feed
  // (without it as a phase, runs.cpp): left out, it would go into the backlash.
  cand.push_back({Kind::servo});
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
}

// A fit of p terms on a handful of samples has no residual left to judge it by: its
// standard errors and identifiability test mean nothing and the later stages (periodogram,
// decay search) work on noise. Refused up front, naming what it needs.
void refuse_too_few_samples(const Inputs& in, const Samples& S, const std::vector<Column>& cand) {
  const Trace& trace = in.trace;
  const Evaluation& ev = in.ev;
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
}

// The reported terms a rejected column's effect goes into: the kept columns its regression
// on them leans on (a normalised coefficient of at least kPartnerWeight).
constexpr double kPartnerWeight = 0.1;

std::vector<Kind> partners(const Eigen::MatrixXd& C, const std::vector<Eigen::Index>& kept,
                           const std::vector<Column>& in, Eigen::Index j) {
  std::vector<Kind> out;
  if (kept.empty()) return out;
  const auto k = static_cast<Eigen::Index>(kept.size());
  const Eigen::VectorXd x = regression(C, kept, j);
  for (Eigen::Index u = 0; u < k; ++u) {
    const Kind kind = in[static_cast<std::size_t>(kept[static_cast<std::size_t>(u)])].kind;
    if (std::abs(x[u]) >= kPartnerWeight && !term_key(kind, {'A', 'B'}).empty())
      out.push_back(kind);
  }
  return out;
}

// Identifiability: forward selection on the normalised normal matrix.
void select(const Samples& S, double vif_floor, Selection& sel, Model& m) {
  const std::vector<Column>& in = sel.cand;
  std::vector<Column>& out = m.cols;
  std::vector<std::pair<Column, double>>& rejected = sel.rejected;
  const Normal N = accumulate(S, m.st, in, m.stride, m.memo);
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
      if (!term_key(in[j].kind, {'A', 'B'}).empty()) {
        for (const Kind p : partners(C, kept, in, ji)) sel.confounded.emplace_back(in[j].kind, p);
      }
    }
  }
}

// What the trace does not identify, and why.
void rejected_notes(const SampleSet& ss, const Selection& sel, const std::vector<Column>& cols,
                    TermSet& terms, Diagnosis& D) {
  const bool reversal_a = ss.reversal_a, reversal_b = ss.reversal_b;
  const std::vector<double>& group_feed = ss.group_feed;
  bool& squareness_servo_confounded = terms.squareness_servo_confounded;
  const std::vector<std::pair<Column, double>>& rejected = sel.rejected;
  const auto unseparable = [&terms, &D](Kind k) {
    if (std::find(terms.unseparable.begin(), terms.unseparable.end(), k) != terms.unseparable.end())
      return;
    terms.unseparable.push_back(k);
    D.unseparable.push_back(term_key(k, D.axes));
  };
  for (const auto& [col, u] : rejected) {
    const std::string name = kind_name(col.kind, D.axes);
    std::vector<Kind> with;
    for (const auto& [k, p] : sel.confounded) {
      if (k == col.kind) with.push_back(p);
    }
    if ((col.kind == Kind::backlash_a && !reversal_a) ||
        (col.kind == Kind::backlash_b && !reversal_b)) {
      // Already said: no reversal.
    } else if (col.kind == Kind::servo && find(cols, Kind::squareness)) {
      squareness_servo_confounded = true;
      unseparable(Kind::squareness);
      unseparable(Kind::servo);
      D.notes.push_back(
          "squareness and servo mismatch both make a sin 2theta term here (one direction at one "
          "feed): they cannot be separated and neither is reported; both directions or two "
          "feeds separate them");
    } else if (!with.empty()) {
      std::string names;
      unseparable(col.kind);
      for (const Kind p : with) {
        names += (names.empty() ? "" : ", ") + kind_name(p, D.axes);
        unseparable(p);
      }
      D.notes.push_back(fmt::format(
          "{} cannot be separated from {} by this trace (its term is {:.2f} % explained by "
          "theirs): none of them is reported",
          name, names, 100.0 * (1.0 - u)));
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
}

}  // namespace

ChosenTerms choose_terms(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                         Diagnosis& D) {
  Selection sel;
  candidates(td, ss, sel.cand, D);
  refuse_too_few_samples(in, ss.S, sel.cand);
  const DiagnosisOptions& options = in.options;
  const Samples& S = ss.S;
  ChosenTerms out;
  out.model.stride =
      std::max<std::size_t>(1, (S.size() + options.max_fit_samples - 1) / options.max_fit_samples);
  const double vif_floor = 1.0 / options.max_variance_inflation;
  select(S, vif_floor, sel, out.model);
  rejected_notes(ss, sel, out.model.cols, out.terms, D);
  return out;
}

}  // namespace circtest::diagnosis_detail
