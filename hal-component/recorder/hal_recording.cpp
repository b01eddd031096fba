// circlog-record's HAL side (record_from_hal): a userspace HAL component that maps the ring
// circlog created, around the HAL-free loop in recorder.cpp. Linked only into circlog-record.
extern "C" {
#include "hal.h"
}

#include <sys/ipc.h>
#include <sys/shm.h>
#include <unistd.h>

#include <fmt/format.h>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "circlog_kernel.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/utc_time.hpp"
#include "recorder.hpp"

namespace {

using circtest::HalError;

volatile std::sig_atomic_t g_stop = 0;

void on_signal(int) {
  g_stop = 1;
}

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  for (int s : {SIGINT, SIGTERM, SIGHUP}) sigaction(s, &sa, nullptr);
}

class SystemEnvironment final : public circtest::circlog_record::Environment {
 public:
  void sleep(double seconds) override {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(seconds);
    ts.tv_nsec = static_cast<long>((seconds - static_cast<double>(ts.tv_sec)) * 1e9);
    nanosleep(&ts, nullptr);  // a signal cuts it short, which is what we want
  }
  double monotonic_s() override {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
  }
  bool stop_requested() override { return g_stop != 0; }
  bool process_alive(std::int32_t pid) override { return kill(pid, 0) == 0 || errno == EPERM; }
  std::string utc_now_iso8601() override { return circtest::utc_now_iso8601(true); }
};

// The HAL component and the mapping of circlog's ring; both undone in the destructor.
class HalRing {
 public:
  HalRing() {
    // The ring first, with plain shmget: rtapi_shmem_new would create an empty ring when
    // circlog is not loaded, and hal_init succeeds (creating HAL's memory) even when no
    // realtime session runs at all.
    shm_id_ = shmget(circtest::circlog::kShmKeyBase, 0, 0);
    if (shm_id_ < 0) {
      const int e = errno;
      if (e == ENOENT) {
        throw HalError(
            "circlog is not loaded (is LinuxCNC or halrun running?): 'loadrt circlog "
            "channels=N' and 'addf circlog.0 servo-thread' in the HAL file");
      }
      throw HalError(fmt::format("cannot open circlog's ring (key 0x{:08x}): {}{}",
                                 circtest::circlog::kShmKeyBase, std::strerror(e),
                                 e == EACCES ? " (run as the user that runs LinuxCNC)" : ""));
    }
    const std::string name = fmt::format("circlog-record-{}", getpid());
    comp_id_ = hal_init(name.c_str());
    if (comp_id_ < 0) {
      throw HalError("HAL is not running: start LinuxCNC (or halrun) and 'loadrt circlog' first");
    }
    shmid_ds stat{};
    void* mem = shmat(shm_id_, nullptr, 0);
    if (mem == reinterpret_cast<void*>(-1) || shmctl(shm_id_, IPC_STAT, &stat) != 0) {
      const int e = errno;
      cleanup();
      throw HalError(fmt::format("cannot map circlog's ring: {}", std::strerror(e)));
    }
    memory_ = mem;
    if (stat.shm_nattch < 2) {
      // Only this process: the ring was left behind by a recorder that outlived the module.
      cleanup();
      throw HalError(
          "circlog is not loaded (only a stale ring from an earlier run was found; "
          "it has been removed)");
    }
    const auto result = ring_.attach(mem, stat.shm_segsz);
    if (result != circtest::circlog::AttachResult::ok) {
      cleanup();
      throw HalError(
          fmt::format("circlog's ring: {}", circtest::circlog::attach_result_text(result)));
    }
    hal_ready(comp_id_);
  }
  ~HalRing() { cleanup(); }
  HalRing(const HalRing&) = delete;
  HalRing& operator=(const HalRing&) = delete;

  circtest::circlog::Consumer& ring() { return ring_; }

 private:
  void cleanup() {
    if (memory_) {
      shmdt(memory_);
      memory_ = nullptr;
      // If circlog was unloaded while we held the ring, nobody else will remove it, and a
      // later circlog with a larger ring could not be created.
      shmid_ds stat{};
      if (shm_id_ >= 0 && shmctl(shm_id_, IPC_STAT, &stat) == 0 && stat.shm_nattch == 0) {
        shmctl(shm_id_, IPC_RMID, nullptr);
      }
    }
    if (comp_id_ >= 0) hal_exit(comp_id_);
    comp_id_ = -1;
  }

  int comp_id_ = -1;
  int shm_id_ = -1;
  void* memory_ = nullptr;
  circtest::circlog::Consumer ring_;
};

}  // namespace

namespace circtest::circlog_record {

void record_from_hal(const RecordRequest& request) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> progress(
      request.progress_to.empty() ? nullptr : open_progress_terminal(request.progress_to),
      &std::fclose);
  install_signal_handlers();
  HalRing hal;
  SystemEnvironment env;
  const Summary s =
      record(hal.ring(), static_cast<std::int32_t>(getpid()), request, env, stderr, progress.get());
  std::fprintf(stderr,
               "circlog-record: %s: %zu rows, %llu run(s), %llu overrun(s), %llu gap(s), "
               "%llu lost sample(s); stopped by %s\n",
               request.output.c_str(), s.rows, static_cast<unsigned long long>(s.runs),
               static_cast<unsigned long long>(s.overruns), static_cast<unsigned long long>(s.gaps),
               static_cast<unsigned long long>(s.lost), s.stop_reason.c_str());
  std::vector<std::string> problems;
  if (s.lost > 0 || s.overruns > 0) {
    problems.push_back(
        fmt::format("{} sample(s) lost ({} overrun(s), {} gap(s))", s.lost, s.overruns, s.gaps));
  }
  if (!s.missing_runs.empty()) {
    problems.push_back(fmt::format("run(s) announced by {} missing: {}", request.program,
                                   join(s.missing_runs, "; ")));
  }
  if (!problems.empty()) {
    throw Error(ExitCode::data_loss,
                fmt::format("{}; {} is complete up to where it stopped ({})", join(problems, "; "),
                            request.output, s.stop_reason));
  }
}

}  // namespace circtest::circlog_record
