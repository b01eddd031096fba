#pragma once
// The last gate before a result is printed: every number of the report finite and of a size
// a circular test can have, or a DataError instead of "F = -inf um".
#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/remedy.hpp"

namespace circtest {

// Largest magnitude any reported number may have (mm, deg, mm/min, counts): 1e9. A nominal
// diameter of 1e308 or an expansion coefficient of 1e308 ends up beyond it or non-finite.
inline constexpr double kMaxReportedMagnitude = 1e9;

// Throws DataError naming the trace and the first offending value (its JSON path); `words`
// names the nominal radius setting among the inputs to check.
void require_finite_results(const Evaluation& evaluation, RemedyWords words = library_remedy_words);

}  // namespace circtest
