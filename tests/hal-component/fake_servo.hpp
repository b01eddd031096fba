#pragma once
// A servo thread without HAL for circlog-record's loop: a producer in heap memory runs the
// servo periods that pass while the recorder sleeps, on a fake clock (1 kHz).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "circlog_kernel.hpp"
#include "recorder.hpp"
#include "scratch.hpp"

namespace circtest::testing {

namespace rec = circtest::circlog_record;
namespace fs = std::filesystem;

struct FreeDeleter {
  void operator()(void* p) const { std::free(p); }
};

// The servo thread at 1 kHz; enable and segment follow a script of the period number.
class FakeServo final : public rec::Environment {
 public:
  FakeServo(int channels, int depth)
      : bytes_(circtest::circlog::shared_size(channels, depth)),
        memory_(std::aligned_alloc(64, (bytes_ + 63) / 64 * 64)),
        values_(static_cast<std::size_t>(channels)),
        pointers_(static_cast<std::size_t>(channels)) {
    for (std::size_t i = 0; i < values_.size(); ++i) pointers_[i] = &values_[i];
    EXPECT_TRUE(producer_.init(memory_.get(), bytes_, channels, depth));
    EXPECT_EQ(consumer.attach(memory_.get(), bytes_), circtest::circlog::AttachResult::ok);
  }

  std::function<bool(std::uint64_t)> enable = [](std::uint64_t) { return false; };
  std::function<double(std::uint64_t)> segment = [](std::uint64_t) { return 0.0; };
  bool running = true;
  int stop_after_sleeps = -1;
  std::vector<std::int32_t> alive;

  void run_periods(std::uint64_t n) {
    for (std::uint64_t i = 0; i < n; ++i) {
      for (std::size_t c = 0; c < values_.size(); ++c) {
        values_[c] = static_cast<double>(period_) + 0.001 * static_cast<double>(c);
      }
      producer_.step(enable(period_), segment(period_), pointers_.data(), 1000000);
      ++period_;
    }
  }

  // Called at each sleep of the recorder, after the periods that passed have run.
  std::function<void()> on_sleep;

  void sleep(double seconds) override {
    ++sleeps_;
    const double before = now_;
    now_ += seconds;
    if (running) {
      run_periods(static_cast<std::uint64_t>(std::floor(now_ * 1000.0)) -
                  static_cast<std::uint64_t>(std::floor(before * 1000.0)));
    }
    if (on_sleep) on_sleep();
  }
  double monotonic_s() override { return now_; }
  bool stop_requested() override { return stop_after_sleeps >= 0 && sleeps_ >= stop_after_sleeps; }
  bool process_alive(std::int32_t pid) override {
    return std::find(alive.begin(), alive.end(), pid) != alive.end();
  }
  std::string utc_now_iso8601() override { return "2026-01-02T03:04:05.000Z"; }

  circtest::circlog::Consumer consumer;
  circtest::circlog::Status status() const { return producer_.status(); }

 private:
  std::size_t bytes_;
  std::unique_ptr<void, FreeDeleter> memory_;
  std::vector<double> values_;
  std::vector<const volatile double*> pointers_;
  circtest::circlog::Producer producer_;
  std::uint64_t period_ = 0;
  double now_ = 0.0;
  int sleeps_ = 0;
};

class Recorder : public ::testing::Test {
 protected:
  void SetUp() override { log_ = std::tmpfile(); }
  void TearDown() override { std::fclose(log_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string log_text() {
    std::rewind(log_);
    std::string s;
    char buf[256];
    while (std::fgets(buf, sizeof buf, log_)) s += buf;
    return s;
  }

  circtest::testing::ScratchDir scratch_{"circlog-recorder-test"};
  fs::path dir_ = scratch_.dir();
  std::FILE* log_ = nullptr;
};

}  // namespace circtest::testing
