#pragma once
// The plot of the actual paths that clause 6 asks for: radial deviations magnified around
// the nominal circle, both directions about one centre, the magnification stated.
#include <string>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

struct PlotOptions {
  int size_px = 640;
  std::size_t max_points_per_run = 3600;  // decimated for a light file; peaks are kept
};

// An SVG document of the evaluation's runs, drawn from the trace it was made from.
std::string svg_plot(const Evaluation& evaluation, const Trace& trace,
                     const PlotOptions& options = {});

}  // namespace circtest
