#include "circtest/analysis/plot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iterator>
#include <numbers>

#include "circtest/analysis/report.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/svg.hpp"

namespace circtest {

namespace {

// The smallest of 1, 2, 5 x 10^k at or above x.
double nice_at_least(double x) {
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * p >= x * (1 - 1e-12)) return m * p;
  }
  return 10.0 * p;
}

struct Polar {
  double theta;
  double dev_mm;
};

struct Layer {
  const Evaluation* ev;
  std::string label;
  Circle ref;
  std::vector<std::vector<Polar>> paths;  // one per run
};

// Deviations of each run from the reference circle, decimated.
Layer polar_paths(const PlotLayer& in, const PlotOptions& options, double& dmax) {
  const Evaluation& ev = *in.evaluation;
  const Trace& trace = *in.trace;
  const auto& col_a = trace.values[ev.columns.a];
  const auto& col_b = trace.values[ev.columns.b];
  Layer layer{&ev, in.label, {}, {}};
  // One centre and reference circle for all runs, so that both directions compare as in H.
  layer.ref = ev.hysteresis.empty() ? ev.runs.front().lsc : ev.hysteresis.front().common_lsc;
  const Circle& ref = layer.ref;
  for (const RunResult& r : ev.runs) {
    std::vector<Polar> path;
    const std::size_t n = r.run.size();
    // Keep each bucket's lowest and highest point: decimation must not hide the spikes.
    const std::size_t bucket =
        std::max<std::size_t>(1, (n + options.max_points_per_run / 2 - 1) /
                                     std::max<std::size_t>(1, options.max_points_per_run / 2));
    for (std::size_t s = 0; s < n; s += bucket) {
      const std::size_t e = std::min(n, s + bucket);
      std::size_t lo = s, hi = s;
      double rlo = 1e300, rhi = -1e300;
      for (std::size_t k = s; k < e; ++k) {
        const std::size_t i = r.run.begin + k;
        const double rad = std::hypot(col_a[i] - ref.centre_a_mm, col_b[i] - ref.centre_b_mm);
        if (rad < rlo) rlo = rad, lo = i;
        if (rad > rhi) rhi = rad, hi = i;
      }
      // The run's first sample stays first: it is the start point drawn on the plot.
      std::vector<std::size_t> keep;
      if (s == 0 && std::min(lo, hi) != r.run.begin) keep.push_back(r.run.begin);
      keep.push_back(std::min(lo, hi));
      keep.push_back(std::max(lo, hi));
      for (std::size_t i : keep) {
        const double da = col_a[i] - ref.centre_a_mm, db = col_b[i] - ref.centre_b_mm;
        const double dev = std::hypot(da, db) - ref.radius_mm;
        path.push_back({std::atan2(db, da), dev});
        dmax = std::max(dmax, std::abs(dev));
      }
    }
    layer.paths.push_back(std::move(path));
  }
  return layer;
}

// The diagnosis panel: one line per identified source, then the contributions to the modelled
// G as bars scaled to the largest, then the residual. Returns its height.
double diagnosis_panel(std::string& s, const Diagnosis& d, double x0, double y0, double width) {
  auto out = std::back_inserter(s);
  std::vector<std::string> lines;
  for (std::size_t k = 0; k < 2; ++k) {
    const char a = d.axes[k];
    if (d.backlash_mm[k].value) {
      std::string l = fmt::format("{} backlash {:.1f} um", a, *d.backlash_mm[k].value * 1e3);
      if (const auto& e = d.backlash_reversals_mm[k]) {
        l += fmt::format(" (+ end {:.1f}, - end {:.1f})", (*e)[0] * 1e3, (*e)[1] * 1e3);
      }
      lines.push_back(l);
    }
    if (d.spike_mm[k].value && d.spike_ms[k].value) {
      lines.push_back(fmt::format("{} reversal spike {:.1f} um, decay {:.1f} ms", a,
                                  *d.spike_mm[k].value * 1e3, *d.spike_ms[k].value));
    }
    if (const auto& c = d.cyclic[k]) {
      lines.push_back(fmt::format("{} cyclic {:.2f} um at pitch {:.3f} mm", a,
                                  c->amplitude_mm * 1e3, c->pitch_mm));
    }
  }
  if (d.squareness_urad.value) {
    const double v = *d.squareness_urad.value;
    lines.push_back(fmt::format("squareness {:+.1f} urad (+{}/+{} at 90 deg {} {:.1f} urad)", v,
                                d.axes[0], d.axes[1], v >= 0 ? "-" : "+", std::abs(v)));
  }
  if (d.servo_mismatch_ms.value) {
    const double m = *d.servo_mismatch_ms.value;
    lines.push_back(fmt::format("servo mismatch: {} lags {} by {:.3f} ms",
                                m >= 0 ? d.axes[0] : d.axes[1], m >= 0 ? d.axes[1] : d.axes[0],
                                std::abs(m)));
  }
  if (d.scale_mismatch_ppm.value) {
    lines.push_back(fmt::format("scale mismatch s_{} - s_{} {:+.1f} ppm", d.axes[0], d.axes[1],
                                *d.scale_mismatch_ppm.value));
  }
  double y = y0;
  fmt::format_to(out,
                 "<g class=\"diagnosis\">\n<text x=\"{:.0f}\" y=\"{:.0f}\" font-size=\"14\" "
                 "font-weight=\"bold\">Diagnosis (circana diagnose)</text>\n",
                 x0, y);
  y += 20;
  for (const std::string& l : lines) {
    fmt::format_to(out, "<text class=\"source\" x=\"{:.0f}\" y=\"{:.0f}\">{}</text>\n", x0, y,
                   xml_escape(l));
    y += 17;
  }
  y += 8;
  fmt::format_to(
      out, "<text x=\"{:.0f}\" y=\"{:.0f}\" font-weight=\"bold\">{}</text>\n", x0, y,
      xml_escape(fmt::format("Contributions to the modelled G ({:.1f} um)", d.model_g_mm * 1e3)));
  y += 8;
  double gmax = 0.0;
  for (const auto& c : d.contributions) gmax = std::max(gmax, c.g_mm);
  const double bar_w = width - 10.0;
  for (const auto& c : d.contributions) {
    const double w = gmax > 0 ? bar_w * c.g_mm / gmax : 0.0;
    fmt::format_to(
        out,
        "<rect class=\"contribution\" x=\"{:.0f}\" y=\"{:.0f}\" width=\"{:.1f}\" "
        "height=\"14\" fill=\"#9ab8e0\"/>\n<text x=\"{:.0f}\" y=\"{:.0f}\">{}</text>\n",
        x0, y + 4, w, x0 + 3, y + 15,
        xml_escape(fmt::format("{}: G {:.2f} um, {:.0f} %", c.source, c.g_mm * 1e3, c.percent)));
    y += 20;
  }
  y += 10;
  fmt::format_to(out, "<text x=\"{:.0f}\" y=\"{:.0f}\">{}</text>\n</g>\n", x0, y,
                 xml_escape(fmt::format("residual (measured - model): RMS {:.2f} um, G {:.2f} um",
                                        d.residual_rms_mm * 1e3, d.residual_g_mm * 1e3)));
  return y - y0 + 10;
}

// The run colours, in the order of the runs over all layers.
constexpr const char* kColours[] = {"#1f5fbf", "#c0392b", "#27ae60", "#8e44ad",
                                    "#d35400", "#16a085", "#7f8c8d", "#2c3e50"};
constexpr std::size_t kNColours = std::size(kColours);

using Legend = std::vector<std::pair<std::string, std::string>>;  // text, colour

// The polar frame: the reference circle's ring and the deviation band around it, in px.
struct Frame {
  double size = 0.0;
  double c = 0.0;        // the centre (x and y)
  double ring_px = 0.0;  // the reference circle
  double band_px = 0.0;  // +-4 divisions of deviation
  double div_mm = 0.0;   // one division
  double px_per_mm = 0.0;
  double magnification = 0.0;
};

Frame plot_frame(const std::vector<Layer>& layers, const PlotOptions& options, double dmax) {
  Frame f;
  f.size = options.size_px;
  f.c = f.size / 2.0;
  f.ring_px = 0.30 * f.size;
  f.band_px = 0.15 * f.size;
  f.div_mm = options.mm_per_division ? *options.mm_per_division : nice_at_least(dmax / 4.0);
  f.px_per_mm = f.band_px / (4.0 * f.div_mm);
  f.magnification = f.px_per_mm / (f.ring_px / layers.front().ref.radius_mm);
  return f;
}

// The legend's lines: the reference circle and scale, then per layer the channels, each H and
// each run in its colour.
Legend build_legend(const std::vector<Layer>& layers, const Frame& f, const PlotOptions& options) {
  Legend legend;
  legend.emplace_back(fmt::format("Deviations from the least-squares circle of the runs "
                                  "(radius {:.4f} mm)",
                                  layers.front().ref.radius_mm),
                      "black");
  legend.emplace_back(fmt::format("magnified x{:.0f}: 1 division = {:g} um{}", f.magnification,
                                  f.div_mm * 1000.0, options.mm_per_division ? " (fixed)" : ""),
                      "black");
  std::size_t colour = 0;
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const Evaluation& ev = *layers[l].ev;
    const std::string prefix = layers[l].label.empty() ? "" : layers[l].label + ": ";
    legend.emplace_back(fmt::format("{}channels evaluated {}{}", prefix, channels_text(ev),
                                    l > 0 ? " (dashed)" : ""),
                        "black");
    // Each H, G and F with its expanded uncertainty, as circana analyze states them.
    const UncertaintyBudget budget = uncertainty_budget(ev, ev.uncertainty_options);
    for (const auto& h : ev.hysteresis) {
      legend.emplace_back(
          fmt::format("{}H_{} = {:.1f} um at {} (runs {}/{}), U = {:.1f} um (k = 2)", prefix,
                      ev.runs[h.run_ccw].label, h.h_mm * 1000.0,
                      feed_text(ev.runs[h.run_ccw].feed_mm_per_min), h.run_ccw + 1, h.run_cw + 1,
                      budget.u_h_mm * 1000.0),
          "black");
    }
    for (std::size_t p = 0; p < ev.runs.size(); ++p, ++colour) {
      const RunResult& r = ev.runs[p];
      std::string fm =
          r.f_max_mm
              ? fmt::format("F_max = {:+.1f} um, F_min = {:+.1f} um, U = {:.1f} um",
                            *r.f_max_mm * 1000.0, *r.f_min_mm * 1000.0, budget.u_f_mm * 1000.0)
              : std::string("F: n/a");
      legend.emplace_back(
          fmt::format("{}run {} {} ({}) at {}: G = {:.1f} um, U = {:.1f} um ({}), {} (k = 2)",
                      prefix, p + 1, direction_name(r.run.direction), r.label,
                      feed_text(r.feed_mm_per_min), r.g_mm(ev.g_method) * 1000.0,
                      budget.u_g_mm * 1000.0, g_method_name(ev.g_method), fm),
          kColours[colour % kNColours]);
    }
  }
  return legend;
}

// The grid: the reference circle and rings every division, spokes every 45 deg, the axes named.
void draw_grid(std::string& s, const Frame& f, Plane plane) {
  auto out = std::back_inserter(s);
  const double c = f.c;
  for (int j = -4; j <= 4; ++j) {
    fmt::format_to(out,
                   "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.2f}\" fill=\"none\" stroke=\"{}\" "
                   "stroke-width=\"{}\"/>\n",
                   c, c, f.ring_px + j * f.div_mm * f.px_per_mm, j == 0 ? "#555" : "#ddd",
                   j == 0 ? 1.2 : 0.8);
  }
  for (int k = 0; k < 8; ++k) {
    const double t = k * std::numbers::pi / 4;
    const double r0 = f.ring_px - f.band_px, r1 = f.ring_px + f.band_px;
    fmt::format_to(out,
                   "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"#ddd\" "
                   "stroke-width=\"0.8\"/>\n",
                   c + r0 * std::cos(t), c - r0 * std::sin(t), c + r1 * std::cos(t),
                   c - r1 * std::sin(t));
  }
  const PlaneAxes axes = plane_axes(plane);
  fmt::format_to(out, "<text x=\"{:.1f}\" y=\"{:.1f}\">+{}</text>\n", c + f.ring_px + f.band_px + 6,
                 c + 4, static_cast<char>(std::toupper(axes.first)));
  fmt::format_to(out, "<text x=\"{:.1f}\" y=\"{:.1f}\">+{}</text>\n", c - 6,
                 c - f.ring_px - f.band_px - 8, static_cast<char>(std::toupper(axes.second)));
}

// A run's start point (a dot on the path) and its direction of motion (an arrow outside the
// band, along the path from the start); COLOUR_INDEX staggers the arrows of the runs.
void draw_start_and_direction(std::string& s, const Frame& f, const Polar& s0, Direction direction,
                              const char* col, std::size_t colour_index) {
  auto out = std::back_inserter(s);
  const double c = f.c;
  const double r0 = std::max(0.0, f.ring_px + s0.dev_mm * f.px_per_mm);
  fmt::format_to(out, "<circle class=\"start\" cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"4\" fill=\"{}\"/>\n",
                 c + r0 * std::cos(s0.theta), c - r0 * std::sin(s0.theta), col);
  const double sign = direction == Direction::CCW ? 1.0 : -1.0;
  const double ra = f.ring_px + f.band_px + 12.0 + 10.0 * static_cast<double>(colour_index % 4);
  const double t0 = s0.theta, t1 = s0.theta + sign * 0.25;
  std::string arc;
  for (int k = 0; k <= 8; ++k) {
    const double t = t0 + (t1 - t0) * k / 8.0;
    svg_add_point(arc, c + ra * std::cos(t), c - ra * std::sin(t));
  }
  // Arrow head at t1, pointing along the tangent of the motion.
  const double hx = c + ra * std::cos(t1), hy = c - ra * std::sin(t1);
  const double tx = -std::sin(t1) * sign, ty = -std::cos(t1) * sign;  // screen tangent
  const double nx = -ty, ny = tx;
  fmt::format_to(out,
                 "<polyline points=\"{}\" class=\"direction\" fill=\"none\" stroke=\"{}\" "
                 "stroke-width=\"1.5\"/>\n<polygon points=\"{:.1f},{:.1f} {:.1f},{:.1f} "
                 "{:.1f},{:.1f}\" fill=\"{}\"/>\n",
                 arc, col, hx + 8 * tx, hy + 8 * ty, hx + 4 * nx, hy + 4 * ny, hx - 4 * nx,
                 hy - 4 * ny, col);
}

// Every run of every layer as a path in its colour (later layers dashed), with its start and
// direction marked.
void draw_runs(std::string& s, const Frame& f, const std::vector<Layer>& layers) {
  auto out = std::back_inserter(s);
  const double c = f.c;
  std::size_t colour = 0;
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const Evaluation& ev = *layers[l].ev;
    for (std::size_t p = 0; p < layers[l].paths.size(); ++p, ++colour) {
      const auto& path = layers[l].paths[p];
      const char* col = kColours[colour % kNColours];
      std::string pts;
      for (const Polar& q : path) {
        // A fixed scale can put a large deviation past the centre: clamp, never fold over.
        const double rr = std::max(0.0, f.ring_px + q.dev_mm * f.px_per_mm);
        svg_add_point(pts, c + rr * std::cos(q.theta), c - rr * std::sin(q.theta));
      }
      fmt::format_to(out,
                     "<polyline points=\"{}\" class=\"run\" fill=\"none\" stroke=\"{}\" "
                     "stroke-width=\"1.2\"{}/>\n",
                     pts, col, l > 0 ? " stroke-dasharray=\"5,3\"" : "");
      if (path.empty()) continue;
      draw_start_and_direction(s, f, path.front(), ev.runs[p].run.direction, col, colour);
    }
  }
}

}  // namespace

std::string svg_plot(const Evaluation& ev, const Trace& trace, const PlotOptions& options) {
  return svg_plot(std::vector<PlotLayer>{{&ev, &trace, ""}}, options);
}

std::string svg_plot(const std::vector<PlotLayer>& inputs, const PlotOptions& options) {
  double dmax = 1e-4;  // mm: a perfect path still gets a readable 0.1 um grid
  std::vector<Layer> layers;
  for (const PlotLayer& in : inputs) layers.push_back(polar_paths(in, options, dmax));
  const Evaluation& first = *layers.front().ev;
  const Frame f = plot_frame(layers, options, dmax);

  // The legend, first: the height of the document follows from its length.
  Legend legend = build_legend(layers, f, options);
  std::string s;
  auto out = std::back_inserter(s);
  if (options.legend_out) {
    *options.legend_out = std::move(legend);
    legend.clear();
  }
  const double size = f.size;
  double height = size + (legend.empty() ? 0.0 : 20.0 + 18.0 * static_cast<double>(legend.size()));
  // The diagnosis panel beside the plot: drawn first into its own string, as its height can
  // set the document's.
  constexpr double kPanelWidth = 380.0;
  std::string panel;
  if (options.diagnosis) {
    const double h = diagnosis_panel(panel, *options.diagnosis, size + 10.0, 18.0, kPanelWidth);
    height = std::max(height, h + 28.0);
  }
  const double width = options.diagnosis ? size + 20.0 + kPanelWidth : size;
  s += svg_open(width, height, 12, true);
  s += panel;
  fmt::format_to(out,
                 "<text x=\"10\" y=\"18\" font-size=\"14\" font-weight=\"bold\">ISO 230-4 "
                 "circular test, plane {}</text>\n",
                 plane_name(first.plane));
  if (!options.legend_out) {
    fmt::format_to(out, "<text x=\"10\" y=\"34\">{}</text>\n", xml_escape(first.source));
  }
  draw_grid(s, f, first.plane);
  draw_runs(s, f, layers);

  double y = size + 10;
  for (const auto& [text, col] : legend) {
    fmt::format_to(out, "<text class=\"legend\" x=\"10\" y=\"{:.0f}\" fill=\"{}\">{}</text>\n", y,
                   col, xml_escape(text));
    y += 18;
  }
  s += "</svg>\n";
  return s;
}

}  // namespace circtest
