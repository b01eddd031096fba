#pragma once
// The circana commands as library calls: main.cpp only parses options.
#include <ostream>
#include <string>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/plot.hpp"

namespace circtest {

struct AnalyzeRequest {
  std::string trace_path;
  EvaluationOptions options;
  bool json = false;
  std::string svg_path;  // also write the clause 6 plot there (atomically), when set
  PlotOptions plot;
  // Evaluate the radial channel `r` even when the plane's position columns exist (a trace
  // without them is evaluated from `r` anyway).
  bool radial = false;
};
// Reads, evaluates and prints the report (text or JSON) to `out` in one write, so that
// nothing reaches stdout when an error is thrown. Returns the exit code.
int run_analyze(const AnalyzeRequest& request, std::ostream& out);

struct DiagnoseRequest {
  std::string trace_path;
  DiagnosisOptions options;
  bool json = false;
  bool radial = false;  // a ball bar's trace (found by itself when it has the r column)
};
// Reads, evaluates and diagnoses (docs/diagnosis.md); prints text or JSON in one write.
int run_diagnose(const DiagnoseRequest& request, std::ostream& out);

struct FitRequest {
  std::string points_path;
  std::string column_a = "x";
  std::string column_b = "y";
  bool json = false;
};
int run_fit(const FitRequest& request, std::ostream& out);

// circana import-polar: a plain two-column polar export (angle deg, radial deviation um)
// written as a radial trace (docs/trace-format.md "Radial traces").
struct ImportPolarRequest {
  std::string input_path;
  std::string output_path;
  double radius_mm = 0.0;  // the nominal radius the deviations are taken from
  Plane plane = Plane::XY;
};
int run_import_polar(const ImportPolarRequest& request, std::ostream& out);

}  // namespace circtest
