#include "budget_inputs.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "circtest/core/error.hpp"
#include "circtest/core/trace_keys.hpp"
#include "median.hpp"

namespace circtest::detail {

namespace {

// A straight line T = T0 + slope (t - t0), fitted by least squares.
struct Line {
  double t0 = 0.0, value0 = 0.0, slope = 0.0;
  double at(double t) const { return value0 + slope * (t - t0); }
};

Line fit_line(const std::vector<double>& t, const std::vector<double>& v, std::size_t begin,
              std::size_t end) {
  const double n = static_cast<double>(end - begin);
  double mt = 0.0, mv = 0.0;
  for (std::size_t i = begin; i < end; ++i) mt += t[i], mv += v[i];
  mt /= n;
  mv /= n;
  double sxx = 0.0, sxy = 0.0;
  for (std::size_t i = begin; i < end; ++i) {
    sxx += (t[i] - mt) * (t[i] - mt);
    sxy += (t[i] - mt) * (v[i] - mv);
  }
  return {mt, mv, sxx > 0.0 ? sxy / sxx : 0.0};
}

// The time of each row: the time column, else the row number (samples evenly spaced).
std::vector<double> row_times(const Trace& trace) {
  if (const std::vector<double>* t = trace.column(column_name::t)) return *t;
  std::vector<double> rows(trace.rows());
  for (std::size_t i = 0; i < rows.size(); ++i) rows[i] = static_cast<double>(i);
  return rows;
}

// The series' straight line over rows [begin, end): fitted to a column, or the line from the
// first to the last value over the whole recording.
Line series_line(const TemperatureSeries& s, const std::vector<double>& t, std::size_t begin,
                 std::size_t end) {
  if (s.column) return fit_line(t, *s.column, begin, end);
  const double span = t.back() - t.front();
  return {t.front(), s.first_C, span > 0.0 ? (s.last_C - s.first_C) / span : 0.0};
}

// The change of the series over rows [begin, end), K.
double change_over(const TemperatureSeries& s, const std::vector<double>& t, std::size_t begin,
                   std::size_t end) {
  if (end <= begin + 1) return 0.0;
  return std::abs(series_line(s, t, begin, end).slope * (t[end - 1] - t[begin]));
}

// The expected largest of m independent standard normal values (Blom's approximation,
// Phi^-1((m - 0.375) / (m + 0.25))); 0 for one value.
double expected_largest(std::size_t m) {
  if (m <= 1) return 0.0;
  const double p = (static_cast<double>(m) - 0.375) / (static_cast<double>(m) + 0.25);
  double lo = 0.0, hi = 10.0;
  for (int i = 0; i < 80; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

struct RunNoise {
  double sigma_mm = 0.0;
  std::size_t top = 0, bottom = 0;  // samples near the largest and the smallest radius
};

// The noise of one run: the standard deviation of the radius from sample to sample (second
// differences, by their median: a reversal's spike or a step does not count), and how many
// samples lie within one standard deviation of the extremes of the radius smoothed over 11
// samples (those compete for the zone's edges).
RunNoise run_noise(const Trace& trace, const Evaluation& ev, const RunResult& rr) {
  const auto& a = trace.values[ev.columns.a];
  const auto& b = trace.values[ev.columns.b];
  const std::size_t n = rr.run.size();
  RunNoise out;
  if (n < 16) return out;
  std::vector<double> r(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t row = rr.run.begin + i;
    r[i] = std::hypot(a[row] - rr.lsc.centre_a_mm, b[row] - rr.lsc.centre_b_mm);
  }
  std::vector<double> d2(n - 2);
  for (std::size_t i = 1; i + 1 < n; ++i) d2[i - 1] = std::abs(r[i - 1] - 2.0 * r[i] + r[i + 1]);
  // Second differences of white noise have the standard deviation sqrt(6) sigma; the median
  // of their magnitude is 0.6745 of it.
  out.sigma_mm = median_in_place(d2) / 0.6745 / std::sqrt(6.0);
  // The radius less its first value, summed: each window's mean from two sums.
  constexpr std::size_t w = 11;
  std::vector<double> prefix(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) prefix[i + 1] = prefix[i] + (r[i] - r[0]);
  std::vector<double> smooth(n);
  for (std::size_t i = 0; i < n; ++i) {
    // A window of w samples about i, held inside the run at its ends.
    const std::size_t lo = std::min(i > w / 2 ? i - w / 2 : 0, n - w);
    smooth[i] = (prefix[lo + w] - prefix[lo]) / static_cast<double>(w);
  }
  const auto [lo_it, hi_it] = std::minmax_element(smooth.begin(), smooth.end());
  const double lo = *lo_it, hi = *hi_it;
  for (double s : smooth) {
    out.top += s >= hi - out.sigma_mm ? 1 : 0;
    out.bottom += s <= lo + out.sigma_mm ? 1 : 0;
  }
  return out;
}

void measure_drift(const Trace& trace, const Evaluation& ev, const std::vector<double>& t,
                   BudgetMeasurements& m) {
  const auto machine = temperature_series(trace, meta_key::temperature_machine_C);
  const auto instrument = temperature_series(trace, meta_key::temperature_instrument_C);
  if (!machine && !instrument) return;
  m.drift_source = (machine ? machine : instrument)->source;
  const std::size_t first = ev.runs.front().run.begin, last = ev.runs.back().run.end;
  auto one = [&](const std::optional<TemperatureSeries>& s, const std::optional<double>& used,
                 double& run_K, double& pair_K, double& from_K) {
    if (!s) return;
    for (const RunResult& r : ev.runs) {
      run_K = std::max(run_K, change_over(*s, t, r.run.begin, r.run.end));
    }
    for (const HysteresisResult& h : ev.hysteresis) {
      const std::size_t begin = std::min(ev.runs[h.run_ccw].run.begin, ev.runs[h.run_cw].run.begin);
      const std::size_t end = std::max(ev.runs[h.run_ccw].run.end, ev.runs[h.run_cw].run.end);
      pair_K = std::max(pair_K, change_over(*s, t, begin, end));
    }
    const Line line = series_line(*s, t, first, last);
    const double at = used.value_or(s->mean_C);
    from_K = std::max(std::abs(line.at(t[first]) - at), std::abs(line.at(t[last - 1]) - at));
  };
  one(machine, ev.temperatures.machine_C, m.machine_run_K, m.machine_pair_K,
      m.machine_from_corrected_K);
  one(instrument, ev.temperatures.instrument_C, m.instrument_run_K, m.instrument_pair_K,
      m.instrument_from_corrected_K);
}

}  // namespace

std::optional<TemperatureSeries> temperature_series(const Trace& trace, const char* key) {
  TemperatureSeries s;
  if (const std::vector<double>* column = trace.column(key); column && !column->empty()) {
    double sum = 0.0;
    for (std::size_t i = 0; i < column->size(); ++i) {
      const double v = (*column)[i];
      if (!(v >= -273.15 && v <= 1000.0)) {
        throw ParseError(trace.source, trace.line_of_row[i],
                         fmt::format("column '{}': expected a temperature in deg C from -273.15 "
                                     "to 1000, got {:g}",
                                     key, v));
      }
      sum += v;
    }
    s.source = "columns";
    s.column = column;
    s.mean_C = sum / static_cast<double>(column->size());
    return s;
  }
  std::vector<double> values;
  const auto& entries = trace.metadata.entries();
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (entries[i].first != key) continue;
    // check_metadata has checked every value the reader read; one set since is read alike.
    try {
      values.push_back(std::stod(entries[i].second));
    } catch (const std::exception&) {
      throw ParseError(
          trace.source, trace.metadata.line_at(i),
          fmt::format("metadata '{}': expected a number, got '{}'", key, entries[i].second));
    }
  }
  if (values.size() < 2 || values.front() == values.back() || trace.rows() < 2) return std::nullopt;
  s.source = "start and end";
  s.first_C = values.front();
  s.last_C = values.back();
  s.mean_C = 0.5 * (s.first_C + s.last_C);
  return s;
}

BudgetMeasurements measure_budget_inputs(const Trace& trace, const Evaluation& ev) {
  BudgetMeasurements m;
  if (ev.runs.empty()) return m;
  const std::vector<double> t = row_times(trace);
  measure_drift(trace, ev, t, m);
  if (trace.column(column_name::t)) {
    double run_s = 0.0, pair_s = 0.0;
    for (const RunResult& r : ev.runs) run_s = std::max(run_s, t[r.run.end - 1] - t[r.run.begin]);
    for (const HysteresisResult& h : ev.hysteresis) {
      const std::size_t begin = std::min(ev.runs[h.run_ccw].run.begin, ev.runs[h.run_cw].run.begin);
      const std::size_t end = std::max(ev.runs[h.run_ccw].run.end, ev.runs[h.run_cw].run.end);
      pair_s = std::max(pair_s, t[end - 1] - t[begin]);
    }
    m.run_s = run_s;
    m.pair_s = pair_s;
    m.test_s = t[ev.runs.back().run.end - 1] - t[ev.runs.front().run.begin];
  }
  for (const RunResult& r : ev.runs) {
    const RunNoise noise = run_noise(trace, ev, r);
    const double top = expected_largest(noise.top), bottom = expected_largest(noise.bottom);
    m.noise_mm = std::max(m.noise_mm, noise.sigma_mm);
    const double g = noise.sigma_mm * (top + bottom);
    if (g >= m.noise_g_mm) {
      m.noise_g_mm = g;
      m.noise_samples_top = noise.top;
      m.noise_samples_bottom = noise.bottom;
    }
    m.noise_f_mm = std::max(m.noise_f_mm, noise.sigma_mm * std::max(top, bottom));
    // H: the difference of two runs' readings, sqrt(2) sigma, at its largest.
    m.noise_h_mm = std::max(m.noise_h_mm, std::sqrt(2.0) * noise.sigma_mm * std::max(top, bottom));
  }
  return m;
}

}  // namespace circtest::detail
