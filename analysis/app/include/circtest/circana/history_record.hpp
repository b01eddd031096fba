#pragma once
// The history's record of a test (circtest::history) made from the analysis' own types: an
// evaluation (a stored document is read back through evaluation_from_json first, so every
// key is checked once, by the schema's own reader) and, when there is one, its diagnosis.
#include <string>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/remedy.hpp"
#include "circtest/history/history.hpp"

namespace circtest {

// H per pair, G (the evaluation's headline method), F_max and F_min per run, the trend's
// largest H, G and |F|; from the diagnosis the larger backlash of the plane's two axes and
// the squareness. The machine is `machine` when given, else the evaluation's `machine`
// condition; DataError when there is none (its text names the remedy in `words`). tested_at is
// the trace's start_time, else its date, in the canonical UTC form of canonical_utc_iso8601;
// empty when the trace has neither (the store then takes the time of storing). A date that
// is no date, or a number that is not finite or beyond kMaxReportedMagnitude, is a DataError
// naming `source` (the file the evaluation was read from; empty: the evaluation's source) and
// the key: such a record is never stored.
// The measures of the evaluation (H per pair, G, F_max, F_min per run) added to R, with the
// trend's largest H, G and |F| and their expanded uncertainties U (k = 2) from the
// evaluation's budget (uncertainty_budget with its own options): what history_record and the
// report's verdict judge.
void add_measures(const Evaluation& evaluation, history::TestRecord& r);

history::TestRecord history_record(const Evaluation& evaluation,
                                   const Diagnosis* diagnosis = nullptr,
                                   const std::string& machine = {},
                                   RemedyWords words = library_remedy_words,
                                   const std::string& source = {});

}  // namespace circtest
