// Circle-fit throughput on a simulated circular-test trace: R = 75 mm with a form error of
// several harmonics (1-20 um) plus 0.5 um noise, points in path order as a recorder writes
// them. Args: number of points.
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <vector>

#include "circtest/analysis/circle_fit.hpp"

namespace {

struct Trace {
  std::vector<double> a, b;
};

const Trace& trace(std::size_t n) {
  static std::map<std::size_t, Trace> cache;
  auto it = cache.find(n);
  if (it != cache.end()) return it->second;
  Trace t;
  t.a.resize(n);
  t.b.resize(n);
  std::mt19937_64 rng(42);
  std::normal_distribution<double> noise(0.0, 0.0005);
  const double amp[] = {0.020, 0.012, 0.006, 0.003, 0.001};
  const int order[] = {2, 3, 4, 7, 19};
  const double phase[] = {0.3, 1.1, 2.0, 4.2, 5.5};
  const double pi = std::numbers::pi;
  for (std::size_t i = 0; i < n; ++i) {
    const double th = 2 * pi * static_cast<double>(i) / static_cast<double>(n);
    double r = 75.0 + noise(rng);
    for (int k = 0; k < 5; ++k) r += amp[k] * std::cos(order[k] * th + phase[k]);
    t.a[i] = 310.0 + r * std::cos(th);
    t.b[i] = -120.0 + r * std::sin(th);
  }
  return cache.emplace(n, std::move(t)).first->second;
}

void BM_fit_mzc(benchmark::State& state) {
  const Trace& t = trace(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    circtest::MinimumZone z = circtest::fit_mzc(t.a, t.b);
    benchmark::DoNotOptimize(z);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

void BM_fit_lsc(benchmark::State& state) {
  const Trace& t = trace(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    circtest::Circle c = circtest::fit_lsc(t.a, t.b);
    benchmark::DoNotOptimize(c);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

void BM_fit_mcc(benchmark::State& state) {
  const Trace& t = trace(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    circtest::ContactCircle c = circtest::fit_mcc(t.a, t.b);
    benchmark::DoNotOptimize(c);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

void BM_fit_mic(benchmark::State& state) {
  const Trace& t = trace(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    circtest::MicFit c = circtest::fit_mic(t.a, t.b);
    benchmark::DoNotOptimize(c);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// One pass that only reads the points: the memory-bandwidth floor for any exact fit.
void BM_read_pass(benchmark::State& state) {
  const Trace& t = trace(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    double hi = 0.0;
    const std::size_t n = t.a.size();
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = t.a[i] - 310.0, dy = t.b[i] + 120.0;
      hi = std::max(hi, dx * dx + dy * dy);
    }
    benchmark::DoNotOptimize(hi);
  }
}

BENCHMARK(BM_fit_mzc)->Arg(100000)->Arg(1000000)->Arg(10000000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_fit_lsc)->Arg(100000)->Arg(1000000)->Arg(10000000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_fit_mcc)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_fit_mic)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_read_pass)->Arg(100000)->Arg(1000000)->Arg(10000000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
