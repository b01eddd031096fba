#include "circtest/core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <limits>
#include <system_error>
#include <thread>
#include <vector>

namespace circtest {

unsigned core_count() {
  static const unsigned cores = std::max(std::thread::hardware_concurrency(), 1u);
  return cores;
}

unsigned thread_count(const ThreadCountRequest& request) {
  const unsigned cap = std::max(request.max_threads, 1u);
  if (request.asked == 1 || request.work < request.min_work) return 1;
  const unsigned cores = std::min(core_count(), cap);
  if (request.asked != 0) return std::min(request.asked, request.asked_within_cores ? cores : cap);
  if (!request.idle_cores_only) return cores;
  double load = 0.0;
  if (::getloadavg(&load, 1) != 1) return cores;
  const double idle = static_cast<double>(cores) - load + 1.0;  // this process counts itself
  // Rounded, not truncated: a run of this program alone keeps the load near 1, which must still
  // leave both cores of two (1.9 idle is two, 1.4 is one).
  return static_cast<unsigned>(std::clamp(std::round(idle), 1.0, static_cast<double>(cores)));
}

namespace {

// A worker's first failure. Each worker takes its tasks in increasing order, so its first
// failure is its lowest-numbered one; the lowest of all workers' is the first in task order.
struct Failure {
  std::size_t task = std::numeric_limits<std::size_t>::max();
  std::exception_ptr error;
};

}  // namespace

unsigned run_tasks(std::size_t n, unsigned threads, const std::function<void(std::size_t)>& task) {
  // No task, no thread (an extra-thread count of min(threads, n) - 1 wraps around at n = 0: it
  // once started threads until the system refused).
  if (n == 0) return 0;
  const std::size_t workers = std::min<std::size_t>(std::max(threads, 1u), n);
  std::vector<Failure> failures(workers);
  std::atomic<std::size_t> next{0};
  // Tasks after the first failure known so far need not run: their results are thrown away.
  std::atomic<std::size_t> first_failed{std::numeric_limits<std::size_t>::max()};
  auto drain = [&](Failure& mine) noexcept {
    for (std::size_t i; (i = next.fetch_add(1, std::memory_order_relaxed)) < n;) {
      if (i > first_failed.load(std::memory_order_relaxed)) break;
      try {
        task(i);
      } catch (...) {
        mine.task = i;
        mine.error = std::current_exception();
        std::size_t seen = first_failed.load(std::memory_order_relaxed);
        while (i < seen && !first_failed.compare_exchange_weak(seen, i)) {
        }
        break;
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  try {
    for (std::size_t k = 1; k < workers; ++k) pool.emplace_back(drain, std::ref(failures[k]));
  } catch (const std::system_error&) {
    // No more threads to be had: the ones started and this one share the rest.
  }
  drain(failures[0]);
  for (auto& t : pool) t.join();
  const auto first =
      std::min_element(failures.begin(), failures.end(),
                       [](const Failure& a, const Failure& b) { return a.task < b.task; });
  if (first->error) std::rethrow_exception(first->error);
  return static_cast<unsigned>(pool.size() + 1);
}

}  // namespace circtest
