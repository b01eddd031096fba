#pragma once
// A test set: several planes (and feeds) in one trace, as circgen's set program and
// circlog-record write it (docs/diagnosis.md, "Test sets"). The trace's `plane` metadata lists
// the planes in program order ("XY,YZ,ZX") and each `segments` entry names its plane
// ("id:DIR:Ffeed:PLANE"). The set is split into one trace per plane, each evaluated and
// diagnosed as a single-plane trace, then one model is fitted across the set (diagnose_set): each
// axis's parameters from every plane it appears in, the planes' agreement shown, and the three
// squarenesses.
#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/core/plane.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

// The planes of a set's trace when its `plane` metadata lists two or more, in program order;
// nullopt for a single-plane trace (or none). ParseError at the metadata line for a list that
// is not planes each given once, and for a single-plane trace whose `segments` entries name
// another plane.
std::optional<std::vector<Plane>> test_set_planes(const Trace& trace);

struct PlaneTrace {
  Plane plane = Plane::XY;
  Trace trace;  // the plane's rows (line numbers kept), `plane` and `segments` its own
};

// One trace per plane of the set, in program order. Each holds the rows from the end of the
// previous plane's last run (the start of the trace for the first) to the end of its own last
// run (the end of the trace for the last): its approach, the operator's pause and its runs.
// Throws ParseError (file and metadata line) for `segments` entries without a plane of the set
// or with an id given twice, DataError for a trace without a `segment` column, a run whose
// segment id `segments` does not announce, a plane whose runs are interleaved with another's,
// and a plane of the set without any run in the trace.
std::vector<PlaneTrace> split_test_set(const Trace& trace, const std::vector<Plane>& planes);

// One plane's estimate of a parameter an axis shares across the set.
struct PlaneEstimate {
  Plane plane = Plane::XY;
  Estimate estimate;
};

// A parameter of one axis from every plane that fitted it: the joint value is the joint fit's
// (diagnose_set) or the inverse-variance weighted mean of the planes' (join_set_diagnoses);
// chi2 over dof tells whether the planes agree within their standard errors. When they do
// not (chi2 beyond the 99.9 % point), the joint standard error is scaled by sqrt(chi2 / dof)
// and a note names the planes' values. Planes without standard errors give their plain mean,
// and disagree when they lie more than 10 % of it apart (a note, no standard error).
struct JointEstimate {
  Estimate joint;
  std::vector<PlaneEstimate> planes;
  std::optional<double> chi2;
  int dof = 0;
  bool consistent = true;
};

struct AxisJoint {
  char axis = 'X';  // uppercase
  JointEstimate backlash_mm;
  JointEstimate spike_mm;
  JointEstimate spike_ms;
  JointEstimate scale_ppm;
  // The axis's own following lag, each plane's as it reports it (Diagnosis::axis_lag: the
  // following error over velocity as the trace logs it); the joint fit's in that convention.
  JointEstimate lag_ms;
};

struct SetDiagnosis {
  std::string source;
  std::vector<Plane> planes;                               // program order
  std::vector<Diagnosis> plane_diagnoses;                  // one per plane, in that order
  std::vector<AxisJoint> axes;                             // X, Y, Z: those the planes cover
  std::array<std::optional<Estimate>, 3> squareness_urad;  // XY, YZ, ZX: the planes in the set
  std::vector<double> feeds_mm_per_min;                    // every plane's feeds, each once
  std::vector<std::string> notes;
  bool joint_fit = false;  // the joint values from one model across the set (diagnose_set)
};

// Joins the planes' diagnoses (in the set's order): each axis's joint values are the inverse-
// variance means of the planes' own (joint_fit false).
SetDiagnosis join_set_diagnoses(std::string source, std::vector<Diagnosis> planes);

// A joint value found otherwise (the joint fit) into J, judged against the planes' own: chi2
// of the planes about it on one degree of freedom per plane (99.9 % point), or without
// standard errors more than 10 % of it outside the planes' range, makes it not consistent
// (never "agree" for a joint value outside every plane's), widens its standard error by
// sqrt(chi2 / dof) and returns the note that says so; nothing when it is consistent.
std::optional<std::string> take_joint_value(const AxisJoint& axis, JointEstimate& j,
                                            const Estimate& value, const char* what,
                                            const char* unit, double factor);

// One plane of a set for diagnose_set: its trace, its evaluation and the options its diagnosis
// runs with (a ball bar's plane has no absolute channels).
struct SetPlaneInput {
  const Trace* trace = nullptr;
  const Evaluation* evaluation = nullptr;
  DiagnosisOptions options;
};

// One model across the set (joint_fit true): each plane is diagnosed on its own (its own
// values, the planes' agreement and the nonlinear state: the play's take-up, spike decays,
// cyclic pitches, lag mismatch), then the planes' normal equations at that state are solved as
// one least-squares problem in which each axis's backlash, reversal spike height, scale and
// following lag are one unknown shared by every plane the axis is in, and everything else
// (centre, radius per feed, squareness, cyclic terms) is the plane's own. Each plane's rows
// are weighted by its own residual variance; the standard errors are the joint covariance's
// times the joint residual variance (widened by sqrt(chi2 / dof) where the planes disagree).
// The scales are shared when a plane's radius change gives the mean scale of its two axes
// (the mismatch columns give the differences), the lags when a plane's mean lag against the
// commanded columns is measured (the servo mismatch columns give the differences; the joint
// lag has no standard error, as the mean lags have none); else those columns stay the planes'
// own. The spike decay is the planes' values joined as join_set_diagnoses does. Throws what
// diagnose throws for a plane.
SetDiagnosis diagnose_set(std::string source, const std::vector<SetPlaneInput>& planes);

// diagnose_set for planes split from one trace, every plane with the same options.
SetDiagnosis diagnose_set(const std::vector<PlaneTrace>& planes,
                          const std::vector<Evaluation>& evaluations,
                          const DiagnosisOptions& options = {});

nlohmann::ordered_json to_json(const SetDiagnosis& diagnosis);
std::string text_report(const SetDiagnosis& diagnosis);

// The index of a plane in squareness_urad (XY 0, YZ 1, ZX 2).
std::size_t plane_index(Plane plane) noexcept;

}  // namespace circtest
