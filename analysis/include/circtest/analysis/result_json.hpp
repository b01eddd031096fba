#pragma once
// The evaluation result as JSON: the contract `circana analyze --json` prints and the parts
// built on it (diagnosis, compensation, report, history) read back. Schema
// "circtest.evaluation/1" (docs/result-json.md): keys may be added in /1, never renamed or
// removed.
#include <nlohmann/json.hpp>
#include <string>

#include "circtest/analysis/evaluation.hpp"

namespace circtest {

inline constexpr const char* kEvaluationSchema = "circtest.evaluation/1";

nlohmann::ordered_json to_json(const Evaluation& evaluation);

// The Evaluation a document of this schema describes; to_json of the result re-serialises
// the document identically. Not carried by the JSON, so left at their defaults: the row
// indices of each run (a run's rows are [0, points); its file lines are `lines`), the
// evaluated column indices, the MZC multipliers, the common LSC radius of an H pair and
// the metadata line numbers. Throws ParseError naming `source` (the document's file) when
// the schema is another one or a key is missing or of the wrong type.
Evaluation evaluation_from_json(const nlohmann::ordered_json& document,
                                const std::string& source = "<json>");

// The budget as the document's `uncertainty` object (docs/result-json.md).
nlohmann::ordered_json uncertainty_json(const UncertaintyBudget& budget,
                                        const UncertaintyOptions& options);

const char* g_method_name(GMethod method) noexcept;  // "min-zone", "least-squares"

}  // namespace circtest
