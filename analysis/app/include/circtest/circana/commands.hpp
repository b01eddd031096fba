#pragma once
// The circana commands as library calls: main.cpp only parses options.
#include <cstddef>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/instrument_export.hpp"
#include "circtest/analysis/plot.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest {

// The plausible ranges of circana's numeric options (docs/input-checks.md). A length is
// bounded as the trace metadata bounds radius_mm and centre_mm (100 m), an expansion
// coefficient as expansion_*_per_K, so a value is judged alike from either source.
inline constexpr NumberRange kRadiusRangeMm{0.0, 100'000.0, true,
                                            "a radius in mm above 0 and at most 100000"};
inline constexpr double kMaxOptionLengthMm = kRadiusRangeMm.max;
inline constexpr NumberRange kCentreRangeMm{-100'000.0, 100'000.0, false,
                                            "two numbers A,B in mm, each within +-100000"};
inline constexpr NumberRange kExpansionRangePerK{-1e-3, 1e-3, false,
                                                 "an expansion coefficient per K within +-0.001"};
// The plot's scale sizes its drawing: coordinates grow as 1 / scale.
inline constexpr NumberRange kPlotScaleRangeUm{0.01, 10'000.0, false,
                                               "a plot scale in um per division from 0.01 to "
                                               "10000"};
inline constexpr NumberRange kRadiusToleranceRangeMm{
    0.0, 1000.0, true, "a radius tolerance in mm above 0 and at most 1000"};
// From an encoder's signal period (a few um) to the longest ball screw lead.
inline constexpr NumberRange kPitchRangeMm{0.001, 1000.0, false,
                                           "AXIS=MM items like X=5,Y=5, each pitch from 0.001 to "
                                           "1000 mm"};
inline constexpr NumberRange kFeedRange{0.0, 1e6, true,
                                        "a feed in mm/min above 0 and at most 1000000"};
// A polar export read whole: about 20 bytes a point, so 3 million points.
inline constexpr std::size_t kMaxPolarExportBytes = std::size_t{64} << 20;

// A trace file read and evaluated as circana analyze does (a ball bar's `r` channel turned
// into positions when forced or when it is the only channel); every result finite.
struct EvaluatedTrace {
  Trace trace;  // the trace evaluated (a ball bar's: with the positions made from `r`)
  Evaluation evaluation;
  bool radial = false;  // evaluated from the length channel r
};
// A test set's trace (its `plane` metadata lists several planes) is refused with DataError
// unless options.plane picks one of its planes, which is then evaluated alone.
EvaluatedTrace evaluate_file(const std::string& path, const EvaluationOptions& options,
                             bool radial);
// The same for every plane of a test set in program order (test_set.hpp); one entry for a
// single-plane trace, or for the set's plane options.plane names (DataError when the set has
// no such plane).
std::vector<EvaluatedTrace> evaluate_file_planes(const std::string& path,
                                                 const EvaluationOptions& options, bool radial);

struct AnalyzeRequest {
  std::string trace_path;
  EvaluationOptions options;
  bool json = false;
  std::string svg_path;  // also write the clause 6 plot there (atomically), when set
  PlotOptions plot;
  // With svg_path: an earlier trace of the same test (before a compensation), evaluated with
  // the same options and drawn under this one in the same frame (--compare).
  std::string compare_path;
  // Evaluate the radial channel `r` even when the plane's position columns exist (a trace
  // without them is evaluated from `r` anyway).
  bool radial = false;
  bool store = false;  // also keep the test in the history (--store)
  std::string db_url;  // the history: empty for the default SQLite file
  // --limits H=..,G=..,F=..: each judged with its U by ISO 14253-1 (uncertainty.hpp); the
  // exit code is ExitCode::tolerance unless every one passes. None: no verdict.
  std::optional<ResultLimits> limits;
};
// The H, G and F limits of --limits in the history's syntax (history::parse_limits, defined in
// history_record.cpp); UsageError for backlash and squareness, which need the diagnosis.
ResultLimits result_limits(const std::string& text);
// Reads, evaluates and prints the report (text or JSON) to `out` in one write, so that
// nothing reaches stdout when an error is thrown. Returns the exit code. A test set: each
// plane's report in program order (JSON: {"test_set": [planes], "planes": [evaluations]}),
// its plot to svg_path with the plane before the extension (plot-XY.svg).
int run_analyze(const AnalyzeRequest& request, std::ostream& out);

// circana summary: several runs of one machine side by side (scripts/demo.sh's table).
struct SummaryRun {
  std::string name;            // the column's title ("before", "after")
  std::string result_path;     // circana analyze --json
  std::string diagnosis_path;  // circana diagnose --json of the same run
};
struct SummaryRequest {
  std::vector<SummaryRun> runs;
  std::string json_path;  // also the table as JSON ({"runs", "rows": [{label, unit, values}]})
};
// Reads each run's documents through their readers and prints one row per figure (H, G per
// run, backlash, spike, scale, cyclic, squareness, servo, modelled G), one column per run;
// lengths in um, "-" where a document has no value.
int run_summary(const SummaryRequest& request, std::ostream& out);

struct DiagnoseRequest {
  std::string trace_path;
  DiagnosisOptions options;
  bool json = false;
  bool radial = false;   // a ball bar's trace (found by itself when it has the r column)
  bool store = false;    // also keep the test with its diagnosis in the history (--store)
  std::string db_url;    // the history: empty for the default SQLite file
  std::string svg_path;  // also write the plot with the diagnosis panel there, when set
  PlotOptions plot;
};
// Reads, evaluates and diagnoses (docs/diagnosis.md); prints text or JSON in one write. A
// test set: the planes' diagnoses joined (test_set.hpp), plots per plane as run_analyze.
int run_diagnose(const DiagnoseRequest& request, std::ostream& out);
// circana store: an evaluation document (analyze --json) or a trace (evaluated with
// `options`) into the history. Prints one line naming the stored test.
struct StoreRequest {
  std::string path;
  EvaluationOptions options;  // for a trace; its `conditions` also override a document's
  bool radial = false;        // as AnalyzeRequest::radial
  std::string db_url;
};
int run_store(const StoreRequest& request, std::ostream& out);

// circana history: the tests of a machine, as a table or JSON, the trend as SVG, and with
// limits a pass/fail check of the latest test (ExitCode::tolerance when it fails).
struct HistoryRequest {
  std::string machine;
  std::string since;  // ISO 8601 date or date-time prefix; empty: all
  std::string db_url;
  bool json = false;
  std::string svg_path;
  std::string limits;  // "H=0.015,G=0.020"; empty: no check
};
int run_history(const HistoryRequest& request, std::ostream& out);

// circana report: the self-contained HTML report (html_report.hpp), one page per plane.
struct ReportRequest {
  std::vector<std::string> trace_paths;      // one per plane
  std::vector<std::string> before_paths;     // earlier tests, each matched to its plane's page
  std::vector<std::string> diagnosis_paths;  // circana diagnose --json documents, by plane;
                                             // the others' planes are diagnosed here
  EvaluationOptions options;
  bool radial = false;
  PlotOptions plot;
  std::string db_url;  // the trend from this history; empty: no trend
  std::string output_path;
  std::string limits;       // "H=0.015,G=0.020" as circana history --limits; empty: none
  std::string limits_file;  // the same items in a file, one or more a line, '#' comments
  // circcomp plan --json of each apply between the tests, in order: what was changed
  std::vector<std::string> changes_paths;
  std::string tested_by;    // empty: the trace's operator
  std::string accepted_by;  // empty: a blank line to sign on
};
int run_report(const ReportRequest& request, std::ostream& out);

struct FitRequest {
  std::string points_path;
  std::string column_a = column_name::x;
  std::string column_b = column_name::y;
  bool json = false;
};
int run_fit(const FitRequest& request, std::ostream& out);

// circana import (import-polar): an instrument's export (instrument_export.hpp) written as
// a trace; one line on `out` says what was read.
struct ImportRequest {
  std::string input_path;
  std::string output_path;
  ExportImportOptions options;
};
int run_import(const ImportRequest& request, std::ostream& out);

// circana export-polar: a trace, evaluated as analyze does, as a polar export that circana
// import reads back and that other polar software can plot.
struct ExportPolarRequest {
  std::string trace_path;
  std::string output_path;
  EvaluationOptions options;
  bool radial = false;
};
int run_export_polar(const ExportPolarRequest& request, std::ostream& out);

}  // namespace circtest
