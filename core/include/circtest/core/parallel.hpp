#pragma once
// Work shared out over a few threads: how many to use, and a bounded pool that runs a list of
// independent tasks and reports their errors as a single-threaded run would.
#include <cstddef>
#include <functional>

namespace circtest {

struct ThreadCountRequest {
  // 0: one per core; 1: the calling thread alone; n: at most n.
  unsigned asked = 0;
  // The size of the work (samples, bytes, tasks) and the least that is worth a second thread:
  // below it, a thread costs more than it saves.
  std::size_t work = 0;
  std::size_t min_work = 0;
  // Never more than this, asked or not.
  unsigned max_threads = 64;
  // An asked count is capped by the cores too (otherwise only by max_threads).
  bool asked_within_cores = true;
  // With asked = 0, one per core the load average leaves idle: on a machine that is already
  // busy, threads only fight over the cores.
  bool idle_cores_only = false;
};

// The number of threads (at least 1) for the request.
unsigned thread_count(const ThreadCountRequest& request);

// The cores this process may run on (at least 1), read once.
unsigned core_count();

// Calls task(0) .. task(n - 1), each once, on up to `threads` threads counting the calling one
// (0 counts as 1), never more threads than tasks: with n = 0 nothing runs and no thread starts.
// When the system refuses a thread, the ones started share the rest. A task's exception does
// not stop the others before it; after all have joined, the first failed task in task order
// has its exception rethrown, so the error is the one a single-threaded run reports (tasks
// after a failed one may be skipped: their results are not used). Returns the number of threads
// that ran, this one included (0 for no task).
unsigned run_tasks(std::size_t n, unsigned threads, const std::function<void(std::size_t)>& task);

// fn(lo, hi, b) for every block b = [lo, hi) of [0, n) of `block` items (the last one
// shorter), as tasks of run_tasks: blocks are fixed whatever the thread count, so results
// combined per block in block order do not depend on it.
template <class F>
unsigned for_blocks(std::size_t n, std::size_t block, unsigned threads, F&& fn) {
  if (block == 0) block = 1;
  const std::size_t blocks = n / block + (n % block != 0 ? 1 : 0);
  return run_tasks(blocks, threads, [&](std::size_t b) {
    const std::size_t lo = b * block;
    fn(lo, lo + block < n ? lo + block : n, b);
  });
}

}  // namespace circtest
