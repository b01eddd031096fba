// The realtime cost of circlog: Producer::step per servo period (the body of the HAL
// function circlog.0), recording 8 channels with a reader attached. The consumer drains
// the ring outside the timed region, as circlog-record does in its own process.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <memory>
#include <vector>

#include "circlog_kernel.hpp"

namespace {

namespace circlog = circtest::circlog;

struct FreeDeleter {
  void operator()(void* p) const { std::free(p); }
};

void step_benchmark(benchmark::State& state, bool enabled) {
  const int channels = static_cast<int>(state.range(0));
  const int depth = circlog::kDefaultDepth;
  const std::size_t bytes = circlog::shared_size(channels, depth);
  std::unique_ptr<void, FreeDeleter> memory(std::aligned_alloc(64, (bytes + 63) / 64 * 64));
  circlog::Producer producer;
  circlog::Consumer consumer;
  if (!producer.init(memory.get(), bytes, channels, depth) ||
      consumer.attach(memory.get(), bytes) != circlog::AttachResult::ok || consumer.claim(1)) {
    state.SkipWithError("ring setup failed");
    return;
  }
  std::vector<double> values(static_cast<std::size_t>(channels), 1.5);
  std::vector<const volatile double*> pins(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) pins[i] = &values[i];
  std::vector<unsigned char> buffer(consumer.record_size() * 4096);
  int n = 0;
  for (auto _ : state) {
    producer.step(enabled, 1.0, pins.data(), 1000000);
    if (++n == 4096) {
      state.PauseTiming();
      while (consumer.read(buffer.data(), 4096) > 0) {
      }
      n = 0;
      state.ResumeTiming();
    }
  }
  if (producer.status().overruns != 0) state.SkipWithError("the ring overflowed");
  state.counters["overruns"] = static_cast<double>(producer.status().overruns);
}

void BM_StepRecording(benchmark::State& state) {
  step_benchmark(state, true);
}
void BM_StepDisabled(benchmark::State& state) {
  step_benchmark(state, false);
}

BENCHMARK(BM_StepRecording)->Arg(1)->Arg(8)->Arg(16);
BENCHMARK(BM_StepDisabled)->Arg(8);

}  // namespace

BENCHMARK_MAIN();
