#pragma once
// Diagnosis: which machine errors (ISO 230-4 Annex B) make up H, G and F. A least-squares
// fit of a first-order error model to the radial deviation of all runs of a trace together.
// The Diagnosis it gives and its JSON (to_json, the readers) are the diagnosis document,
// core/diagnosis_document.hpp.
// Model and sign conventions: docs/diagnosis.md (the same as configs/sim-mill [SIM] and the
// test simulator tests/support/machine_sim).
#include <array>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/diagnosis_document.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

struct DiagnosisOptions {
  EvaluationOptions evaluation;
  // Cyclic-error pitch per axis (lowercase letter -> mm), e.g. the screw lead; axes without
  // one are searched by a periodogram of the residual over axis position.
  std::map<char, double> pitch_mm;
  // A periodogram peak is reported only when its power is this many times the median power.
  double cyclic_detection_factor = 25.0;
  // ... and only when its amplitude is at least this and five standard errors.
  double min_cyclic_amplitude_mm = 0.1e-3;
  // A reversal spike is kept only when its height exceeds this many standard errors.
  double spike_detection_t = 5.0;
  double min_spike_mm = 0.1e-3;  // ... and only when it is at least this high
  // The normal equations are summed over at most this many samples (evenly strided); the
  // residual is evaluated on all of them.
  std::size_t max_fit_samples = 250000;
  // A parameter whose column is this well explained by the others (variance inflation
  // factor) is not identifiable from the trace and is reported as null.
  double max_variance_inflation = 1000.0;
  // False for an instrument without an absolute length along the axes (a ball bar): only the
  // scale mismatch is reported. True also needs the trace's `instrument` metadata not to name
  // a ball bar.
  bool absolute_channels = true;
};

// Evaluates the trace (segmentation, nominal circle) and fits the model.
Diagnosis diagnose(const Trace& trace, const DiagnosisOptions& options = {});
// The same on an evaluation already made from this trace.
Diagnosis diagnose(const Trace& trace, const Evaluation& evaluation,
                   const DiagnosisOptions& options = {});

std::string text_report(const Diagnosis& diagnosis);
// A few lines for the end of the analyze report.
std::string short_text_report(const Diagnosis& diagnosis);

}  // namespace circtest
