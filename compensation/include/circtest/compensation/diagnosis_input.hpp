#pragma once
// The part of a `circtest.diagnosis/1` document (circana diagnose --json) that the planner
// reads, taken from the one reader of the document (core/diagnosis_document.hpp,
// docs/diagnosis-json.md). Keys are the plane's axis letters; a null is a value the diagnosis
// could not fit, or a term it lists as unseparable.
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "circtest/core/diagnosis_document.hpp"

namespace circtest::compensation {

// A value and its standard error, and a cyclic error, as the document holds them.
using Measured = Estimate;
using Cyclic = CyclicEstimate;  // error = amplitude * sin(2 pi position / pitch + phase)

struct DiagnosisInput {
  std::string source;  // the JSON file, for messages
  std::string plane;   // "XY", "YZ", "ZX"
  std::array<char, 2> axes{'X', 'Y'};
  std::array<Measured, 2> backlash_mm;        // play: positive = lost motion
  std::array<Measured, 2> reversal_spike_mm;  // friction transient, never compensated as play
  std::array<std::optional<double>, 2> reversal_spike_ms;  // the spike's decay time
  // From the reversal to the spike's peak when the table sticks; none: it peaks at the reversal.
  std::array<std::optional<double>, 2> reversal_spike_peak_ms;
  std::array<std::optional<double>, 2> reversal_spike_se_ms;  // its standard error
  std::array<Measured, 2> scale_ppm;                          // actual = (1 + s) * commanded
  Measured scale_mismatch_ppm;
  Measured squareness_urad;    // a_actual = a + alpha * b
  Measured servo_mismatch_ms;  // lag of the first axis minus lag of the second
  std::optional<double> kv_per_s;
  // Per axis: the following lag (ms) and how it was measured ("feedback", "instrument",
  // "feeds"; empty when not measured).
  std::array<Measured, 2> axis_lag_ms;
  std::array<std::string, 2> axis_lag_source;
  std::array<std::optional<Cyclic>, 2> cyclic;
  std::optional<std::string> ini_sha256;
  // The terms the diagnosis could not tell apart ("backlash_mm.X", "servo_mismatch_ms"): their
  // values above are empty whatever the document holds beside them.
  std::vector<std::string> unseparable;
  // A test set's plane: its axis k is corrected from an earlier plane of the set (its
  // per-axis values here are null).
  std::array<bool, 2> axis_in_earlier_plane{false, false};
};

// Throws IoError (missing, a device, larger than kMaxDiagnosisBytes (core)), ParseError (not JSON,
// nested deeper than 16 levels, a number beyond a double, not schema circtest.diagnosis/1 or
// a newer version of it, a "version" that is not MAJOR.MINOR or of a newer major, a key of
// the wrong type: file and key named), DataError (a cyclic
// pitch outside 0.001..10000 mm).
// A test set's document (its "plane" lists several) is refused by these with ParseError.
DiagnosisInput read_diagnosis(const std::string& path);
DiagnosisInput parse_diagnosis(const std::string& text, const std::string& source);
// The same, and a test set's document as one entry per plane in the set's order: each plane's
// own diagnosis (test_set.diagnoses) with the joint per-axis values, an axis's values only in
// the first plane that has the axis. ParseError also for a set without test_set.diagnoses or
// whose diagnoses' planes are not the document's "plane".
std::vector<DiagnosisInput> read_diagnosis_planes(const std::string& path);
std::vector<DiagnosisInput> parse_diagnosis_planes(const std::string& text,
                                                   const std::string& source);

}  // namespace circtest::compensation
