// The model's terms: the candidates in order of priority, and those the trace identifies.
#include <fmt/format.h>

#include "circtest/core/error.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

// Candidate columns in order of priority: a later one that the earlier ones already explain
// is not identifiable and is left out.
void candidates(DiagnosisState& ds) {
  Diagnosis& D = ds.D;
  std::vector<Column>& cand = ds.cand;
  const std::vector<double>& group_feed = ds.group_feed;
  const bool speed_known = ds.speed_known, reversal_a = ds.reversal_a, reversal_b = ds.reversal_b;
  const std::string &A = ds.A, &B = ds.B;
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
}

// A fit of p terms on a handful of samples has no residual left to judge it by: its
// standard errors and identifiability test mean nothing and the later stages (periodogram,
// decay search) work on noise. Refused up front, naming what it needs.
void refuse_too_few_samples(const DiagnosisState& ds) {
  const Trace& trace = ds.trace;
  const Evaluation& ev = ds.ev;
  const Samples& S = ds.S;
  const std::vector<Column>& cand = ds.cand;
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

// Identifiability: forward selection on the normalised normal matrix.
void select(DiagnosisState& ds) {
  const std::vector<Column>& in = ds.cand;
  std::vector<Column>& out = ds.cols;
  std::vector<std::pair<Column, double>>& rejected = ds.rejected;
  const double vif_floor = ds.vif_floor;
  const Normal N = accumulate(ds.S, ds.st, in, ds.stride, ds.memo);
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
}

// What the trace does not identify, and why.
void rejected_notes(DiagnosisState& ds) {
  Diagnosis& D = ds.D;
  const std::vector<Column>& cols = ds.cols;
  const bool reversal_a = ds.reversal_a, reversal_b = ds.reversal_b;
  const std::vector<double>& group_feed = ds.group_feed;
  bool& squareness_servo_confounded = ds.squareness_servo_confounded;
  const std::vector<std::pair<Column, double>>& rejected = ds.rejected;
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
}

}  // namespace

void choose_terms(DiagnosisState& ds) {
  candidates(ds);
  refuse_too_few_samples(ds);
  const DiagnosisOptions& options = ds.options;
  const Samples& S = ds.S;
  ds.stride =
      std::max<std::size_t>(1, (S.size() + options.max_fit_samples - 1) / options.max_fit_samples);
  ds.vif_floor = 1.0 / options.max_variance_inflation;
  select(ds);
  rejected_notes(ds);
}

}  // namespace circtest::diagnosis_detail
