#pragma once
// Internal: what the uncertainty budget measures in a trace beyond H, G and F (evaluate()
// calls these): the temperatures recorded over the test, and the readings' noise.
#include <optional>
#include <string>
#include <vector>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/trace.hpp"

namespace circtest::detail {

// A temperature recorded over the test: a column of that name (a value per sample), or the
// metadata key given twice with different values (at the start and at the end of the
// recording: taken as changing linearly in time).
struct TemperatureSeries {
  std::string source;                           // "columns" or "start and end"
  const std::vector<double>* column = nullptr;  // the column, for "columns"
  double first_C = 0.0, last_C = 0.0;           // "start and end": the key's first and last
  double mean_C = 0.0;                          // over the recording: F is corrected at it
};
// None when the trace records the temperature once or not at all. A column value outside
// -273.15 to 1000 deg C is a ParseError naming its line.
std::optional<TemperatureSeries> temperature_series(const Trace& trace, const char* key);

// The drift of the recorded temperatures, the durations and the noise of the evaluation's
// runs (docs/uncertainty.md).
BudgetMeasurements measure_budget_inputs(const Trace& trace, const Evaluation& ev);

}  // namespace circtest::detail
