#pragma once
// Feedback on long work for the person at a terminal: one status line on stderr, redrawn in
// place. It appears only when the stream is a terminal and only once the work has run longer
// than a delay (1 s; CIRCTEST_PROGRESS_AFTER_S sets another), so piped or redirected output
// and short commands never carry it. Other messages to the same stream first call clear().
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>

namespace circtest {

// Whether STREAM is a terminal.
bool is_terminal(std::FILE* stream) noexcept;

// The delay before a status line appears: CIRCTEST_PROGRESS_AFTER_S when it is a number of
// seconds from 0 to 3600, else 1 s.
double progress_delay_s() noexcept;

// A status line drawn on demand, with the caller's monotonic clock (a recorder's fake clock in
// its tests). Not thread-safe; ProgressTicker adds the lock.
class ProgressLine {
 public:
  // Draws on STREAM when ENABLED, once NOW_S - START_S exceeds DELAY_S, at most every
  // INTERVAL_S.
  ProgressLine(std::FILE* stream, std::string prefix, bool enabled, double start_s,
               double delay_s = progress_delay_s(), double interval_s = 0.2);
  ~ProgressLine();
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  // The status at NOW_S: "PREFIX: TEXT" replaces the line, when due.
  void update(double now_s, std::string_view text);
  // Erases the line (before another message, and when the work ends).
  void clear();
  bool enabled() const noexcept { return enabled_; }

 private:
  std::FILE* stream_;
  std::string prefix_;
  bool enabled_;
  double start_s_;
  double delay_s_;
  double interval_s_;
  double last_draw_s_ = -1.0;
  bool drawn_ = false;
  std::string last_text_;
};

// A status line kept up by its own thread for work that runs in one long call (reading a
// large trace, fitting): "circana analyze: reading run.csv (3 s)". The stage is set by the
// working thread; the line goes when the ticker is destroyed (also by an exception, before
// the error message is printed). Shown on stderr when it is a terminal.
class ProgressTicker {
 public:
  explicit ProgressTicker(std::string prefix, std::FILE* stream = stderr);
  ProgressTicker(std::string prefix, std::FILE* stream, bool enabled);
  ~ProgressTicker();
  ProgressTicker(const ProgressTicker&) = delete;
  ProgressTicker& operator=(const ProgressTicker&) = delete;

  void stage(std::string text);

 private:
  void tick();
  void draw();  // with mutex_ held
  std::mutex mutex_;
  std::condition_variable wake_;
  std::string stage_;
  bool stop_ = false;
  double start_s_;
  ProgressLine line_;
  std::thread thread_;
};

}  // namespace circtest
