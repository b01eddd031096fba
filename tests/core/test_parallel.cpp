#include "circtest/core/parallel.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace circtest {
namespace {

TEST(Parallel, NoTaskRunsNothingAndStartsNoThread) {
  for (unsigned threads : {0u, 1u, 2u, 64u, ~0u}) {
    std::atomic<int> calls{0};
    EXPECT_EQ(run_tasks(0, threads, [&](std::size_t) { ++calls; }), 0u) << threads;
    EXPECT_EQ(calls.load(), 0);
    EXPECT_EQ(for_blocks(0, 16, threads, [&](std::size_t, std::size_t, std::size_t) { ++calls; }),
              0u);
    EXPECT_EQ(calls.load(), 0);
  }
}

TEST(Parallel, EveryTaskRunsOnceOnNoMoreThreadsThanTasks) {
  for (std::size_t n : {1u, 2u, 7u, 1000u}) {
    for (unsigned threads : {1u, 2u, 3u, 64u}) {
      std::vector<std::atomic<int>> runs(n);
      std::mutex mutex;
      std::set<std::thread::id> ids;
      const unsigned used = run_tasks(n, threads, [&](std::size_t i) {
        ++runs[i];
        const std::lock_guard lock(mutex);
        ids.insert(std::this_thread::get_id());
      });
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(runs[i].load(), 1) << n << " " << threads;
      // As many as asked, or as tasks if fewer (the system refuses none here).
      EXPECT_EQ(used, std::min<std::size_t>(threads, n));
      EXPECT_LE(ids.size(), used);
    }
  }
}

TEST(Parallel, BlocksCoverTheRangeOnce) {
  for (std::size_t n : {1u, 15u, 16u, 17u, 1000u}) {
    std::vector<std::atomic<int>> hits(n);
    std::vector<std::atomic<int>> block_calls(n / 16 + 1);
    for_blocks(n, 16, 3, [&](std::size_t lo, std::size_t hi, std::size_t b) {
      EXPECT_EQ(lo, b * 16);
      EXPECT_EQ(hi, std::min(n, lo + 16));
      ++block_calls[b];
      for (std::size_t i = lo; i < hi; ++i) ++hits[i];
    });
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(hits[i].load(), 1) << n << " " << i;
    for (std::size_t b = 0; b < (n + 15) / 16; ++b) EXPECT_EQ(block_calls[b].load(), 1);
  }
}

// Tasks 5, 40 and 41 fail; whatever the thread count and whichever finishes first, the error
// is task 5's, as in a run on one thread.
TEST(Parallel, FirstErrorInTaskOrderIsRethrown) {
  for (unsigned threads : {1u, 2u, 3u, 64u}) {
    for (int repeat = 0; repeat < 20; ++repeat) {
      try {
        run_tasks(100, threads, [&](std::size_t i) {
          if (i == 40 || i == 41) throw std::runtime_error("task " + std::to_string(i));
          // Task 5 fails last in time when other threads run.
          if (i == 5) {
            if (threads > 1) std::this_thread::sleep_for(std::chrono::milliseconds(2));
            throw std::invalid_argument("task 5");
          }
        });
        ADD_FAILURE() << "no error rethrown";
      } catch (const std::invalid_argument& e) {
        EXPECT_STREQ(e.what(), "task 5");
      } catch (const std::exception& e) {
        ADD_FAILURE() << threads << " threads rethrew " << e.what();
      }
    }
  }
}

TEST(Parallel, EveryTaskBeforeTheFirstFailureRuns) {
  std::vector<std::atomic<int>> runs(200);
  EXPECT_THROW(run_tasks(200, 3,
                         [&](std::size_t i) {
                           ++runs[i];
                           if (i == 150) throw std::runtime_error("150");
                         }),
               std::runtime_error);
  for (std::size_t i = 0; i <= 150; ++i) EXPECT_EQ(runs[i].load(), 1) << i;
}

// A sum per block, combined in block order: the same bits on 1 and 3 threads.
TEST(Parallel, ResultsIdenticalForOneAndThreeThreads) {
  std::vector<double> x(100000);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = std::sin(0.37 * static_cast<double>(i)) * 1e3;
  auto sum = [&](unsigned threads) {
    std::vector<double> part(x.size() / 1000 + 1, 0.0);
    const unsigned used =
        for_blocks(x.size(), 1000, threads, [&](std::size_t lo, std::size_t hi, std::size_t b) {
          for (std::size_t i = lo; i < hi; ++i) part[b] += x[i] * x[i];
        });
    double total = 0.0;
    for (double p : part) total += p;
    return std::pair{total, used};
  };
  const auto [one, one_used] = sum(1);
  const auto [three, three_used] = sum(3);
  EXPECT_EQ(one_used, 1u);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(one), std::bit_cast<std::uint64_t>(three));
}

TEST(Parallel, ThreadCount) {
  const unsigned cores = core_count();
  EXPECT_GE(cores, 1u);
  EXPECT_EQ(thread_count({.asked = 1, .work = 1000}), 1u);
  EXPECT_EQ(thread_count({.asked = 0, .work = 99, .min_work = 100}), 1u);
  EXPECT_EQ(thread_count({.asked = 0, .work = 100, .min_work = 100}), std::min(cores, 64u));
  EXPECT_EQ(thread_count({.asked = 0, .max_threads = 1}), 1u);
  EXPECT_EQ(thread_count({.asked = 0, .max_threads = 0}), 1u);
  EXPECT_EQ(thread_count({.asked = 500}), std::min(cores, 64u));
  EXPECT_EQ(thread_count({.asked = 500, .asked_within_cores = false}), 64u);
  EXPECT_EQ(thread_count({.asked = 3, .max_threads = 2, .asked_within_cores = false}), 2u);
  const unsigned idle = thread_count({.idle_cores_only = true});
  EXPECT_GE(idle, 1u);
  EXPECT_LE(idle, std::min(cores, 64u));
}

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define CIRCTEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define CIRCTEST_SANITIZED 1
#endif
#endif

#ifndef CIRCTEST_SANITIZED
long vm_size_kib() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmSize:", 0) == 0) return std::strtol(line.c_str() + 7, nullptr, 10);
  }
  return -1;
}
#endif

#ifndef CIRCTEST_SANITIZED
// In a child process: with 2 MiB more address space than in use, less than one thread stack
// (8 MiB by default), every thread creation fails; exits 0 when all tasks ran once, on this
// thread alone.
[[noreturn]] void run_without_room_for_threads() {
  const long kib = vm_size_kib();
  if (kib <= 0) std::_Exit(3);
  const auto bytes = static_cast<rlim_t>(kib + 2048) * 1024;
  const rlimit limit{bytes, bytes};
  if (::setrlimit(RLIMIT_AS, &limit) != 0) std::_Exit(4);
  std::vector<int> runs(100, 0);
  const unsigned used = run_tasks(100, 8, [&](std::size_t i) { ++runs[i]; });
  for (int r : runs) {
    if (r != 1) std::_Exit(5);
  }
  std::_Exit(used == 1 ? 0 : 6);
}
#endif

// Thread creation throws std::system_error when the system refuses: the calling thread then
// runs every task itself.
TEST(Parallel, SurvivesTheSystemRefusingThreads) {
#ifdef CIRCTEST_SANITIZED
  GTEST_SKIP() << "sanitizers reserve address space beyond any limit set here";
#else
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(run_without_room_for_threads(), ::testing::ExitedWithCode(0), "");
#endif
}

}  // namespace
}  // namespace circtest
