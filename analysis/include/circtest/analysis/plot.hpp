#pragma once
// The plot of the actual paths that clause 6 asks for: radial deviations magnified around
// the nominal circle, both directions about one centre, the magnification stated.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

struct PlotOptions {
  int size_px = 640;
  std::size_t max_points_per_run = 3600;  // decimated for a light file; peaks are kept
  // A fixed scale (mm of deviation per grid division) so that two plots compare; automatic
  // (1, 2, 5 x 10^k covering the largest deviation in 4 divisions) when empty.
  std::optional<double> mm_per_division;
  // A diagnosis of the same trace: drawn as a panel beside the polar plot (the identified
  // sources with their values, and the ranked contributions to G as bars). Not owned.
  const Diagnosis* diagnosis = nullptr;
  // When set, the legend's lines (text, colour) go here instead of into the SVG, and the SVG
  // names no trace file: the HTML report writes the legend as text that wraps at print size.
  std::vector<std::pair<std::string, std::string>>* legend_out = nullptr;
};

// An SVG document of the evaluation's runs, drawn from the trace it was made from: each
// run's start point and direction of motion marked, every run and every H (with its feed)
// in the legend, the channels evaluated named.
std::string svg_plot(const Evaluation& evaluation, const Trace& trace,
                     const PlotOptions& options = {});

// Several tests in one frame (before / after): each about its own least-squares circle, at
// one scale; later layers are drawn dashed. Labels prefix each layer's legend lines.
struct PlotLayer {
  const Evaluation* evaluation = nullptr;
  const Trace* trace = nullptr;
  std::string label;
};
std::string svg_plot(const std::vector<PlotLayer>& layers, const PlotOptions& options = {});

}  // namespace circtest
