#pragma once
// A `circtest.diagnosis/1` document (circana diagnose --json) as the planner reads it, through
// the one reader of the document (core/diagnosis_document.hpp, docs/diagnosis-json.md). A
// null is a value the diagnosis could not fit, or a term it lists as unseparable.
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

// One plane's diagnosis as the planner takes it: core's Diagnosis itself, and what the planner
// adds to it.
struct DiagnosisInput {
  std::string source;  // the JSON file, for messages
  // A test set's plane carries the set's joint per-axis values (backlash, spike, scale) and
  // squareness; the per-axis values of an axis corrected from an earlier plane are cleared.
  Diagnosis diagnosis;
  // A test set's plane: its axis k is corrected from an earlier plane of the set.
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
