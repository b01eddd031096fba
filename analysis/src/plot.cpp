#include "circtest/analysis/plot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iterator>
#include <numbers>

#include "circtest/analysis/report.hpp"

namespace circtest {

namespace {

std::string escape(std::string_view s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

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

}  // namespace

std::string svg_plot(const Evaluation& ev, const Trace& trace, const PlotOptions& options) {
  const auto& col_a = trace.values[static_cast<std::size_t>(ev.columns.a)];
  const auto& col_b = trace.values[static_cast<std::size_t>(ev.columns.b)];
  // One centre and reference circle for all runs, so that both directions compare as in H.
  Circle ref = ev.hysteresis.empty() ? ev.runs.front().lsc : ev.hysteresis.front().common_lsc;

  std::vector<std::vector<Polar>> paths;
  double dmax = 1e-4;  // mm: a perfect path still gets a readable 0.1 um grid
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
      for (std::size_t i : {std::min(lo, hi), std::max(lo, hi)}) {
        const double da = col_a[i] - ref.centre_a_mm, db = col_b[i] - ref.centre_b_mm;
        const double dev = std::hypot(da, db) - ref.radius_mm;
        path.push_back({std::atan2(db, da), dev});
        dmax = std::max(dmax, std::abs(dev));
      }
    }
    paths.push_back(std::move(path));
  }

  const double size = options.size_px;
  const double c = size / 2.0;
  const double ring_px = 0.30 * size;  // the reference circle
  const double band_px = 0.15 * size;  // +-4 divisions of deviation
  const double div_mm = nice_at_least(dmax / 4.0);
  const double px_per_mm = band_px / (4.0 * div_mm);
  const double magnification = px_per_mm / (ring_px / ref.radius_mm);

  std::string s;
  auto out = std::back_inserter(s);
  const double height = size + 40.0 + 18.0 * static_cast<double>(ev.runs.size() + 3);
  fmt::format_to(out,
                 "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" "
                 "viewBox=\"0 0 {0} {1}\" font-family=\"sans-serif\" font-size=\"12\">\n"
                 "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
                 size, height);
  fmt::format_to(out,
                 "<text x=\"10\" y=\"18\" font-size=\"14\" font-weight=\"bold\">ISO 230-4 "
                 "circular test, plane {}</text>\n",
                 plane_name(ev.plane));
  fmt::format_to(out, "<text x=\"10\" y=\"34\">{}</text>\n", escape(ev.source));
  // Grid: the reference circle and rings every division, spokes every 45 deg.
  for (int j = -4; j <= 4; ++j) {
    fmt::format_to(out,
                   "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.2f}\" fill=\"none\" stroke=\"{}\" "
                   "stroke-width=\"{}\"/>\n",
                   c, c, ring_px + j * div_mm * px_per_mm, j == 0 ? "#555" : "#ddd",
                   j == 0 ? 1.2 : 0.8);
  }
  for (int k = 0; k < 8; ++k) {
    const double t = k * std::numbers::pi / 4;
    const double r0 = ring_px - band_px, r1 = ring_px + band_px;
    fmt::format_to(out,
                   "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"#ddd\" "
                   "stroke-width=\"0.8\"/>\n",
                   c + r0 * std::cos(t), c - r0 * std::sin(t), c + r1 * std::cos(t),
                   c - r1 * std::sin(t));
  }
  const PlaneAxes axes = plane_axes(ev.plane);
  fmt::format_to(out, "<text x=\"{:.1f}\" y=\"{:.1f}\">+{}</text>\n", c + ring_px + band_px + 6,
                 c + 4, static_cast<char>(std::toupper(axes.first)));
  fmt::format_to(out, "<text x=\"{:.1f}\" y=\"{:.1f}\">+{}</text>\n", c - 6,
                 c - ring_px - band_px - 8, static_cast<char>(std::toupper(axes.second)));

  static constexpr const char* kColours[] = {"#1f5fbf", "#c0392b", "#27ae60", "#8e44ad"};
  for (std::size_t p = 0; p < paths.size(); ++p) {
    std::string pts;
    for (const Polar& q : paths[p]) {
      const double rr = ring_px + q.dev_mm * px_per_mm;
      fmt::format_to(std::back_inserter(pts), "{:.1f},{:.1f} ", c + rr * std::cos(q.theta),
                     c - rr * std::sin(q.theta));
    }
    fmt::format_to(out,
                   "<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.2\"/>\n",
                   pts, kColours[p % 4]);
  }

  double y = size + 10;
  fmt::format_to(out,
                 "<text x=\"10\" y=\"{:.0f}\">Deviations from the least-squares circle of the "
                 "runs (radius {:.4f} mm)</text>\n",
                 y, ref.radius_mm);
  y += 18;
  fmt::format_to(out,
                 "<text x=\"10\" y=\"{:.0f}\">magnified x{:.0f}: 1 division = {:g} um</text>\n", y,
                 magnification, div_mm * 1000.0);
  y += 18;
  if (!ev.hysteresis.empty()) {
    fmt::format_to(out, "<text x=\"10\" y=\"{:.0f}\">H_{} = {:.1f} um</text>\n", y,
                   ev.runs[ev.hysteresis.front().run_ccw].label,
                   ev.hysteresis.front().h_mm * 1000.0);
    y += 18;
  }
  for (std::size_t p = 0; p < ev.runs.size(); ++p) {
    const RunResult& r = ev.runs[p];
    std::string f = r.f_max_mm ? fmt::format("F_max = {:+.1f} um, F_min = {:+.1f} um",
                                             *r.f_max_mm * 1000.0, *r.f_min_mm * 1000.0)
                               : std::string("F: n/a");
    fmt::format_to(out,
                   "<text x=\"10\" y=\"{:.0f}\" fill=\"{}\">run {} {} ({}): G = {:.1f} um ({}), "
                   "{}</text>\n",
                   y, kColours[p % 4], p + 1, direction_name(r.run.direction), r.label,
                   r.g_mm(ev.g_method) * 1000.0, g_method_name(ev.g_method), f);
    y += 18;
  }
  s += "</svg>\n";
  return s;
}

}  // namespace circtest
